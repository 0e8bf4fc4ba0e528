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
//  * a spline's knots: strictly increasing, at most FitCapacity::max_knots, each strictly
//    inside the runs' model-angle range;
//  * model.delay_start_s: in [0, 1] s, and only with delay = "estimated";
//  * the dynamic-stall keys (StallConfig): stall only in pitch; every stall_* key only with
//    stall; the start values' ranges; stall_known's names, the vortex's names only with the
//    vortex, finite values in the runtime's feasible set, never beside a start value of the same
//    parameter (stall_starts(): the one table of the start-value keys, which both readers,
//    the experiment writer and `indicial init`'s key documentation use); the polar's default
//    (the static table, when the experiment models the polar's column);
//  * the runtime's capacity at input time (check_runtime_capacity): a model larger than
//    indicial::DefaultCapacity is refused, a candidate pool larger than it only warned about.
#pragma once

#include <cstddef>
#include <functional>
#include <set>
#include <optional>
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

// The InputError for entry `index` of a list or row of a table (0-based; npos: the list as a
// whole), with the caller's file and line (or keyword and index).
using EntryError = std::function<InputError(std::size_t index, const std::string& problem)>;

// Where a table's rows came from. error(row, problem): the InputError for row `row`;
// angle_text(row): the row's angle as the user gave it (the CSV field, or the array's number).
struct TableSite {
  EntryError error;
  std::function<std::string(std::size_t row)> angle_text;
};

// Degrees for messages: 6 significant digits (59.99999999999999 reads as 60).
std::string deg_text(double rad);

// Why a run declared periodic (`periodic = true`, `predict --periodic`) with a time column is
// not one cycle: empty when it closes. The fit and predict wrap from its last sample back to
// its first; a record of several cycles, or of a fraction more, jumps there (a user's trial:
// 5.3 cycles, 19.5 -> 6.06 deg in one 2 ms step, predicted without a word). Refused when the
// angle's jump at the wrap exceeds twice the largest step inside the run.
std::string periodic_closure_problem(const Run& run);

// The runs' groups (Run::group): either every run of an experiment has a group or none does (a
// forgotten group would put a run into a fold of its own). A mix: the first run without a group
// and the first run with one (indices into e.runs); otherwise nullopt.
struct GroupMix {
  std::size_t ungrouped = 0;
  std::size_t grouped = 0;
};
std::optional<GroupMix> run_group_mix(const Experiment& e);
// The message for a mix, the runs named as the caller names them.
std::string run_group_mix_problem(const std::string& ungrouped_name, const std::string& grouped_name,
                                  const std::string& group);

// A static table or lift polar of x_rad (rad) and value: equal lengths, 2..max_table_points
// rows, x strictly increasing.
void check_static_table(const std::vector<double>& x_rad, const std::vector<double>& value, const TableSite& site);

// The problem when e's static table does not cover the runs' model-angle range
// (e.data_x_min_rad .. e.data_x_max_rad, within 1e-9 rad of rounding); "" when it does or the
// static curve is a polynomial.
std::string static_table_coverage_problem(const Experiment& e);

// A spline's knots (rad) as given, `key` as the user wrote it ("model.a_knots_deg",
// "a_knots_rad"): strictly increasing, at most FitCapacity::max_knots.
void check_knot_list(const std::vector<double>& knots_rad, const std::string& key, const EntryError& error);

// Each knot strictly inside the runs' model-angle range (e.data_x_min_rad .. e.data_x_max_rad:
// set_data_range first). Why strictly inside: a knot at or beyond the range makes its term
// identically zero or a polynomial on the data, which cannot be identified separately.
void check_knots_in_data(const Experiment& e, const std::vector<double>& knots_rad, const std::string& key,
                         const EntryError& error);

// model.delay and delay_start_s (`start_given`: the key was given).
void check_delay_keys(const ModelConfig& m, bool start_given, const KeySite& site);

// The stall keys given (their [model] names: "stall_T1_start", "stall_known", ...; "stall"
// itself need not be listed) with their values read into s (s.known by name, unchecked), in an
// experiment of `axis` (the families model an airfoil's angle of attack: pitch only).
void check_stall_keys(const StallConfig& s, const std::set<std::string>& given, Axis axis, const KeySite& site);

// Which values a stall start value may take (check_stall_keys).
enum class StartBound { positive, non_negative, angle_to_20_deg };  // the last: (0, 20 deg] in rad

// When a stall start value is used: always (with the families), or only when its parameter is
// estimated at all (T1r: stall_reattachment = "estimated"). Both the reader (refusal) and the
// writer (left out) ask stall_start_used.
enum class StartUse { with_families, with_reattachment_estimated, with_hysteresis_estimated,
                      with_lag_limit_estimated };

// A start value of a dynamic-stall parameter: its [model] key (the same keyword in Python's
// Experiment; docs/formats.md's stall table), the stall_known name of the parameter it
// starts, where StallConfig holds it, its feasible set, unit and default.
struct StallStart {
  const char* key;             // "stall_T1_start"
  const char* parameter;       // "T1"
  double StallConfig::*value;  // &StallConfig::tau1_start (its initialiser is the default)
  StartBound bound;
  const char* unit;            // "l / V" (semichord times) or "C_N"
  const char* default_text;    // nullptr: StallConfig's value; else the default in words
  double example;              // a typical value (`indicial init`'s commented-out line)
  StartUse use = StartUse::with_families;
};

// The one table of the start-value keys, in docs/formats.md's order: T1, T2, CN1, Tv, Tvl, T1r,
// dxr, dxl.
const std::vector<StallStart>& stall_starts();

// Whether v is in the start value's feasible set. A default outside it is "not set" (CN1's 0:
// from the polar), which the experiment writer leaves out.
bool start_in_bound(const StallStart& start, double v);

// Whether the start value is used by the configuration s (StartUse; the families are assumed).
bool stall_start_used(const StallStart& start, const StallConfig& s);

// The [model] key and value a start value needs besides the families (StartUse):
// {"stall_reattachment", "estimated"}; {nullptr, nullptr} for StartUse::with_families.
struct StartCondition {
  const char* key;
  const char* value;
};
StartCondition stall_start_condition(const StallStart& start);

// The [model] key of a stall parameter's start value ("T1" -> "stall_T1_start"); nullptr for a
// parameter without one (k0, k1, k2, cv, xv) or a name that is no stall parameter.
const char* stall_start_key(const std::string& parameter);

// True when s.known holds the parameter whose start value `start_key` gives ("stall_T1_start"
// with T1 held): the start value is then neither accepted nor written.
bool stall_start_held(const StallConfig& s, const std::string& start_key);

// The stall families' lift polar when none was given: the static table, when the experiment
// models the polar's column (s.polar_column), or the table's lift (Experiment::table_lift_polar,
// a Cm experiment whose table has CL, or Cnormal and Ctangential) when that column is CL: the
// polar diagnose offers the families with. False when neither is so (the caller reports it,
// naming its own keys for the polar).
bool stall_polar_from_static_table(const Experiment& e, StallConfig& s);

// A use of one of the runtime's capacities (indicial::DefaultCapacity): `needed` `what`
// against its `limit`, given by `key` as the user wrote it ("model.a_knots_deg" in the file,
// "a_knots_rad" in Python).
struct CapacityUse {
  std::string key;
  std::string what;  // "knots", "powers (x^0..x^n)", "rows", "lags"
  int needed = 0;
  int limit = 0;
  // A candidate pool: model_stepwise is one with structure = "stepwise", rotary_estimate one
  // with rotary.estimate = true; otherwise the terms are all in the model.
  enum class Pool { none, model_stepwise, rotary_estimate } pool = Pool::none;
};

// The one capacity rule of both front ends (issue 12 item 1), before fitting: a use over its
// limit throws error(problem) ("'KEY' needs N WHAT; the runtime (indicial::DefaultCapacity)
// holds at most L"), unless it is a candidate pool of e (the selected model is usually smaller;
// the fit reports if it is not): then e.warnings gets warning_site + problem + ": a candidate
// pool may exceed it, the selected model must not" (warning_site: "FILE:LINE: " or "").
void check_runtime_capacity(const CapacityUse& use, Experiment& e,
                            const std::function<InputError(const std::string& problem)>& error,
                            const std::string& warning_site);

}  // namespace indicial
