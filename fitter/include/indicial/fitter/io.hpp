// indicial/fitter/io.hpp -- everything the tools read from and write to disk, by layer.
//
// What it is for
// --------------
// One include for the input/output layer. The parts live in their own headers:
//   csv_reader.hpp       run CSVs and static tables (tolerant dialects, units, checks)
//   derivative.hpp       Savitzky-Golay differentiation (numerics, no I/O)
//   experiment_toml.hpp  experiment files: load_experiment, write_experiment_toml, enum names
// and this header adds the writers of run CSVs and the number format they share.
// Everything read is validated once, where it enters: a problem is an indicial::InputError
// whose message names the file, the line and the problem.
//
// Usage
// -----
//   indicial::Experiment e = indicial::load_experiment("experiment.toml");  // runs included
//   std::string csv = indicial::write_run_csv({{"time_s", t}, {"alpha_deg", a}}, {"comment"});
//
// Warnings
// --------
// 1. write_run_csv writes commas, '.' decimals and no quotes: the canonical dialect every
//    reader accepts. A column name must carry its unit suffix (docs/formats.md).
// 2. format_double is the shortest text that reads back to the same double, not a fixed
//    precision: do not use it for human-facing tables.
#pragma once

#include <string>
#include <vector>

#include "indicial/fitter/csv_reader.hpp"
#include "indicial/fitter/derivative.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/experiment_toml.hpp"

namespace indicial {

struct CsvColumn {
  std::string name;             // with its unit suffix: time_s, alpha_deg, q_degps, Cm, ...
  std::vector<double> values;   // all columns the same length
};

// A run CSV as text: the comment lines (each prefixed "# "), the header, one row per sample,
// numbers in the shortest form that reads back to the same double.
std::string write_run_csv(const std::vector<CsvColumn>& columns,
                          const std::vector<std::string>& comment_lines);

// Shortest decimal text that reads back to exactly v (std::to_chars).
std::string format_double(double v);

}  // namespace indicial
