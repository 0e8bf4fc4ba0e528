// indicial/fitter/report.hpp -- what `indicial fit` writes: fit.json, model.coef, report.md, plots.
//
// What it is for
// --------------
// A FitResult (fit.hpp) is turned into the three outputs of the user-facing contract
// (docs/formats.md, fit.json):
//
//   fit.json    the contract fields (converged, iterations, fit_error, parameters with name,
//               value, cr_bound, cr_bound_colored; two_stage when rotary.estimate), extended
//               with provenance (provenance.hpp), warnings, termination, unidentifiable parameters, the equation-error start values,
//               the stepwise log, the output-error iteration log, per-run fit errors, the
//               options used, the runtime check and elapsed_s. A bound that the information
//               matrix cannot determine is written as null with "identifiable": false.
//   model.coef  the identified model, written by the runtime's own writer (write_coef_file),
//               with the provenance as `#` comment lines before the body, then loaded back by the runtime's Predictor and replayed over every run: the
//               largest difference from the fitter's model output is reported (same equations,
//               so it is at rounding level).
//   report.md   estimates with white and colored bounds, equation-error start values, the
//               stepwise log, the output-error log and termination, the two-stage log, and
//               plots made by gnuplot (pngcairo): measured vs model per run with the
//               quasi-steady curve, residuals per run (at most kMaxPlotPoints points per
//               curve: longer runs are thinned, and report.md says so), a(x) and b1(x) with +/- 2 sigma bands,
//               C_aq(x) (with its band when estimated). Images live in DIR/plots/ and are
//               referenced by relative paths; the gnuplot script and data files stay beside
//               them so a plot can be restyled and regenerated (`cd DIR/plots && gnuplot plots.gp`).
//
// Usage
// -----
//   indicial::Experiment e = indicial::load_experiment("experiment.toml");
//   indicial::FitOptions o;
//   indicial::FitResult r = indicial::fit_experiment(e, o);
//   indicial::FitOutputs w = indicial::write_fit_outputs(r, e, o, "out", indicial::Overwrite::refuse);
//   if (w.plots != indicial::PlotStatus::written) std::puts(w.plot_message.c_str());
//
// Warnings
// --------
// 1. Everything goes through OutputDir (output.hpp): DIR appears whole or not at all, and a
//    non-empty DIR is refused (InputError) unless Overwrite::replace.
// 2. gnuplot is run as a subprocess (`gnuplot plots.gp` inside the staging directory). If it
//    is not installed, or fails, every other file is still written, report.md says so, and
//    FitOutputs::plots tells the caller; that is not an error.
// 3. model.coef is written at the fitter's capacity (FitCapacity). The default runtime
//    (Predictor<>, DefaultCapacity) may refuse a model with a larger candidate pool; the
//    runtime check loads the file with the default capacity first and reports
//    RuntimeFit::needs_fit_capacity (with the runtime's reason) if it does not fit there.
// 4. The runtime replay starts each run from the fitter's estimated initial state (y0_r, or the
//    periodic steady state for a periodic run) by restoring a Predictor snapshot, then steps
//    from sample 1 on; sample 0 is the initial state itself and is not compared.
#pragma once

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/provenance.hpp"

namespace indicial {

// Whether the plots were made.
enum class PlotStatus {
  written,            // every PNG was produced
  gnuplot_not_found,  // the gnuplot executable could not be run; report.md says so
  gnuplot_failed,     // gnuplot ran but failed (its log is DIR/plots/gnuplot.log)
  not_requested       // ReportOptions::plots == PlotRequest::none
};
const char* plot_status_name(PlotStatus s);

enum class PlotRequest { gnuplot, none };

// Which runtime capacity the written model.coef loads with.
enum class RuntimeFit {
  default_capacity,    // Predictor<> (DefaultCapacity) loads it
  needs_fit_capacity,  // only Predictor<double, FitCapacity> loads it (too many terms)
  refused              // the runtime refuses it even at FitCapacity (see RuntimeCheck::detail)
};
const char* runtime_fit_name(RuntimeFit f);

// The written model.coef, loaded by the runtime and replayed over every run of the fit.
struct RuntimeCheck {
  RuntimeFit fit = RuntimeFit::refused;
  LoadStatus load_status = LoadStatus::ok;  // of the load that decided `fit`
  std::string detail;                       // the runtime's reason when not default_capacity
  double max_abs_difference = 0.0;          // |runtime - FitResult::runs[].model|, samples >= 1
  // Steps compared: every sample after each replayed run's first. Why not the first: it is the
  // run's estimated initial state, which the runtime is reset to, not a step it computes; so a
  // fit of N samples in R runs replays N - R steps.
  std::size_t samples_compared = 0;
  std::size_t runs_replayed = 0;
  std::size_t steps_not_ok = 0;             // steps whose status was neither ok nor angle_clamped
};

struct ReportOptions {
  PlotRequest plots = PlotRequest::gnuplot;
  std::string gnuplot = "gnuplot";  // executable (looked up on PATH)
  std::string command_line;         // shown at the top of report.md
  std::string experiment_display;   // how report.md and fit.json name the experiment file
                                    // (default: Experiment::path); run paths are shown
                                    // relative to the experiment file's directory
  Provenance provenance;            // fit.json / diagnosis.json "provenance" and the model.coef
                                    // header comments (none when provenance.version is empty)
  std::vector<std::string> warnings;  // one-line warnings: fit.json / diagnosis.json "warnings"
  // What the readers did with the files, one line each (Experiment::notes: the delimiter and
  // header found, ignored columns, a column read negated, CL and CD derived from Cn and Ct,
  // times snapped to a uniform grid, coefficients resampled to common phases): fit.json /
  // diagnosis.json "input_notes" and report.md's "Notes and warnings" list, so that what was
  // done to the data travels with the result (they were on stderr only).
  std::vector<std::string> notes;
};

// report.md's "## Notes and warnings" section: ro.notes (what the readers did with the input
// files) and ro.warnings (input and result warnings) as lists; empty when both are empty.
// Shared by the fit and diagnose reports.
std::string input_as_read_markdown(const ReportOptions& ro);

// j with "provenance" (when ro.provenance has a version), "warnings" and "input_notes" (always,
// maybe empty) set from ro: the fields every JSON output of a fit or diagnose carries.
nlohmann::json with_provenance_and_warnings(nlohmann::json j, const ReportOptions& ro);

// Warnings about a finished fit, one line each (empty when there is nothing to say):
//  * the fit error s(v) more than kFitErrorNoiseRatio (3) times the noise level estimated
//    from the data (estimate_noise_level, noise_level.hpp: its white-equivalent level, from the
//    second difference of each run's residual, which passes the noise and removes a smooth
//    model error; AR(1) noise with phi above ~0.85 reads below its level there, so a complete
//    model can warn on such noise: the message gives phi). A ratio that high
//    means a missing effect or wrong input (units, columns), not noise.
//  * a lag that does not decay over the runs (b_j(x) times the longest run under 0.05
//    everywhere in the envelope): it only integrates a(x) x', a static correction, not a lag;
//  * a dynamic-stall time constant long against the shortest periodic run's cycle
//    (slow_stall_state_warnings);
//  * an output-error estimate on the feasible set's boundary (OutputErrorSummary::boundary
//    active: the steps tried from it went to inadmissible models; the solver may still report
//    "converged", stopped by a step it could not take);
//  * estimates whose Cramer-Rao bound exceeds their value (bound_exceeds_value, fit.hpp: the
//    rule diagnose's "ill-conditioned" list uses), with value +- bound; for every fit,
//    replicated or not.
inline constexpr double kFitErrorNoiseRatio = 3.0;
std::vector<std::string> fit_warnings(const FitResult& r, const Experiment& e);

// One line per dynamic-stall time constant (T1, T1r, a first-order T2, T_v) of r's model that
// keeps more than 0.1 of its state's value over the shortest periodic run's cycle of e:
// exp(-cycle / T) > 0.1, cycle in l / V units at the run's airspeed (1 / frequency_hz when
// given). Such a state hardly moves within a cycle: its periodic value is set by the cycle's
// average forcing, an offset the output gains scale. In fit_warnings and in diagnose's warnings
// about its final model.
std::vector<std::string> slow_stall_state_warnings(const FitResult& r, const Experiment& e);

// What one gnuplot run made.
struct PlotSet {
  std::vector<std::string> images;  // made and not empty, relative to the output directory
  PlotStatus status = PlotStatus::not_requested;
  std::string message;              // one line: what happened with gnuplot
};

// Writes `script` as DIR/plots/plots.gp (staged in `out`; its data files must already be
// there), runs `gnuplot plots.gp` in that directory and checks that every image named in
// `expected_pngs` exists and is not empty. gnuplot's output goes to plots/gnuplot.log, which
// is kept only when something failed. Shared by the fit and diagnose reports.
PlotSet run_gnuplot_script(const OutputDir& out, const std::string& script,
                           const std::vector<std::string>& expected_pngs, const ReportOptions& ro);

// What write_fit_outputs wrote (the texts are also returned, for tests and the example).
struct FitOutputs {
  std::filesystem::path dir;
  std::string fit_json;
  std::string model_coef;
  std::string report_md;
  PlotStatus plots = PlotStatus::not_requested;
  std::string plot_message;          // one line: what happened with gnuplot
  std::vector<std::string> images;   // relative to dir, e.g. "plots/run1_fit.png"
  RuntimeCheck runtime;
};

// The model as coefficient-file text: coef_file_text(r.model, origin) (model_merge.hpp, the
// one writer). Throws InputError naming `origin` if the writer refuses the model.
std::string model_coef_text(const FitResult& r, const std::string& origin);

// Loads coef_text with the runtime (DefaultCapacity first, then FitCapacity) and replays every
// run of r (the motion angle and rate of e.runs, at each run's airspeed_mps, e.airspeed_mps
// where a run has none, with each sample's own dt) from its estimated initial state (warning 4).
RuntimeCheck replay_in_runtime(const FitResult& r, const Experiment& e,
                               const std::string& coef_text);

// fit.json as a JSON value (see the essay for the fields). `runtime` may be null.
nlohmann::json fit_json(const FitResult& r, const Experiment& e, const FitOptions& o,
                        const RuntimeCheck* runtime);

// Writes DIR/fit.json, DIR/model.coef, DIR/report.md and DIR/plots/ through OutputDir.
FitOutputs write_fit_outputs(const FitResult& r, const Experiment& e, const FitOptions& o,
                             const std::filesystem::path& dir, Overwrite overwrite,
                             const ReportOptions& ro = {});

// A plain-text table of estimates (name, value, CR bound, colored bound) for terminals;
// undetermined bounds print as "not identifiable".
std::string estimates_text_table(const std::vector<ParameterEstimate>& parameters);

// Root-mean-square of a run's residuals (measured - model); NaN for an empty run.
double run_fit_error(const RunSeries& s);
// The mean of a run's residuals (measured - model; > 0: the model is low on the run); NaN for
// an empty run. Runs at one condition whose means differ are a tunnel's per-run zero drift, or
// a condition the model does not follow; no model of the motion removes the former.
double run_mean_residual(const RunSeries& s);

// Plot data thinning: a curve never gets more than kMaxPlotPoints points (a 160,000-sample
// run would otherwise make megabytes of data and gnuplot would spend seconds drawing points a
// 960-pixel image cannot show). thinned_indices(n) returns every k-th index from 0, k =
// ceil(n / max_points), plus n - 1: all of them when n <= max_points. Shared by the fit and
// diagnose plots.
inline constexpr std::size_t kMaxPlotPoints = 5000;
std::vector<std::size_t> thinned_indices(std::size_t n, std::size_t max_points = kMaxPlotPoints);

// The number as JSON: null when it is not finite (JSON has no NaN or Inf).
nlohmann::json finite_or_null(double v);

}  // namespace indicial
