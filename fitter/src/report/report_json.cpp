// fit.json (see report.hpp, fit_json) and the JSON helpers the fit and diagnose outputs share.
#include <cmath>
#include <string>
#include <vector>

#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/noise_level.hpp"
#include "indicial/fitter/replication.hpp"
#include "indicial/fitter/report.hpp"
#include "report/report_internal.hpp"

namespace indicial {

using report_detail::display_path;

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

// ------------------------------------------------------------------------------------------
// fit.json
// ------------------------------------------------------------------------------------------
nlohmann::json with_provenance_and_warnings(nlohmann::json j, const ReportOptions& ro) {
  if (!ro.provenance.version.empty()) j["provenance"] = provenance_json(ro.provenance);
  j["warnings"] = ro.warnings;
  j["input_notes"] = ro.notes;
  return j;
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

// fit.json's "equation_error": the start values' regression and its stepwise log.
nlohmann::json equation_error_json(const EquationErrorResult& ee) {
  nlohmann::json eej;
  eej["fit_error"] = finite_or_null(ee.fit_error);
  eej["r_squared"] = finite_or_null(ee.r_squared);
  eej["n_samples"] = ee.n_samples;
  eej["correlation_lag"] = ee.correlation_lag;
  eej["state_derivative"] = state_derivative_name(ee.state_derivative);
  eej["parameters"] = nlohmann::json::array();
  for (const ParameterEstimate& p : ee.parameters) eej["parameters"].push_back(parameter_json(p));
  eej["stepwise"] = stepwise_json(ee.stepwise);
  return eej;
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
  if (!e.model.stall.known.empty()) {
    j["held_parameters"] = nlohmann::json::object();  // model.stall_known: not estimated
    for (const auto& [name, value] : e.model.stall.known) j["held_parameters"][name] = value;
  }
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
  j["equation_error"] = equation_error_json(r.equation_error);
  j["rotary"] = rotary_json(r.model.coefficients[0], e);
  j["runs"] = nlohmann::json::array();
  for (std::size_t ri = 0; ri < r.runs.size(); ++ri) {
    const RunSeries& s = r.runs[ri];
    nlohmann::json run = {{"path", display_path(s.path, e)}, {"samples", s.time_s.size()}, {"fit_error", finite_or_null(run_fit_error(s))},
                          {"mean_residual", finite_or_null(run_mean_residual(s))}};
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
  if (r.stall_start_search.chosen >= 0) {
    nlohmann::json trials = nlohmann::json::array();
    for (const StallStartTrial& t : r.stall_start_search.trials) {
      nlohmann::json start = nlohmann::json::object();
      for (const auto& [name, value] : t.start) start[name] = value;
      nlohmann::json trial = {{"start", start}, {"fit_error", finite_or_null(t.fit_error)}};
      if (!t.origin.empty()) trial["origin"] = t.origin;
      trials.push_back(std::move(trial));
    }
    j["stall_start_search"] = {{"chosen", r.stall_start_search.chosen}, {"trials", trials}};
  }
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
                  {"max_two_stage_iterations", o.max_two_stage_iterations},
                  {"stall_start_search", stall_start_search_name(o.stall_start_search)},
                  {"stall_prior", stall_prior_name(o.stall_prior)},
                  {"threads", o.threads}};
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


}  // namespace indicial
