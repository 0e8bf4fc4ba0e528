// indicial/fitter/experiment_toml.hpp -- reading and writing experiment files (TOML).
//
// What it is for
// --------------
// load_experiment() turns an experiment file and every run CSV it names into a validated
// Experiment (all angles in rad); write_experiment_toml() writes one back (the simulator's
// cases). Both use the one table of enum names below, so a value the writer writes is always
// one the reader reads.
//
// Usage
// -----
//   indicial::Experiment e = indicial::load_experiment("experiment.toml");  // runs included
//   std::string text = indicial::write_experiment_toml(e, {"written by ..."});
//
// Keys: exactly those of interface.md plus the extensions documented in docs/formats.md:
//   runs = ["a.csv", {file = "b.csv", periodic = true}]   entries are strings or tables
//   [model] a_powers = [1, 2] / b1_powers = [0] (instead of *_degree), lags = 1
//   [model] b2_degree|b2_powers|b2_knots_deg (bK_* for each lag K = 2..lags): b_K(x)
//   [model] static_correction_degree|_powers|_knots_deg, rotary_correction_degree|_powers|
//           _knots_deg, delay = "none"|"estimated", delay_start_s, further_lag_start =
//           "estimated"|"at_rest"                          what diagnose adds (ModelConfig)
//   [rotary] degree = 2, knots_deg = [...]               the candidate pool for estimate = true
//   [rotary] prior_knots_deg, prior_knot_powers, prior_knot_coefficients   a priori knot terms
//   [static] table = "static.csv"                          alpha_deg|alpha_rad (pitch) or
//            beta_deg|beta_rad (roll, yaw) plus the coefficient column, strictly increasing
//   alpha0_rad instead of alpha0_deg.
//   [columns] our name = the file's name (Cnormal / Ctangential: body-axis forces, CL and CD
//            derived); [csv] delimiter = "detect"|"comma"|"semicolon"|"tab"|"whitespace",
//            comment = "#%"                                 the run files' dialect
//
// Warnings
// --------
// 1. Unknown TOML keys are errors at every level (a misspelt key must never silently fall back
//    to a default). A new key must be added to the reader in experiment_toml.cpp and to
//    docs/formats.md.
// 2. The model-angle range used to check knots and static tables is the range of
//    x = model_angle(axis, alpha0, motion angle) over all samples of all runs; a knot must lie
//    strictly inside it (a knot at or beyond the range has a term that is identically zero or
//    identically a polynomial on the data, so it cannot be identified).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "indicial/fitter/csv_reader.hpp"
#include "indicial/fitter/experiment.hpp"

namespace indicial {

// The name of an enum value in the experiment file. One table per enum, used by the reader
// (which refuses any other string, listing these) and by the writer.
template <class E>
struct NamedValue {
  const char* name;
  E value;
};
inline constexpr std::array<NamedValue<Axis>, 3> axis_names{
    {{"pitch", Axis::pitch}, {"roll", Axis::roll}, {"yaw", Axis::yaw}}};
inline constexpr std::array<NamedValue<StructureMode>, 2> structure_mode_names{
    {{"fixed", StructureMode::fixed}, {"stepwise", StructureMode::stepwise}}};
inline constexpr std::array<NamedValue<DelayEstimation>, 2> delay_estimation_names{
    {{"none", DelayEstimation::none}, {"estimated", DelayEstimation::estimated}}};
inline constexpr std::array<NamedValue<LagStart>, 2> lag_start_names{
    {{"estimated", LagStart::estimated}, {"at_rest", LagStart::at_rest}}};
inline constexpr std::array<NamedValue<StallFamilies>, 3> stall_families_names{
    {{"none", StallFamilies::none}, {"separation", StallFamilies::separation},
     {"separation_and_vortex", StallFamilies::separation_and_vortex}}};
inline constexpr std::array<NamedValue<StallReattachment>, 2> stall_reattachment_names{
    {{"as_separation", StallReattachment::as_separation}, {"estimated", StallReattachment::estimated}}};
inline constexpr std::array<NamedValue<StallHysteresis>, 2> stall_hysteresis_names{
    {{"none", StallHysteresis::none}, {"estimated", StallHysteresis::estimated}}};
inline constexpr std::array<NamedValue<StallLagLimit>, 2> stall_lag_limit_names{
    {{"none", StallLagLimit::none}, {"estimated", StallLagLimit::estimated}}};
inline constexpr std::array<NamedValue<ForcingLag>, 2> forcing_lag_names{
    {{"delay", ForcingLag::delay}, {"first_order", ForcingLag::first_order}}};
inline constexpr std::array<NamedValue<TimeGrid>, 2> time_grid_names{
    {{"uniform", TimeGrid::uniform}, {"nonuniform", TimeGrid::nonuniform}}};

inline constexpr std::array<NamedValue<Delimiter>, 5> delimiter_names{
    {{"detect", Delimiter::detect}, {"comma", Delimiter::comma}, {"semicolon", Delimiter::semicolon},
     {"tab", Delimiter::tab}, {"whitespace", Delimiter::whitespace}}};

inline constexpr const auto& names_of(Axis) { return axis_names; }
inline constexpr const auto& names_of(Delimiter) { return delimiter_names; }
inline constexpr const auto& names_of(StructureMode) { return structure_mode_names; }
inline constexpr const auto& names_of(DelayEstimation) { return delay_estimation_names; }
inline constexpr const auto& names_of(LagStart) { return lag_start_names; }
inline constexpr const auto& names_of(TimeGrid) { return time_grid_names; }
inline constexpr const auto& names_of(StallFamilies) { return stall_families_names; }
inline constexpr const auto& names_of(StallReattachment) { return stall_reattachment_names; }
inline constexpr const auto& names_of(ForcingLag) { return forcing_lag_names; }
inline constexpr const auto& names_of(StallHysteresis) { return stall_hysteresis_names; }
inline constexpr const auto& names_of(StallLagLimit) { return stall_lag_limit_names; }

// The file's name of `value` (e.g. "stepwise").
template <class E>
constexpr const char* name_of(E value) {
  for (const auto& nv : names_of(value))
    if (nv.value == value) return nv.name;
  return "?";
}

// Reads the experiment file and every run it names; validates everything (see the warnings).
// A file listing several coefficients (`coefficients = ["CL", "Cm"]`) is refused unless
// `coefficient` names one of them (diagnose --coefficient).
Experiment load_experiment(const std::string& toml_path, const std::string& coefficient = "");

// One Experiment per coefficient of the file (one for `coefficient = ...`), each with its own
// [static], [rotary] and [model] (shared or per coefficient: [static.CL], [model.Cm]; see
// docs/formats.md) and the same runs, in the order of `coefficients`.
std::vector<Experiment> load_experiments(const std::string& toml_path);

// The runs only, one Experiment per coefficient as load_experiments reads them (axis, lengths,
// airspeed, [columns], [csv], runs), without [static], [rotary] and [model] (not required, not
// read, not checked): for `indicial polar`, which makes the static table, and `indicial predict
// --run`, which predicts a run whatever the experiment's model.
// `also`: coefficients the file does not model, read from the same run files where a run has
// them (a C_L experiment's files with a Cm column, predicted by a C_L + C_m model), one
// Experiment each after the file's own: a run without the column has an empty `coefficient`;
// a column that is there is read and checked as the file's own (a bad value is refused).
std::vector<Experiment> load_experiment_runs(const std::string& toml_path,
                                             const std::vector<std::string>& also = {});

// How the experiment's run files are read: its [columns] map and its [csv] dialect (the rest of
// the file is checked for TOML syntax only). `indicial predict --experiment` reads a run file
// this way, as `fit` reads the experiment's runs.
RunCsvOptions run_file_format(const std::string& toml_path);

// Sets data_x_min_rad / data_x_max_rad to the range of the model angle x = model_angle(axis,
// alpha0, motion angle) over every sample of every run (both 0 without samples). Called by
// load_experiment; code that builds an Experiment from runs in memory calls it too.
void set_data_range(Experiment& experiment);

// An experiment file as text, for `experiment` with the run files named by runs[i].path
// (relative to the experiment file), runs[i].periodic and, where they differ from the
// defaults, frequency_hz (a phase-column run), airspeed_mps and time_grid. Knots are written in degrees,
// polynomials as given. Writes a_degree / b1_degree when the powers are 0..n-1 and
// a_powers / b1_powers otherwise. load_experiment(write_experiment_toml(e)) gives back e's
// configuration (to the last bit; angles in degrees are written with the shortest digits that read back
// to the same radians: a knot read as 12 deg is written 12, not 12.000000000000002).
std::string write_experiment_toml(const Experiment& experiment,
                                  const std::vector<std::string>& comment_lines);

// The same, with the run files' format: its [columns] map and [csv] dialect written where they
// are not the defaults, so that the written file reads its runs and tables as the file the
// format came from (run_file_format) did. Why: an experiment over a database's files
// (whitespace-delimited, `%` header, Cn / Ct columns) rewritten without them names files that
// `fit` cannot read (diagnose's experiment.toml did, found on the Glasgow cycles).
std::string write_experiment_toml(const Experiment& experiment,
                                  const std::vector<std::string>& comment_lines,
                                  const RunCsvOptions& file_format);

}  // namespace indicial
