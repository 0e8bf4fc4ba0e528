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
// skipped; the unit is part of each column name: time_s; the motion angle alpha_deg |
// alpha_rad (pitch), phi_deg | phi_rad (roll), psi_deg | psi_rad (yaw); the optional rate
// q_degps | q_radps, p_... , r_...; coefficients CL, Cm, CD, CY, Cl, Cn.
//
// Warnings
// --------
// 1. A column whose base name is an angle, a rate or time (alpha, beta, phi, psi, theta, q, p,
//    r, time) must carry a known unit suffix (alpha, alpha_grad are refused): a unit must
//    never be guessed. Other extra columns (Cm_true, y_true, Cm_pred, ...) are ignored.
// 2. When a run has no rate column, the rate is the Savitzky-Golay derivative of the angle
//    (derivative.hpp); with fewer than ~20 samples per cycle it is biased.
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

// Reads one run. `coefficient` is the column to load (e.g. "Cm"); with
// CoefficientPresence::optional an absent coefficient column leaves Run::coefficient empty.
// Angles are converted to rad, rates to rad/s. Run::path is `path` as given. With
// TimeGrid::nonuniform the step is not checked (time must still strictly increase), Run::dt_s()
// means nothing, and an absent rate column is derived by smooth_derivative_nonuniform.
Run read_run_csv(const std::string& path, Axis axis, const std::string& coefficient,
                 CoefficientPresence presence, TimeGrid grid = TimeGrid::uniform);

// Reads a static table (columns alpha_* in pitch or beta_* in roll/yaw, plus `coefficient`)
// into config.table_x_rad / table_value. Used by load_experiment.
void read_static_table(const std::string& path, Axis axis, const std::string& coefficient,
                       StaticConfig& config);

}  // namespace indicial
