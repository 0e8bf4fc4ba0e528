// indicial/fitter/experiment_checks.hpp -- the checks of an experiment's configuration that do
// not depend on where it came from, written once and called by both front ends: the
// experiment file's reader (experiment_toml.cpp, which names a key by its file and line) and
// Python's Experiment(...) (python/src/experiment_binding.cpp, which names the keyword). One
// set of rules and one set of messages; the caller only says how a key is spelled and where
// it was given (KeySite, TableSite).
//
//  * a static table (or a lift polar): at least 2 rows, at most FitCapacity::max_table_points,
//    angles strictly increasing (finite numbers are each reader's own: a CSV field is parsed,
//    an array is scanned), and covering the runs' model-angle range;
//  * model.delay_start_s: in [0, 1] s, and only with delay = "estimated";
//  * the dynamic-stall keys (StallConfig): every stall_* key only with stall; the start values'
//    ranges; stall_known's names, the vortex's names only with the vortex, finite values in the
//    runtime's feasible set, never beside a start value of the same parameter; the polar's
//    default (the static table, when the experiment models the polar's column).
#pragma once

#include <cstddef>
#include <functional>
#include <set>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment.hpp"

namespace indicial {

// How a front end spells a key and reports a problem with it. Keys are given by their [model]
// names ("stall_T1_start", "delay_start_s"; an entry of stall_known as "stall_known.T1").
//  * name(key): the key as the user wrote it ("model.stall_T1_start" in the file,
//    "stall_T1_start" in Python);
//  * fail(key, problem): throws the InputError (with the key's file:line, or as is).
struct KeySite {
  std::function<std::string(const std::string& key)> name;
  std::function<void(const std::string& key, const std::string& problem)> fail;
  [[noreturn]] void raise(const std::string& key, const std::string& problem) const;
};

// Where a table's rows came from. error(row, problem): the InputError for row `row` (0-based;
// npos: the table as a whole); angle_text(row): the row's angle as the user gave it (the CSV
// field, or the array's number).
struct TableSite {
  std::function<InputError(std::size_t row, const std::string& problem)> error;
  std::function<std::string(std::size_t row)> angle_text;
};

// Degrees for messages: 6 significant digits (59.99999999999999 reads as 60).
std::string deg_text(double rad);

// A static table or lift polar of x_rad (rad) and value: equal lengths, 2..max_table_points
// rows, x strictly increasing.
void check_static_table(const std::vector<double>& x_rad, const std::vector<double>& value, const TableSite& site);

// The problem when e's static table does not cover the runs' model-angle range
// (e.data_x_min_rad .. e.data_x_max_rad, within 1e-9 rad of rounding); "" when it does or the
// static curve is a polynomial.
std::string static_table_coverage_problem(const Experiment& e);

// model.delay and delay_start_s (`start_given`: the key was given).
void check_delay_keys(const ModelConfig& m, bool start_given, const KeySite& site);

// The stall keys given (their [model] names: "stall_T1_start", "stall_known", ...; "stall"
// itself need not be listed) with their values read into s (s.known by name, unchecked).
void check_stall_keys(const StallConfig& s, const std::set<std::string>& given, const KeySite& site);

// The stall families' lift polar when none was given: the static table, when the experiment
// models the polar's column (s.polar_column). False when that is not so (the caller reports
// it, naming its own keys for the polar).
bool stall_polar_from_static_table(const Experiment& e, StallConfig& s);

}  // namespace indicial
