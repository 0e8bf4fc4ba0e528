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
// so); with ',' delimiters it cannot occur (the cell would be split). A database's text file
// reads as it is (CsvDialect, docs/formats.md "Database text files"): whitespace-separated
// fields, '%' comments, the column names in the comment line above the first numeric row.
// Lift and drag from body-axis forces: with the coefficient CL or CD absent and the columns
// Cnormal and Ctangential present (after the [columns] map), CL = Cn cos(alpha) + Ct
// sin(alpha), CD = Cn sin(alpha) - Ct cos(alpha) with the run's own alpha (pitch only). Our Cn
// is the yawing moment: a file's unmapped `Cn` beside a chord-force column is refused as the
// coefficient Cn (unless [columns] Cn = "Cn" declares it) and named in the missing-column
// message for CL/CD.
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
#include <optional>
#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"

namespace indicial {

// Whether read_run_csv insists on the coefficient column (the fitter) or not (predict, the
// simulator's csv: motion).
enum class CoefficientPresence { required, optional };

// An angle in radians beyond 2 pi in magnitude is almost certainly degrees: the rule of a run
// file's radian angle column (warned by the reader) and of Python's angle arrays (predict).
inline bool radians_look_like_degrees(double largest_abs_rad) {
  return largest_abs_rad > 2.0 * 3.14159265358979323846;
}

// Fewest data rows a run may have: one Savitzky-Golay window (2 * 5 + 1 samples).
inline constexpr int min_run_samples = 11;

// The experiment's [columns] table: our column name -> the file's name ("alpha_deg" -> "AoA").
// A mapping whose file column is absent is ignored (the missing-column message says so).
using ColumnMap = std::map<std::string, std::string>;

// The field delimiter of the run files (experiment [csv] delimiter). detect: the most frequent
// of tab, ';' and ',' in the header line; a header with none of them but blanks is
// whitespace-separated; and when the header and the first data row split into different
// numbers of fields with that choice but the same number on runs of blanks, whitespace.
// whitespace: fields are separated by runs of spaces and tabs (a database's `%` text files).
enum class Delimiter { detect, comma, semicolon, tab, whitespace };

// How the run files are written (experiment [csv] section; detected by default).
struct CsvDialect {
  Delimiter delimiter = Delimiter::detect;
  // A line whose first non-blank character is one of these is a comment. When the first
  // non-comment line is all numbers (no header row), the last comment line before it is the
  // header (its comment character stripped) if it has as many fields as the data: `% Time()
  // Angle(deg) Cn Ct Cm` above tab-separated numbers (a note says so).
  std::string comment_chars = "#%";
};

// Where the caller takes a phase column's frequency from, for the message when it is missing:
// the experiment's runs entry (fit, diagnose), the command line (predict), or nowhere (simulate
// --motion csv:, which cannot take a phase cycle: refused whatever the frequency).
enum class FrequencySource { experiment_entry, command_line, none };

struct RunCsvOptions {
  // uniform: the step must be uniform within 1e-6 relative, or within half a unit of the last
  // printed digit of the time (phase) column, in which case the times are snapped to the
  // uniform grid (a note says so); a phase column that is not uniform even so becomes
  // nonuniform, a time column is refused. nonuniform (declared): no step check.
  // Not given (std::nullopt): uniform for a time column; a phase column not uniform even to its
  // printed digits is read as nonuniform with a note. Given as uniform: such a phase column is
  // refused (the user asked for a grid the file does not have).
  std::optional<TimeGrid> grid;
  ColumnMap columns;
  double frequency_hz = 0.0;  // the cycle's frequency; required by a phase column
  CsvDialect dialect;
  FrequencySource frequency_source = FrequencySource::experiment_entry;
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
                 CoefficientPresence presence, std::optional<TimeGrid> grid = std::nullopt);

// One file of a run whose columns are sampled at their own phases (the experiment's runs entry
// `files = [...]`, phase_resample.hpp): its phase column (phase_rad | phase_deg, in rad here,
// in [0, 2 pi), strictly increasing, at least 4 rows, any spacing) and whichever of the run's
// columns it has (the motion angle, the rate, the coefficient: each empty when absent). CL and
// CD are derived from Cnormal and Ctangential as by read_run_csv when the file also has the
// angle. Dialect and [columns] as read_run_csv.
struct PhaseSeries {
  std::string path;
  std::vector<std::string> columns;  // the file's header as written (for a missing column's hint)
  std::string angle_base;            // the motion angle's name without its unit: alpha (pitch), phi, beta
  std::vector<double> phase_rad;
  std::vector<double> motion_angle_rad;
  std::string motion_column;
  std::vector<double> rate_radps;
  std::vector<double> coefficient;
  std::vector<std::string> notes;
  std::vector<std::string> warnings;  // plausible mistakes (a gap in the phases, radians in a degree column)
};
PhaseSeries read_phase_series(const std::string& path, Axis axis, const std::string& coefficient,
                              const RunCsvOptions& options);

// Reads a static table (columns alpha_* in pitch or beta_* in roll/yaw, plus `coefficient`)
// into config.table_x_rad / table_value. Used by load_experiment.
void read_static_table(const std::string& path, Axis axis, const std::string& coefficient,
                       StaticConfig& config, const ColumnMap& columns = {}, const CsvDialect& dialect = {});

}  // namespace indicial
