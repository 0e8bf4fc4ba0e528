// report.cpp -- fit.json, model.coef, report.md and the gnuplot plots (see report.hpp).
#include "indicial/fitter/report.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/noise_level.hpp"
#include "indicial/fitter/replication.hpp"
#include "indicial/runtime.hpp"

namespace fs = std::filesystem;

namespace indicial {

const char* plot_status_name(PlotStatus s) {
  switch (s) {
    case PlotStatus::written: return "written";
    case PlotStatus::gnuplot_not_found: return "gnuplot_not_found";
    case PlotStatus::gnuplot_failed: return "gnuplot_failed";
    case PlotStatus::not_requested: return "not_requested";
  }
  return "?";
}

const char* runtime_fit_name(RuntimeFit f) {
  switch (f) {
    case RuntimeFit::default_capacity: return "default_capacity";
    case RuntimeFit::needs_fit_capacity: return "needs_fit_capacity";
    case RuntimeFit::refused: return "refused";
  }
  return "?";
}

nlohmann::json finite_or_null(double v) {
  // Why: JSON has no NaN/Inf; an undetermined number is null, never a huge stand-in.
  if (std::isfinite(v)) return v;
  return nullptr;
}

double run_fit_error(const RunSeries& s) {
  if (s.residual.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0;
  for (double v : s.residual) sum += v * v;
  return std::sqrt(sum / static_cast<double>(s.residual.size()));
}

std::string model_coef_text(const FitResult& r, const std::string& origin) { return coef_file_text(r.model, origin); }

namespace {

// A run or experiment path as the report shows it: relative to the experiment's directory when
// it lies inside it (so a report does not carry a temporary or absolute prefix).
std::string display_path(const std::string& path, const Experiment& e) {
  const fs::path base = fs::path(e.path).parent_path().lexically_normal();
  const fs::path rel = fs::path(path).lexically_normal().lexically_relative(base);
  // Why the checks: a path outside the experiment's directory (or on another root) keeps its
  // full form rather than a confusing ../../ chain.
  if (base.empty() || rel.empty() || *rel.begin() == "..") return path;
  return rel.string();
}

// The initial lag states of run `ri` (0-based) as the fitter estimated them.
// Returns false when they cannot be recovered (a periodic run of a multi-lag model).
bool initial_states(const FitResult& r, std::size_t ri, int n_lags, double* y) {
  bool found_first = false;
  for (int j = 0; j < n_lags; ++j) y[j] = 0.0;
  for (const ParameterEstimate& p : r.parameters) {
    if (p.id.kind != ParamKind::initial_state || p.id.run != static_cast<int>(ri)) continue;
    if (p.id.lag < n_lags) y[p.id.lag] = p.value;
    if (p.id.lag == 0) found_first = true;
  }
  if (found_first) return true;
  // Why: a periodic run has no y0 parameter (its state is the periodic steady state); with one
  // lag the model's state at sample 0 is the whole unsteady part there.
  const RunSeries& s = r.runs[ri];
  if (n_lags == 1 && !s.y_model.empty() && std::isfinite(s.y_model[0])) {
    // y_model includes the dynamic-stall families' output (zero without them).
    y[0] = s.y_model[0] - stall_output(r.model.coefficients[0].stall, s.x_rad[0], s.stall_initial);
    return true;
  }
  return false;
}

template <class Cap>
void replay_with(Predictor<double, Cap>& p, const FitResult& r, const Experiment& e,
                 RuntimeCheck& check) {
  const int n_lags = r.model.coefficients[0].n_lags;
  for (std::size_t ri = 0; ri < r.runs.size() && ri < e.runs.size(); ++ri) {
    const RunSeries& s = r.runs[ri];
    const Run& run = e.runs[ri];
    if (run.size() != s.model.size() || run.size() < 2) continue;
    double y0[FitCapacity::max_lags] = {};
    if (!initial_states(r, ri, n_lags, y0)) {
      check.detail += (check.detail.empty() ? "" : "; ") + s.path +
                      ": initial state not recoverable, not replayed";
      continue;
    }
    // The run's own airspeed (0 in a Run built in code: the experiment's), as the fit used it.
    const double airspeed_mps = run.airspeed_mps > 0.0 ? run.airspeed_mps : e.airspeed_mps;
    p.reset(run.motion_angle_rad[0], airspeed_mps);
    auto snap = p.snapshot();
    for (int j = 0; j < n_lags; ++j) snap.y[0][j] = y0[j];
    // The dynamic-stall states at sample 0 as the fit propagated them (the periodic state of a
    // periodic run; the steady state otherwise): RunSeries::stall_initial.
    snap.stall[0] = s.stall_initial;
    p.restore(snap);
    ++check.runs_replayed;
    typename Predictor<double, Cap>::Outputs out;
    for (std::size_t k = 1; k < run.size(); ++k) {
      const MotionInput in{run.motion_angle_rad[k], run.rate_radps[k], airspeed_mps};
      const StepStatus st = p.step(in, run.time_s[k] - run.time_s[k - 1], &out);
      if (st != StepStatus::ok && st != StepStatus::angle_clamped) {
        ++check.steps_not_ok;
        continue;
      }
      const double d = std::fabs(out.value[0] - s.model[k]);
      // Why the NaN test: a NaN difference must show up as a failure, not vanish in max().
      if (!(d <= check.max_abs_difference)) check.max_abs_difference = std::isnan(d) ? std::numeric_limits<double>::infinity() : d;
      ++check.samples_compared;
    }
  }
}

}  // namespace

RuntimeCheck replay_in_runtime(const FitResult& r, const Experiment& e,
                               const std::string& coef_text) {
  RuntimeCheck check;
  ParseDiagnostic diag;
  auto small = std::make_unique<Predictor<double, DefaultCapacity>>();
  check.load_status = small->load(coef_text.data(), coef_text.size(), &diag);
  if (check.load_status == LoadStatus::ok) {
    check.fit = RuntimeFit::default_capacity;
    replay_with(*small, r, e, check);
    return check;
  }
  const std::string small_reason = fmt::format("default capacity: {} at line {}: {}",
                                               to_string(check.load_status), diag.line, diag.reason);
  auto big = std::make_unique<Predictor<double, FitCapacity>>();
  ParseDiagnostic diag2;
  check.load_status = big->load(coef_text.data(), coef_text.size(), &diag2);
  if (check.load_status == LoadStatus::ok) {
    check.fit = RuntimeFit::needs_fit_capacity;
    check.detail = small_reason;
    replay_with(*big, r, e, check);
    return check;
  }
  check.fit = RuntimeFit::refused;
  check.detail = fmt::format("{}; fit capacity: {} at line {}: {}", small_reason,
                             to_string(check.load_status), diag2.line, diag2.reason);
  return check;
}

std::string estimates_text_table(const std::vector<ParameterEstimate>& parameters) {
  std::string t = fmt::format("  {:<10} {:>14} {:>12} {:>12}\n", "parameter", "estimate", "CR bound", "colored");
  for (const ParameterEstimate& p : parameters) {
    if (p.identifiability == Identifiability::identified)
      t += fmt::format("  {:<10} {:>14.6g} {:>12.4g} {:>12.4g}\n", p.name, p.value, p.cr_bound,
                       p.cr_bound_colored);
    else
      t += fmt::format("  {:<10} {:>14.6g} {:>25}\n", p.name, p.value, "not identifiable");
  }
  return t;
}

// ------------------------------------------------------------------------------------------
// fit.json
// ------------------------------------------------------------------------------------------
nlohmann::json with_provenance_and_warnings(nlohmann::json j, const ReportOptions& ro) {
  if (!ro.provenance.version.empty()) j["provenance"] = provenance_json(ro.provenance);
  j["warnings"] = ro.warnings;
  return j;
}

std::vector<std::string> fit_warnings(const FitResult& r, const Experiment& e) {
  std::vector<std::string> w;
  // Why first: replicates' spread is the noise; a residual's short-lag level is noise only
  // where the model is right (replication.hpp).
  const ReplicationNoise rep = replication_noise(e);
  if (rep.source != NoiseSource::none) {
    if (std::isfinite(r.fit_error) && rep.sigma > 0.0 && r.fit_error > kFitErrorNoiseRatio * rep.sigma)
      w.push_back(fmt::format(
          "{}: the fit error s(v) = {:.4g} is {:.1f} times the noise level from replication ({:.4g}: {}); "
          "more than {:g} times means the model misses an effect or the input is wrong: check the angle "
          "units and columns, or run `indicial diagnose`",
          e.path, r.fit_error, r.fit_error / rep.sigma, rep.sigma, rep.detail, kFitErrorNoiseRatio));
    return w;
  }
  const NoiseEstimate noise = estimate_noise_level(r.runs);
  // Why the white-equivalent level: a model error leaks into the marginal (AR(1)) level and
  // would hide itself; the second difference does not pass it (noise_level.hpp).
  const double level = noise.white_equivalent;
  if (std::isfinite(r.fit_error) && level > 0.0 && r.fit_error > kFitErrorNoiseRatio * level) {
    w.push_back(fmt::format(
        "{}: the fit error s(v) = {:.4g} is {:.1f} times the short-lag level of the fit's own residual "
        "({:.4g}, white-equivalent, from the residuals' second differences; their AR(1) phi is {:.2f}): "
        "more than {:g} times, the residual is smooth and structured -- wrong input (check the angle units "
        "and columns) or a missing effect. That level comes from this model's residual, not from "
        "replicated data, so it is not a measurement of the noise: `indicial diagnose` decides whether an "
        "effect is missing",
        e.path, r.fit_error, r.fit_error / level, level, noise.lag1_correlation, kFitErrorNoiseRatio));
  }
  std::string weak;
  for (const ParameterEstimate& p : r.parameters)
    if (bound_exceeds_value(p)) weak += fmt::format("{}{} = {:.4g} +- {:.4g}", weak.empty() ? "" : ", ", p.name, p.value, p.cr_bound);
  if (!weak.empty())
    w.push_back(fmt::format("{}: ill-conditioned estimates (Cramer-Rao bound larger than the value): {}; the data "
                            "do not determine them (remove the terms, or add runs that excite them)",
                            e.path, weak));
  return w;
}

namespace {

nlohmann::json parameter_json(const ParameterEstimate& p) {
  nlohmann::json j;
  j["name"] = p.name;
  j["value"] = finite_or_null(p.value);
  const bool identified = p.identifiability == Identifiability::identified;
  j["cr_bound"] = identified ? finite_or_null(p.cr_bound) : nlohmann::json(nullptr);
  j["cr_bound_colored"] = identified ? finite_or_null(p.cr_bound_colored) : nlohmann::json(nullptr);
  j["identifiable"] = identified;
  return j;
}

nlohmann::json stepwise_json(const StepwiseResult& s) {
  nlohmann::json j;
  j["steps"] = nlohmann::json::array();
  for (const StepwiseStep& st : s.steps) {
    j["steps"].push_back({{"step", st.step},
                          {"term", st.term},
                          {"action", st.action == StepwiseAction::entered ? "entered" : "removed"},
                          {"partial_f", finite_or_null(st.partial_f)},
                          {"partial_f_white", finite_or_null(st.partial_f_white)},
                          {"r_squared", finite_or_null(st.r_squared)},
                          {"pse", finite_or_null(st.pse)},
                          {"n_terms", st.n_terms}});
  }
  j["selected"] = s.selected;
  j["min_pse"] = finite_or_null(s.min_pse);
  j["n_samples"] = s.n_samples;
  return j;
}

const char* state_derivative_name(StateDerivative d) {
  return d == StateDerivative::smoothed_difference ? "smoothed" : "modulating";
}

// One iteration of the two-stage loop (fit.json's `two_stage` entries).
nlohmann::json two_stage_iteration_json(const TwoStageIteration& it) {
  nlohmann::json t;
  t["iteration"] = it.iteration;
  t["cost"] = finite_or_null(it.cost);
  t["fit_error"] = finite_or_null(it.fit_error);
  t["rotary"] = nlohmann::json::array();
  for (double v : it.rotary) t["rotary"].push_back(finite_or_null(v));
  t["rotary_knot_coef"] = nlohmann::json::array();
  for (double v : it.rotary_knot_coef) t["rotary_knot_coef"].push_back(finite_or_null(v));
  t["rotary_parameters"] = nlohmann::json::array();
  for (const ParameterEstimate& p : it.rotary_parameters) t["rotary_parameters"].push_back(parameter_json(p));
  t["stepwise"] = stepwise_json(it.stepwise);
  return t;
}

// The final C_aq(x) of the model (fit.json's `rotary`).
nlohmann::json rotary_json(const CoefficientModel<double, FitCapacity>& cm, const Experiment& e) {
  nlohmann::json rot;
  rot["estimated"] = e.rotary.estimate;
  rot["polynomial"] = nlohmann::json::array();
  for (int i = 0; i < cm.rotary.n_powers; ++i) rot["polynomial"].push_back(cm.rotary.power_coef[i]);
  rot["knots_rad"] = nlohmann::json::array();
  rot["knot_coef"] = nlohmann::json::array();
  for (int k = 0; k < cm.rotary.n_knots; ++k) {
    rot["knots_rad"].push_back(cm.rotary.knot_rad[k]);
    rot["knot_coef"].push_back(cm.rotary.knot_coef[k]);
  }
  return rot;
}

}  // namespace

nlohmann::json fit_json(const FitResult& r, const Experiment& e, const FitOptions& o,
                        const RuntimeCheck* runtime) {
  const OutputErrorSummary& oe = r.output_error;
  nlohmann::json j;
  // The contract's fields first (interface.md), then the extensions.
  j["converged"] = oe.termination == Termination::converged;
  j["iterations"] = oe.iterations;
  j["fit_error"] = finite_or_null(r.fit_error);
  {
    // The noise: the replicates' spread where there are replicates; otherwise the residual's
    // short-lag level, said to be that (issue 21, item 1).
    const ReplicationNoise rep = replication_noise(e);
    const bool replicated = rep.source != NoiseSource::none;
    j["noise_source"] = replicated ? noise_source_name(rep.source) : "residual_differences";
    j["noise_source_detail"] = rep.detail;
    j["noise_estimate"] = finite_or_null(replicated ? rep.sigma : estimate_noise_level(r.runs).white_equivalent);
  }
  j["parameters"] = nlohmann::json::array();
  for (const ParameterEstimate& p : r.parameters) j["parameters"].push_back(parameter_json(p));
  if (e.rotary.estimate) {
    j["two_stage"] = nlohmann::json::array();
    for (const TwoStageIteration& it : r.two_stage) j["two_stage"].push_back(two_stage_iteration_json(it));
  }
  j["termination"] = termination_name(oe.termination);
  j["message"] = oe.message;
  j["feasibility_boundary"] = oe.boundary == FeasibilityBoundary::active ? "active" : "interior";
  j["infeasible_trials"] = oe.infeasible_trials;
  j["cost"] = finite_or_null(oe.cost);
  j["n_samples"] = oe.n_samples;
  j["n_parameters"] = oe.n_parameters;
  j["rank"] = oe.rank;
  j["correlation_lag"] = oe.correlation_lag;
  j["unidentifiable"] = oe.unidentifiable;
  j["output_error_log"] = nlohmann::json::array();
  for (const OutputErrorIteration& it : oe.log) {
    j["output_error_log"].push_back({{"iteration", it.iteration},
                                     {"cost", finite_or_null(it.cost)},
                                     {"damping", finite_or_null(it.damping)},
                                     {"max_step_in_bounds", finite_or_null(it.max_step_in_bounds)}});
  }
  const EquationErrorResult& ee = r.equation_error;
  nlohmann::json eej;
  eej["fit_error"] = finite_or_null(ee.fit_error);
  eej["r_squared"] = finite_or_null(ee.r_squared);
  eej["n_samples"] = ee.n_samples;
  eej["correlation_lag"] = ee.correlation_lag;
  eej["state_derivative"] = state_derivative_name(ee.state_derivative);
  eej["parameters"] = nlohmann::json::array();
  for (const ParameterEstimate& p : ee.parameters) eej["parameters"].push_back(parameter_json(p));
  eej["stepwise"] = stepwise_json(ee.stepwise);
  j["equation_error"] = eej;
  j["rotary"] = rotary_json(r.model.coefficients[0], e);
  j["runs"] = nlohmann::json::array();
  for (std::size_t ri = 0; ri < r.runs.size(); ++ri) {
    const RunSeries& s = r.runs[ri];
    nlohmann::json run = {{"path", display_path(s.path, e)}, {"samples", s.time_s.size()}, {"fit_error", finite_or_null(run_fit_error(s))}};
    if (ri < e.runs.size()) {  // the run's own airspeed and time grid (issue 12)
      run["airspeed_mps"] = e.runs[ri].airspeed_mps;
      run["time_grid"] = name_of(e.runs[ri].time_grid);
    }
    j["runs"].push_back(run);
  }
  j["experiment"] = {{"path", e.path},
                     {"axis", axis_name(e.axis)},
                     {"coefficient", e.coefficient},
                     {"structure", e.model.structure == StructureMode::stepwise ? "stepwise" : "fixed"}};
  if (!r.output_error_stepwise.selected.empty()) {
    nlohmann::json steps = nlohmann::json::array();
    for (const OutputErrorStepwiseStep& st : r.output_error_stepwise.steps)
      steps.push_back({{"action", st.action == OutputErrorStepwiseStep::Action::entered ? "entered" : "removed"},
                       {"term", st.term},
                       {"f", finite_or_null(st.f)},
                       {"f_white", finite_or_null(st.f_white)},
                       {"sse_before", finite_or_null(st.sse_before)},
                       {"sse_after", finite_or_null(st.sse_after)}});
    j["output_error_stepwise"] = {{"steps", steps}, {"selected", r.output_error_stepwise.selected}};
  }
  if (!r.stepwise_fallback.empty()) j["stepwise_fallback"] = r.stepwise_fallback;
  j["options"] = {{"f_to_enter", o.f_to_enter},
                  {"f_to_remove", o.f_to_remove},
                  {"stepwise_refinement",
                   o.stepwise_refinement == StepwiseRefinement::output_error ? "output_error" : "none"},
                  {"stepwise_significance",
                   o.stepwise_significance == StepwiseSignificance::white_residuals ? "white" : "colored"},
                  {"stepwise_fallback", o.stepwise_fallback == StepwiseFallback::off ? "off" : "automatic"},
                  {"fallback_r_squared", o.fallback_r_squared},
                  {"max_iterations", o.max_iterations},
                  {"cost_tolerance", o.cost_tolerance},
                  {"step_tolerance", o.step_tolerance},
                  {"sv_cutoff", o.sv_cutoff},
                  {"state_derivative", state_derivative_name(o.state_derivative)},
                  {"max_two_stage_iterations", o.max_two_stage_iterations}};
  if (runtime != nullptr) {
    j["runtime_check"] = {{"loads_with", runtime_fit_name(runtime->fit)},
                          {"load_status", to_string(runtime->load_status)},
                          {"detail", runtime->detail},
                          {"max_abs_difference", finite_or_null(runtime->max_abs_difference)},
                          {"samples_compared", runtime->samples_compared},
                          {"runs_replayed", runtime->runs_replayed},
                          {"steps_not_ok", runtime->steps_not_ok}};
  }
  j["elapsed_s"] = r.elapsed_s;
  return j;
}

// ------------------------------------------------------------------------------------------
// Plots (gnuplot) and report.md
// ------------------------------------------------------------------------------------------
std::vector<std::size_t> thinned_indices(std::size_t n, std::size_t max_points) {
  std::vector<std::size_t> idx;
  if (n == 0) return idx;
  // Why max_points - 1: the last sample is always kept, so the stride leaves room for it.
  const std::size_t slots = std::max<std::size_t>(max_points, 2) - 1;
  const std::size_t stride = n <= max_points ? 1 : (n - 1 + slots - 1) / slots;
  for (std::size_t k = 0; k < n; k += stride) idx.push_back(k);
  if (idx.back() != n - 1) idx.push_back(n - 1);
  return idx;
}

namespace {

constexpr double kDegPerRad = 57.29577951308232;

std::string sh_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "'\\''";
    else q += c;
  }
  return q + "'";
}

// gnuplot string literal in single quotes (a quote is doubled).
std::string gp_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "''";
    else q += c;
  }
  return q + "'";
}

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("-"); }

std::string rel_percent(double bound, double value) {
  if (!std::isfinite(bound) || !std::isfinite(value) || value == 0.0) return "-";
  return fmt::format("{:.2f}", 100.0 * bound / std::fabs(value));
}

bool rotary_terms_estimated(const FitResult& r) {
  for (const ParameterEstimate& p : r.parameters)
    if (p.id.kind == ParamKind::rotary_power || p.id.kind == ParamKind::rotary_knot) return true;
  return false;
}

PlotSet make_plots(const FitResult& r, const Experiment& e, const OutputDir& out,
                   const ReportOptions& ro) {
  if (ro.plots == PlotRequest::none) {
    PlotSet ps;
    ps.message = "plots not requested";
    return ps;
  }
  std::string gp;
  gp += "# gnuplot script written by indicial fit; run `gnuplot plots.gp` in this directory.\n";
  gp += "set terminal pngcairo size 960,540 enhanced font ',10'\n";
  gp += "set grid\nset key outside right top\n";
  std::vector<std::string> expected;
  const std::string coef = e.coefficient;
  for (std::size_t ri = 0; ri < r.runs.size(); ++ri) {
    const RunSeries& s = r.runs[ri];
    const std::string dat = fmt::format("run{}.dat", ri + 1);
    const std::vector<std::size_t> shown = thinned_indices(s.time_s.size());
    std::string text = fmt::format("# time_s measured model quasi_steady residual x_deg ({} of {} samples)\n",
                                   shown.size(), s.time_s.size());
    for (std::size_t k : shown) {
      text += fmt::format("{} {} {} {} {} {}\n", s.time_s[k], s.measured[k], s.model[k],
                          s.quasi_steady[k], s.residual[k], s.x_rad[k] * kDegPerRad);
    }
    out.write("plots/" + dat, text);
    const std::string fit_png = fmt::format("run{}_fit.png", ri + 1);
    const std::string res_png = fmt::format("run{}_residual.png", ri + 1);
    gp += fmt::format("set output {}\n", gp_quote(fit_png));
    gp += fmt::format("set title {} noenhanced\n", gp_quote("run " + std::to_string(ri + 1) + ": " + display_path(s.path, e)));
    gp += fmt::format("set xlabel 'time, s'\nset ylabel {}\n", gp_quote(coef));
    gp += fmt::format(
        "plot {0} using 1:2 with lines lw 1 lc rgb '#888888' title 'measured', \\\n"
        "     {0} using 1:3 with lines lw 2 lc rgb '#d62728' title 'model', \\\n"
        "     {0} using 1:4 with lines lw 1.5 dt 2 lc rgb '#1f77b4' title 'quasi-steady'\n",
        gp_quote(dat));
    gp += fmt::format("set output {}\n", gp_quote(res_png));
    gp += fmt::format("set title {} noenhanced\n",
                      gp_quote("residuals, run " + std::to_string(ri + 1) + ": " + display_path(s.path, e) +
                               fmt::format("  (rms {:.4g})", run_fit_error(s))));
    gp += fmt::format("set ylabel {}\n", gp_quote(coef + " measured - model"));
    gp += fmt::format("plot {} using 1:5 with lines lc rgb '#2ca02c' title 'residual'\n", gp_quote(dat));
    expected.push_back(fit_png);
    expected.push_back(res_png);
  }
  // The functions over the data's angle range.
  const double lo = e.data_x_min_rad, hi = e.data_x_max_rad;
  const int n = 241;
  std::string ftext =
      "# x_deg a a_lo a_hi a_lo_col a_hi_col b1 b1_lo b1_hi b1_lo_col b1_hi_col caq caq_lo caq_hi "
      "(bands: value -/+ 2 sigma, white and colored)\n";
  for (int i = 0; i < n; ++i) {
    const double x = lo + (hi - lo) * static_cast<double>(i) / static_cast<double>(n - 1);
    ftext += fmt::format("{}", x * kDegPerRad);
    for (ModelFunction f : {ModelFunction::a, ModelFunction::b1, ModelFunction::rotary}) {
      const FunctionBand w = function_band(r, f, x, BoundKind::white);
      ftext += fmt::format(" {} {} {}", w.value, w.value - 2.0 * w.sigma, w.value + 2.0 * w.sigma);
      if (f != ModelFunction::rotary) {
        const FunctionBand c = function_band(r, f, x, BoundKind::colored);
        ftext += fmt::format(" {} {}", c.value - 2.0 * c.sigma, c.value + 2.0 * c.sigma);
      }
    }
    ftext += "\n";
  }
  out.write("plots/functions.dat", ftext);
  const std::string xname = e.axis == Axis::pitch ? "alpha" : "beta";
  gp += "unset title\n";
  gp += fmt::format("set xlabel {}\n", gp_quote(xname + ", deg"));
  struct FPlot {
    const char* png;
    const char* label;
    int col;  // value column
    bool colored;
  };
  const bool rotary_estimated = e.rotary.estimate && rotary_terms_estimated(r);
  for (const FPlot& f : {FPlot{"a_band.png", "a(x)", 2, true}, FPlot{"b1_band.png", "b1(x), 1/s", 7, true},
                         FPlot{"caq_band.png", "C_aq(x)", 12, false}}) {
    gp += fmt::format("set output {}\nset ylabel {} noenhanced\n", gp_quote(f.png), gp_quote(f.label));
    const bool band = f.colored || rotary_estimated;
    std::string cmd = "plot ";
    if (band) {
      cmd += fmt::format(
          "'functions.dat' using 1:{}:{} with filledcurves fc rgb '#9ecae1' fs transparent solid 0.5 "
          "title '+/- 2 sigma (Cramer-Rao)' noenhanced, \\\n     ",
          f.col + 1, f.col + 2);
    }
    if (f.colored) {
      cmd += fmt::format(
          "'functions.dat' using 1:{} with lines dt 2 lc rgb '#555555' title '+/- 2 sigma (colored)' noenhanced, \\\n"
          "     'functions.dat' using 1:{} with lines dt 2 lc rgb '#555555' notitle, \\\n     ",
          f.col + 3, f.col + 4);
    }
    cmd += fmt::format("'functions.dat' using 1:{} with lines lw 2 lc rgb '#08519c' title {} noenhanced\n", f.col,
                       gp_quote(std::string(f.label) +
                                (f.col == 12 && !rotary_estimated ? " (a priori)" : " (estimate)")));
    gp += cmd;
    expected.push_back(f.png);
  }
  return run_gnuplot_script(out, gp, expected, ro);
}

std::string param_table(const std::vector<ParameterEstimate>& ps) {
  std::string t =
      "| parameter | estimate | CR bound | rel. % | colored bound | rel. % | identifiable |\n"
      "|---|---:|---:|---:|---:|---:|---|\n";
  for (const ParameterEstimate& p : ps) {
    const bool id = p.identifiability == Identifiability::identified;
    t += fmt::format("| {} | {} | {} | {} | {} | {} | {} |\n", p.name, num(p.value),
                     id ? num(p.cr_bound) : "-", id ? rel_percent(p.cr_bound, p.value) : "-",
                     id ? num(p.cr_bound_colored) : "-",
                     id ? rel_percent(p.cr_bound_colored, p.value) : "-", id ? "yes" : "**no**");
  }
  return t;
}

std::string stepwise_table(const StepwiseResult& s) {
  if (s.steps.empty()) return "";
  std::string t = "| step | term | action | partial F | R^2 | PSE | terms |\n|---:|---|---|---:|---:|---:|---:|\n";
  for (const StepwiseStep& st : s.steps) {
    t += fmt::format("| {} | {} | {} | {} | {:.6f} | {} | {} |\n", st.step, st.term,
                     st.action == StepwiseAction::entered ? "entered" : "removed", num(st.partial_f),
                     st.r_squared, num(st.pse), st.n_terms);
  }
  std::string sel;
  for (const std::string& n : s.selected) sel += (sel.empty() ? "" : ", ") + n;
  t += fmt::format("\nSelected at the minimum PSE ({}): {} ({} samples).\n", num(s.min_pse),
                   sel.empty() ? "(none)" : sel, s.n_samples);
  return t;
}

std::string image(const PlotSet& ps, const std::string& rel, const std::string& alt) {
  if (std::find(ps.images.begin(), ps.images.end(), rel) == ps.images.end()) return "";
  return fmt::format("![{}]({})\n\n", alt, rel);
}

// The title, the command line and the experiment in one paragraph.
std::string report_header(const FitResult& r, const Experiment& e, const FitOptions& o, const ReportOptions& ro) {
  std::string m;
  m += fmt::format("# Fit report: {} ({} axis)\n\n", e.coefficient, axis_name(e.axis));
  if (!ro.command_line.empty()) m += fmt::format("Command: `{}`\n\n", ro.command_line);
  std::size_t samples = 0;
  for (const Run& run : e.runs) samples += run.size();
  m += fmt::format(
      "Experiment `{}`: {} runs, {} samples, model angle {:.3f} to {:.3f} deg, l/V = {:.6g} s, "
      "structure {}, state derivative for the equation error: {}. Fit took {:.2f} s.\n\n",
      ro.experiment_display.empty() ? e.path : ro.experiment_display, e.runs.size(), samples, e.data_x_min_rad * kDegPerRad, e.data_x_max_rad * kDegPerRad,
      e.l_over_v_s(), e.model.structure == StructureMode::stepwise ? "stepwise" : "fixed",
      o.state_derivative == StateDerivative::smoothed_difference ? "Savitzky-Golay smoothed derivative"
                                                                 : "modulating functions",
      r.elapsed_s);
  return m;
}

// The output-error outcome, the estimates and the per-run fit.
std::string report_result(const FitResult& r, const Experiment& e) {
  std::string m;
  const OutputErrorSummary& oe = r.output_error;
  m += "## Result\n\n";
  m += fmt::format("Output error (maximum likelihood): **{}** after {} iterations. {}\n\n",
                   termination_name(oe.termination), oe.iterations, oe.message);
  m += fmt::format("Fit error s(v) = {} over {} samples; cost J = {}; {} parameters, information-matrix "
                   "rank {}; colored bounds use {} residual autocorrelation lags.\n\n",
                   num(r.fit_error), oe.n_samples, num(oe.cost), oe.n_parameters, oe.rank,
                   oe.correlation_lag);
  // The noise source, as fit.json's noise_source (replication.hpp).
  const ReplicationNoise rep = replication_noise(e);
  m += rep.source != NoiseSource::none
           ? fmt::format("Noise from replication (`{}`): {}; sigma {}, fit error / noise {:.2f}.\n\n",
                         noise_source_name(rep.source), rep.detail, num(rep.sigma), r.fit_error / rep.sigma)
           : "Noise (`residual_differences`): " + rep.detail + ".\n\n";
  if (!oe.unidentifiable.empty()) {
    std::string names;
    for (const std::string& n : oe.unidentifiable) names += (names.empty() ? "" : ", ") + n;
    m += fmt::format("**Not identifiable from these data: {}.** Their bounds are undetermined "
                     "(written as null in fit.json), not large.\n\n", names);
  }
  m += "### Estimates\n\n";
  m += "CR bound: Cramer-Rao bound on the standard error (white residuals). Colored bound: the "
       "same corrected for the residuals' autocorrelation. rel. %: bound / |estimate|.\n\n";
  m += param_table(r.parameters);
  m += "\n";

  m += "### Per-run fit\n\n| run | samples | rms residual |\n|---|---:|---:|\n";
  for (const RunSeries& s : r.runs) m += fmt::format("| {} | {} | {} |\n", display_path(s.path, e), s.time_s.size(), num(run_fit_error(s)));
  m += "\n";
  return m;
}

// Whether model.coef loads in the runtime and how closely it replays the fit.
std::string report_runtime_check(const RuntimeCheck& rc) {
  std::string m;
  m += "### Runtime check\n\n";
  if (rc.fit == RuntimeFit::refused) {
    m += fmt::format("The runtime refuses model.coef: {}.\n\n", rc.detail);
  } else {
    m += fmt::format(
        "model.coef loads in the runtime ({}); replayed over every run from the estimated initial "
        "states, it differs from the fitter's model output by at most {:.3g} over {} steps (each run's "
        "first sample is its initial state, not a step: {} runs){}.{}\n\n",
        rc.fit == RuntimeFit::default_capacity ? "`Predictor<>`, default capacity"
                                               : "only `Predictor<double, FitCapacity>`",
        rc.max_abs_difference, rc.samples_compared, rc.runs_replayed,
        rc.steps_not_ok > 0 ? fmt::format(" ({} steps refused)", rc.steps_not_ok) : std::string(),
        rc.detail.empty() ? std::string() : " Note: " + rc.detail + ".");
  }
  return m;
}

// The plots written (or why none were).
std::string report_plots(const FitResult& r, const Experiment& e, const PlotSet& ps) {
  std::string m;
  m += "## Plots\n\n";
  if (ps.status != PlotStatus::written) m += fmt::format("**No plots: {}.**\n\n", ps.message);
  for (const RunSeries& s : r.runs) {
    if (s.time_s.size() <= kMaxPlotPoints) continue;
    m += fmt::format("Run plots show at most {} points per curve (every k-th sample of a longer run; "
                     "the statistics above use every sample).\n\n", kMaxPlotPoints);
    break;
  }
  m += "### a(x), b1(x), C_aq(x)\n\n";
  m += image(ps, "plots/a_band.png", "a(x) with +/- 2 sigma bands");
  m += image(ps, "plots/b1_band.png", "b1(x) with +/- 2 sigma bands");
  m += image(ps, "plots/caq_band.png", "C_aq(x)");
  for (std::size_t ri = 0; ri < r.runs.size(); ++ri) {
    m += fmt::format("### Run {}: {}\n\n", ri + 1, display_path(r.runs[ri].path, e));
    m += image(ps, fmt::format("plots/run{}_fit.png", ri + 1), "measured, model and quasi-steady");
    m += image(ps, fmt::format("plots/run{}_residual.png", ri + 1), "residuals");
  }
  return m;
}

// The equation error's start values and its stepwise log.
std::string report_equation_error(const FitResult& r, const FitOptions& o) {
  std::string m;
  m += "## Equation error (start values)\n\n";
  const EquationErrorResult& ee = r.equation_error;
  m += fmt::format("Least squares of eq. 22 (SVD, singular-value cut-off {:.1e}): s(e) = {}, R^2 = {:.6f}, "
                   "{} samples, colored bounds with {} lags.\n\n",
                   o.sv_cutoff, num(ee.fit_error), ee.r_squared, ee.n_samples, ee.correlation_lag);
  m += param_table(ee.parameters);
  m += "\n";
  if (!ee.stepwise.steps.empty()) {
    m += fmt::format("### Stepwise regression (F to enter {}, F to remove {})\n\n", o.f_to_enter, o.f_to_remove);
    m += stepwise_table(ee.stepwise);
    m += "\n";
  }
  return m;
}

// The output-error iteration log and how it ended.
std::string report_output_error_log(const OutputErrorSummary& oe) {
  std::string m;
  m += "## Output-error iterations\n\n";
  if (oe.log.empty()) {
    m += "(no iterations logged)\n\n";
  } else {
    m += "| iteration | cost J | LM damping | max step / CR bound |\n|---:|---:|---:|---:|\n";
    for (const OutputErrorIteration& it : oe.log)
      m += fmt::format("| {} | {:.10g} | {} | {} |\n", it.iteration, it.cost, num(it.damping),
                       num(it.max_step_in_bounds));
    m += "\n";
  }
  m += fmt::format("Termination: **{}**: {}\n\n", termination_name(oe.termination), oe.message);
  return m;
}

// With rotary.estimate: the two-stage iterations and their stepwise logs.
std::string report_two_stage(const FitResult& r, const Experiment& e) {
  std::string m;
  if (e.rotary.estimate) {
    m += "## Two-stage loop (C_aq(x) re-estimated)\n\n";
    if (r.two_stage.empty()) {
      m += "(no iterations were run)\n\n";
    } else {
      m += "| iteration | ML cost | s(v) | C_aq polynomial (x^0, x^1, ...) | knot terms |\n|---:|---:|---:|---|---|\n";
      for (const TwoStageIteration& it : r.two_stage) {
        std::string poly, knots;
        for (double v : it.rotary) poly += (poly.empty() ? "" : ", ") + num(v);
        for (double v : it.rotary_knot_coef) knots += (knots.empty() ? "" : ", ") + num(v);
        m += fmt::format("| {} | {:.10g} | {} | {} | {} |\n", it.iteration, it.cost, num(it.fit_error),
                         poly, knots.empty() ? "-" : knots);
      }
      m += "\n";
      for (const TwoStageIteration& it : r.two_stage) {
        if (it.stepwise.steps.empty()) continue;
        m += fmt::format("### Iteration {}: stepwise regression of z on the C_aq candidates\n\n", it.iteration);
        m += stepwise_table(it.stepwise);
        m += "\n";
      }
    }
  }
  return m;
}

std::string report_markdown(const FitResult& r, const Experiment& e, const FitOptions& o,
                            const RuntimeCheck& rc, const PlotSet& ps, const ReportOptions& ro) {
  return report_header(r, e, o, ro) + report_result(r, e) + report_runtime_check(rc) + report_plots(r, e, ps) +
         report_equation_error(r, o) + report_output_error_log(r.output_error) + report_two_stage(r, e) +
         "## Files\n\n"
         "* `fit.json`: the estimates, bounds and logs (contract fields plus extensions)\n"
         "* `model.coef`: the identified model for the runtime (`indicial::Predictor`)\n"
         "* `plots/`: PNG images, the gnuplot script `plots.gp` and its data files\n";
}

}  // namespace

PlotSet run_gnuplot_script(const OutputDir& out, const std::string& script,
                           const std::vector<std::string>& expected_pngs, const ReportOptions& ro) {
  PlotSet ps;
  out.write("plots/plots.gp", script);
  const fs::path plots_dir = out.path("plots");
  const std::string cmdline = "cd " + sh_quote(plots_dir.string()) + " && " + sh_quote(ro.gnuplot) +
                              " plots.gp > gnuplot.log 2>&1";
  const int rc = std::system(cmdline.c_str());
  const int exit_code = (rc != -1 && WIFEXITED(rc)) ? WEXITSTATUS(rc) : -1;
  std::error_code ec;
  if (exit_code == 127 || exit_code == 126) {
    // Why 126/127: the shell's codes for "not executable" and "command not found".
    ps.status = PlotStatus::gnuplot_not_found;
    ps.message = "gnuplot (" + ro.gnuplot + ") could not be run; no plots were made "
                 "(install gnuplot, then run `gnuplot plots.gp` in plots/)";
    fs::remove(plots_dir / "gnuplot.log", ec);
    return ps;
  }
  std::vector<std::string> missing;
  for (const std::string& png : expected_pngs) {
    if (fs::exists(plots_dir / png, ec) && fs::file_size(plots_dir / png, ec) > 0)
      ps.images.push_back("plots/" + png);
    else
      missing.push_back(png);
  }
  if (exit_code != 0 || !missing.empty()) {
    ps.status = PlotStatus::gnuplot_failed;
    ps.message = fmt::format("gnuplot exited with status {} and {} of {} images are missing; see plots/gnuplot.log",
                             exit_code, missing.size(), expected_pngs.size());
    return ps;
  }
  if (fs::exists(plots_dir / "gnuplot.log", ec) && fs::file_size(plots_dir / "gnuplot.log", ec) == 0)
    fs::remove(plots_dir / "gnuplot.log", ec);
  ps.status = PlotStatus::written;
  ps.message = fmt::format("{} plots written by gnuplot", ps.images.size());
  return ps;
}

FitOutputs write_fit_outputs(const FitResult& r, const Experiment& e, const FitOptions& o,
                             const fs::path& dir, Overwrite overwrite, const ReportOptions& ro) {
  FitOutputs w;
  w.dir = dir;
  // Everything that can fail on the model comes before the output directory is touched.
  w.model_coef = with_provenance_header(model_coef_text(r, e.path), ro.provenance);
  w.runtime = replay_in_runtime(r, e, w.model_coef);
  OutputDir out(dir, overwrite);
  const PlotSet ps = make_plots(r, e, out, ro);
  w.plots = ps.status;
  w.plot_message = ps.message;
  w.images = ps.images;
  nlohmann::json j = with_provenance_and_warnings(fit_json(r, e, o, &w.runtime), ro);
  if (!ro.experiment_display.empty()) j["experiment"]["path"] = ro.experiment_display;
  j["plots"] = {{"status", plot_status_name(ps.status)}, {"message", ps.message}, {"images", ps.images}};
  w.fit_json = j.dump(2) + "\n";
  w.report_md = report_markdown(r, e, o, w.runtime, ps, ro);
  out.write("fit.json", w.fit_json);
  out.write("model.coef", w.model_coef);
  out.write("report.md", w.report_md);
  out.commit();
  return w;
}

}  // namespace indicial
