// report.md (see report.hpp) and the terminal table of estimates: words and tables only.
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <string>
#include <vector>

#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/replication.hpp"
#include "indicial/fitter/report.hpp"
#include "report/report_internal.hpp"

namespace indicial {

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


std::string input_as_read_markdown(const ReportOptions& ro) {
  if (ro.notes.empty() && ro.warnings.empty()) return "";
  std::string m = "## Notes and warnings\n\n";
  if (!ro.notes.empty()) {
    m += "What the readers did with the input files:\n\n";
    for (const std::string& n : ro.notes) m += "* " + n + "\n";
    m += "\n";
  }
  if (!ro.warnings.empty()) {
    m += "Warnings:\n\n";
    for (const std::string& w : ro.warnings) m += "* " + w + "\n";
    m += "\n";
  }
  return m;
}

namespace report_detail {
namespace {

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("-"); }

std::string rel_percent(double bound, double value) {
  if (!std::isfinite(bound) || !std::isfinite(value) || value == 0.0) return "-";
  return fmt::format("{:.2f}", 100.0 * bound / std::fabs(value));
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
  if (!e.model.stall.known.empty()) {
    std::string held;
    for (const auto& [name, value] : e.model.stall.known) held += (held.empty() ? "" : ", ") + name + " = " + num(value);
    m += "Held at known values (`model.stall_known`; not estimated, no bounds): " + held + ".\n\n";
  }

  m += "### Per-run fit\n\nmean residual: measured - model averaged over the run (> 0: the model is low); "
       "runs at one condition whose means differ point at a per-run zero drift.\n\n"
       "| run | samples | rms residual | mean residual |\n|---|---:|---:|---:|\n";
  for (const RunSeries& s : r.runs)
    m += fmt::format("| {} | {} | {} | {} |\n", display_path(s.path, e), s.time_s.size(), num(run_fit_error(s)),
                     num(run_mean_residual(s)));
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

// With the stall start grid: each start and the fit error it ended at, the kept one marked.
std::string report_stall_start_search(const StallStartSearchResult& ss) {
  if (ss.chosen < 0) return "";
  std::string m = "## Stall start search (the output error from each start; the lowest cost kept)\n\n"
                  "| start | varied start values (l / V) | s(v) | kept |\n|---:|---|---:|---|\n";
  for (std::size_t k = 0; k < ss.trials.size(); ++k) {
    std::string start;
    for (const auto& [name, value] : ss.trials[k].start) start += fmt::format("{}{} = {}", start.empty() ? "" : ", ", name, num(value));
    if (!ss.trials[k].origin.empty()) start += (start.empty() ? "" : "; ") + ss.trials[k].origin;
    m += fmt::format("| {} | {} | {} | {} |\n", k == 0 ? "configured" : std::to_string(k), start,
                     num(ss.trials[k].fit_error), static_cast<int>(k) == ss.chosen ? "**kept**" : "");
  }
  return m + "\n";
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

}  // namespace

std::string report_markdown(const FitResult& r, const Experiment& e, const FitOptions& o,
                            const RuntimeCheck& rc, const PlotSet& ps, const ReportOptions& ro) {
  return report_header(r, e, o, ro) + input_as_read_markdown(ro) + report_result(r, e) + report_runtime_check(rc) + report_plots(r, e, ps) +
         report_equation_error(r, o) + report_stall_start_search(r.stall_start_search) +
         report_output_error_log(r.output_error) + report_two_stage(r, e) +
         "## Files\n\n"
         "* `fit.json`: the estimates, bounds and logs (contract fields plus extensions)\n"
         "* `model.coef`: the identified model for the runtime (`indicial::Predictor`)\n"
         "* `plots/`: PNG images, the gnuplot script `plots.gp` and its data files\n";
}

}  // namespace report_detail
}  // namespace indicial
