// indicial/fitter/io.hpp -- reading and writing run CSVs and experiment files.
//
// What it is for
// --------------
// Everything the fitter, diagnose and predict read from disk enters through this header, and
// every check on that input happens here, once: a problem is an indicial::InputError whose
// message names the file, the line and the problem ("run_f0.25.csv:14: time_s is not strictly
// increasing (0.13 after 0.13)"). Downstream code may assume what is validated here:
// uniform, strictly increasing time; finite values; angles in rad and rates in rad/s.
//
// Usage
// -----
//   indicial::Run run = indicial::read_run_csv("run.csv", indicial::Axis::pitch, "Cm",
//                                              indicial::CoefficientPresence::required);
//   indicial::Experiment e = indicial::load_experiment("experiment.toml");  // runs included
//   std::vector<double> ydot = indicial::smooth_derivative(y, dt_s, 5, 3);  // Savitzky-Golay
//
// File formats (../shared/reference/interface.md, extended as documented in docs/formats.md)
// ----------------------------------------------------------------------------------------
// Run CSV: comma separated; '#' comment lines and blank lines anywhere are skipped; one
// header row; the unit is part of each column name: time_s; the motion angle alpha_deg |
// alpha_rad (pitch), phi_deg | phi_rad (roll), psi_deg | psi_rad (yaw); the optional rate
// q_degps | q_radps, p_... , r_...; coefficients CL, Cm, CD, CY, Cl, Cn. A column whose base
// name is an angle, a rate or time (alpha, beta, phi, psi, theta, q, p, r, time) must carry a
// known unit suffix (alpha, alpha_grad are refused); other extra columns (Cm_true, y_true,
// Cm_pred, ...) are ignored.
//
// Experiment TOML: exactly the keys of interface.md plus these extensions:
//   runs = ["a.csv", {file = "b.csv", periodic = true}]   entries are strings or tables
//   [model] a_powers = [1, 2] / b1_powers = [0] (instead of *_degree), lags = 1
//   [model] static_correction_degree|_powers|_knots_deg, rotary_correction_degree|_powers|
//           _knots_deg, delay = "none"|"estimated", delay_start_s, further_lag_start =
//           "estimated"|"at_rest"                          what diagnose adds (ModelConfig)
//   [rotary] degree = 2, knots_deg = [...]               the candidate pool for estimate = true
//   [rotary] prior_knots_deg, prior_knot_powers, prior_knot_coefficients   a priori knot terms
//   [static] table = "static.csv"                          alpha_deg|alpha_rad (pitch) or
//            beta_deg|beta_rad (roll, yaw) plus the coefficient column, strictly increasing
//   alpha0_rad instead of alpha0_deg.
//
// Warnings
// --------
// 1. When a run has no rate column, the rate is the Savitzky-Golay derivative of the angle
//    (local cubic over 11 samples, see smooth_derivative). It smooths noise but also the
//    signal: with fewer than ~20 samples per cycle it is biased; give the rate when you have it.
// 2. Unknown TOML keys are errors at every level (a misspelt key must never silently fall back
//    to a default). A new key must be added to the parser in io.cpp and to docs/formats.md.
// 3. The model-angle range used to check knots and static tables is the range of
//    x = model_angle(axis, alpha0, motion angle) over all samples of all runs; a knot must lie
//    strictly inside it (a knot at or beyond the range has a term that is identically zero or
//    identically a polynomial on the data, so it cannot be identified).
#pragma once

#include <string>
#include <vector>

#include "indicial/fitter/experiment.hpp"

namespace indicial {

// Whether read_run_csv insists on the coefficient column (the fitter) or not (predict, the
// simulator's csv: motion).
enum class CoefficientPresence { required, optional };

// Fewest data rows a run may have: one Savitzky-Golay window (2 * 5 + 1 samples).
inline constexpr int min_run_samples = 11;

// The smoothing differentiator used for absent rate columns and for y_E' (eq. 22).
inline constexpr int default_sg_half_window = 5;
inline constexpr int default_sg_degree = 3;

// The time grid a run is declared to have (interface.md: "uniform step within 1e-6 relative
// unless a run is declared otherwise"). The fitter needs a uniform grid (its smoothed y_E'
// and the runs' dt); predict takes either, since the runtime steps with each sample's own dt
// (a HIL or flight log with timestamp jitter, or a log with dropped samples).
enum class TimeGrid { uniform, nonuniform };

// Reads one run. `coefficient` is the column to load (e.g. "Cm"); with
// CoefficientPresence::optional an absent coefficient column leaves Run::coefficient empty.
// Angles are converted to rad, rates to rad/s. Run::path is `path` as given. With
// TimeGrid::nonuniform the step is not checked (time must still strictly increase), Run::dt_s()
// means nothing, and an absent rate column is derived by smooth_derivative_nonuniform.
Run read_run_csv(const std::string& path, Axis axis, const std::string& coefficient,
                 CoefficientPresence presence, TimeGrid grid = TimeGrid::uniform);

// Savitzky-Golay first derivative of uniformly sampled values: at every sample, a polynomial of
// degree poly_degree is fitted by least squares to the 2 * half_window + 1 samples of a window
// and differentiated at that sample. Interior samples use the centred window; the first and
// last half_window samples use the first / last full window (the same local polynomial, fitted
// asymmetrically and evaluated at the end sample), so the ends keep the order of accuracy
// instead of dropping to a one-sided difference. Requires values.size() >= 2 * half_window + 1,
// 1 <= poly_degree <= 2 * half_window, dt_s > 0 (std::invalid_argument otherwise).
std::vector<double> smooth_derivative(const std::vector<double>& values, double dt_s,
                                      int half_window, int poly_degree);

// The same local least-squares polynomial on a non-uniform grid: at every sample the window of
// 2 * half_window + 1 samples (clamped at the ends, as above) is fitted in time and the
// polynomial differentiated at that sample's time. On a uniform grid it equals
// smooth_derivative to rounding. Requires strictly increasing time_s of the same length as
// values, and the size and degree limits above (std::invalid_argument otherwise).
std::vector<double> smooth_derivative_nonuniform(const std::vector<double>& time_s,
                                                 const std::vector<double>& values,
                                                 int half_window, int poly_degree);

// Reads the experiment file and every run it names; validates everything (see the warnings).
Experiment load_experiment(const std::string& toml_path);

// Reads a static table (columns alpha_* in pitch or beta_* in roll/yaw, plus `coefficient`)
// into config.table_x_rad / table_value. Used by load_experiment.
void read_static_table(const std::string& path, Axis axis, const std::string& coefficient,
                       StaticConfig& config);

// ------------------------------------------------------------------------------------------
// Writers (used by the simulator; the output is accepted by the readers above).
// ------------------------------------------------------------------------------------------
struct CsvColumn {
  std::string name;             // with its unit suffix: time_s, alpha_deg, q_degps, Cm, ...
  std::vector<double> values;   // all columns the same length
};

// A run CSV as text: the comment lines (each prefixed "# "), the header, one row per sample,
// numbers in the shortest form that reads back to the same double.
std::string write_run_csv(const std::vector<CsvColumn>& columns,
                          const std::vector<std::string>& comment_lines);

// An experiment file as text, for `experiment` with the run files named by runs[i].path
// (relative to the experiment file) and runs[i].periodic. Knots are written in degrees,
// polynomials as given. Writes a_degree / b1_degree when the powers are 0..n-1 and
// a_powers / b1_powers otherwise. load_experiment(write_experiment_toml(e)) gives back e's
// configuration (to the last bit for the polynomials, within 1 ulp for knots).
std::string write_experiment_toml(const Experiment& experiment,
                                  const std::vector<std::string>& comment_lines);

// Shortest decimal text that reads back to exactly v (std::to_chars).
std::string format_double(double v);

}  // namespace indicial
