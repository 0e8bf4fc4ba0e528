// indicial/fitter/csv_reader.hpp -- reading run CSVs and static tables.
//
// What it is for
// --------------
// Every CSV the fitter, diagnose and predict read enters through here, and every check on it
// happens here, once: a problem is an indicial::InputError whose message names the file, the
// line and the problem ("run_f0.25.csv:14: time_s is not strictly increasing (0.13 after
// 0.13)"). Downstream code may assume what is validated here: strictly increasing (and, unless
// declared otherwise, uniform) time; finite values; angles in rad and rates in rad/s.
//
// Usage
// -----
//   indicial::Run run = indicial::read_run_csv("run.csv", indicial::Axis::pitch, "Cm",
//                                              indicial::CoefficientPresence::required);
//
// Format (docs/formats.md): one header row; '#' comment lines and blank lines anywhere are
// skipped; the unit is part of each column name: time_s (or phase_rad | phase_deg: one
// ensemble-averaged cycle, with RunCsvOptions::frequency_hz); the motion angle alpha_deg |
// alpha_rad (pitch), phi_deg | phi_rad (roll), psi_deg | psi_rad (yaw); the optional rate
// q_degps | q_radps, p_... , r_...; coefficients CL, Cm, CD, CY, Cl, Cn.
// Dialects: the delimiter is the most frequent of tab, ';' and ',' in the header line; a UTF-8
// byte-order mark is dropped; double quotes around a name or cell are removed. With ';' or tab
// delimiters a cell with one ',' and no '.' is a decimal comma ("0,25" = 0.25; a note says
// so); with ',' delimiters it cannot occur (the cell would be split).
//
// Warnings
// --------
// 1. A column whose base name is an angle, a rate, time or phase (alpha, beta, phi, psi, theta,
//    q, p, r, time, phase) and whose suffix is missing or names a unit we do not read (alpha,
//    alpha_grad, q_dps, time_ms) is refused: a unit must never be guessed. Any other column
//    the reader does not use is ignored: silently when it is one we write (coefficients,
//    Cm_true, y_true, Cm_pred, other axes' angles), with a note in Run::notes otherwise
//    (q_pa, r_m, alpha_cmd_deg, AoA).
// 2. When a run has no rate column, the rate is the Savitzky-Golay derivative of the angle
//    (derivative.hpp); with fewer than ~20 samples per cycle it is biased.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"

namespace indicial {

// Whether read_run_csv insists on the coefficient column (the fitter) or not (predict, the
// simulator's csv: motion).
enum class CoefficientPresence { required, optional };

// Fewest data rows a run may have: one Savitzky-Golay window (2 * 5 + 1 samples).
inline constexpr int min_run_samples = 11;

// The experiment's [columns] table: our column name -> the file's name ("alpha_deg" -> "AoA").
// A mapping whose file column is absent is ignored (the missing-column message says so).
using ColumnMap = std::map<std::string, std::string>;

struct RunCsvOptions {
  // uniform: the step must be uniform within 1e-6 relative, or within half a unit of the last
  // printed digit of the time (phase) column, in which case the times are snapped to the
  // uniform grid (a note says so); a phase column that is not uniform even so becomes
  // nonuniform, a time column is refused. nonuniform (declared): no step check.
  TimeGrid grid = TimeGrid::uniform;
  ColumnMap columns;
  double frequency_hz = 0.0;  // the cycle's frequency; required by a phase column
};

// Reads one run. `coefficient` is the column to load (e.g. "Cm"); with
// CoefficientPresence::optional an absent coefficient column leaves Run::coefficient empty.
// Angles are converted to rad, rates to rad/s. Run::path is `path` as given. With
// TimeGrid::nonuniform the step is not checked (time must still strictly increase), Run::dt_s()
// means nothing, and an absent rate column is derived by smooth_derivative_nonuniform.
// Run::time_grid is the grid found (see RunCsvOptions::grid), Run::notes what the reader
// noted (ignored columns, dialect, snapped times).
Run read_run_csv(const std::string& path, Axis axis, const std::string& coefficient,
                 CoefficientPresence presence, const RunCsvOptions& options);
Run read_run_csv(const std::string& path, Axis axis, const std::string& coefficient,
                 CoefficientPresence presence, TimeGrid grid = TimeGrid::uniform);

// Reads a static table (columns alpha_* in pitch or beta_* in roll/yaw, plus `coefficient`)
// into config.table_x_rad / table_value. Used by load_experiment.
void read_static_table(const std::string& path, Axis axis, const std::string& coefficient,
                       StaticConfig& config, const ColumnMap& columns = {});

}  // namespace indicial
