// diagnose_output.cpp -- the outputs of `indicial diagnose`: diagnosis.json (one function,
// diagnosis_json), report.md, the residual plots (gnuplot) and the diagnosed experiment file.
// No numerics here beyond formatting (the algorithm is diagnose.cpp).
#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "diagnose/diagnose_internal.hpp"
#include "estimate/fit_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/report.hpp"

namespace indicial {

namespace fs = std::filesystem;
using diagnose_detail::kRadToDeg;
using diagnose_detail::total_samples;

// ==========================================================================================
// Outputs
// ==========================================================================================
namespace {

// The source file's [columns] and [csv], so that the written experiment.toml reads the same run
// files. An experiment built in memory has no source file, and its path may still name one: a
// Python Experiment's path is its name ("experiment" by default), which may be a directory or
// any other file in the working directory. So only a regular file is read, and one whose
// [columns] / [csv] cannot be read gives the defaults (the Experiment diagnosed, not that
// file, is what the written file describes), and *problem (when given) says why, for
// diagnose_warnings.
RunCsvOptions source_run_file_format(const Experiment& e, std::string* problem = nullptr) {
  std::error_code ec;
  if (e.path.empty() || !fs::is_regular_file(e.path, ec)) return {};
  try {
    return run_file_format(e.path);
  } catch (const InputError& err) {
    if (problem != nullptr)
      *problem = fmt::format("{}: [columns] and [csv] not read ({}); the diagnosed experiment.toml has the defaults",
                             e.path, err.what());
    return {};
  }
}

nlohmann::json candidate_json(const CandidateScore& c) {
  nlohmann::json j;
  j["effect"] = effect_name(c.effect);
  j["term"] = c.term;
  j["detail"] = c.detail;
  j["status"] = candidate_status_name(c.status);
  if (c.status == CandidateStatus::fitted) {
    j["added_parameters"] = c.added_parameters;
    j["fit_error"] = finite_or_null(c.fit_error);
    j["statistic"] = finite_or_null(c.statistic);
    j["raw_statistic"] = finite_or_null(c.raw_statistic);
    j["correlation_factor"] = finite_or_null(c.correlation_factor);
    j["p_value"] = c.p_value;
    j["log10_p_value"] = finite_or_null(c.log10_p);
    j["delta_bic"] = finite_or_null(c.delta_bic);
    if (!c.message.empty()) j["message"] = c.message;  // e.g. a stall family refitted from the grid
  } else {
    j["message"] = c.message;
  }
  return j;
}

std::string num(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : std::string("-"); }

std::string pval(double p, double log10p) {
  if (p > 0.0 && p >= 1e-300) return fmt::format("{:.3g}", p);
  return fmt::format("1e{:.0f}", std::floor(log10p));
}

// Residuals against time (one panel per run) and against the model angle, before and after
// each step (or of the configured model when there is no step). Same conventions as the fit
// report (run_gnuplot_script): plots/plots.gp and its data files stay beside the images.
PlotSet make_plots(const DiagnoseResult& d, const OutputDir& out, const ReportOptions& ro) {
  if (ro.plots == PlotRequest::none) {
    PlotSet ps;
    ps.message = "plots not requested";
    return ps;
  }
  for (std::size_t f = 0; f < d.fits.size(); ++f) {
    for (std::size_t r = 0; r < d.fits[f].runs.size(); ++r) {
      const RunSeries& s = d.fits[f].runs[r];
      std::string t = "# time_s x_deg residual\n";
      for (std::size_t i = 0; i < s.residual.size(); ++i)
        t += fmt::format("{:.6g} {:.6g} {:.6g}\n", s.time_s[i], s.x_rad[i] * kRadToDeg, s.residual[i]);
      out.write(fmt::format("plots/fit{}_run{}.dat", f, r + 1), t);
    }
  }
  const std::size_t n_runs = d.fits.front().runs.size();
  std::string gp = "# gnuplot script written by indicial diagnose; run `gnuplot plots.gp` here.\n";
  std::vector<std::string> expected;
  auto pair_plots = [&](std::size_t before, std::size_t after, const std::string& stem,
                        const std::string& title) {
    const bool two = before != after;
    const std::string png_t = stem + "_time.png";
    gp += fmt::format("set terminal pngcairo size 1000,{} noenhanced\nset output '{}'\n",
                      std::max<std::size_t>(300, 230 * n_runs), png_t);
    gp += fmt::format("set multiplot layout {},1 title '{}: residual (measured - model) against time'\n",
                      n_runs, title);
    for (std::size_t r = 1; r <= n_runs; ++r) {
      gp += fmt::format("set xlabel 'time (s)'\nset ylabel 'run {}'\nset grid\n", r);
      if (two)
        gp += fmt::format("plot 'fit{}_run{}.dat' u 1:3 w l lc rgb '#bbbbbb' title 'before', "
                          "'fit{}_run{}.dat' u 1:3 w l lc rgb '#08519c' title 'after'\n",
                          before, r, after, r);
      else
        gp += fmt::format("plot 'fit{}_run{}.dat' u 1:3 w l lc rgb '#08519c' title 'configured model'\n",
                          after, r);
    }
    gp += "unset multiplot\nset output\n";
    expected.push_back(png_t);
    const std::string png_a = stem + "_angle.png";
    gp += fmt::format("set terminal pngcairo size 1000,450 noenhanced\nset output '{}'\n", png_a);
    gp += fmt::format("set title '{}: residual against the model angle'\nset xlabel 'x (deg)'\n"
                      "set ylabel 'residual'\nset grid\nplot ", title);
    std::string items;
    for (std::size_t r = 1; r <= n_runs; ++r) {
      if (two)
        items += fmt::format("{}'fit{}_run{}.dat' u 2:3 w p pt 7 ps 0.3 lc rgb '#bbbbbb' title '{}'",
                             items.empty() ? "" : ", ", before, r, r == 1 ? "before" : "");
    }
    for (std::size_t r = 1; r <= n_runs; ++r)
      items += fmt::format("{}'fit{}_run{}.dat' u 2:3 w p pt 7 ps 0.3 lc rgb '#08519c' title '{}'",
                           items.empty() ? "" : ", ", after, r,
                           r == 1 ? (two ? "after" : "configured model") : "");
    gp += items + "\nunset title\nset output\n";
    expected.push_back(png_a);
  };
  if (d.steps.empty()) {
    pair_plots(0, 0, "initial", "configured model");
  } else {
    for (std::size_t k = 1; k <= d.steps.size(); ++k)
      pair_plots(k - 1, k, fmt::format("step{}", k),
                 fmt::format("step {}: {} ({})", k, effect_name(d.steps[k - 1].effect),
                             d.steps[k - 1].detail));
  }
  return run_gnuplot_script(out, gp, expected, ro);
}

std::string rms_list(const std::vector<double>& v) {
  std::string s;
  for (double x : v) s += (s.empty() ? "" : ", ") + num(x);
  return s;
}

std::string names_of(const std::vector<Effect>& v) {
  std::string s;
  for (Effect e : v) s += (s.empty() ? "`" : ", `") + std::string(effect_name(e)) + "`";
  return s;
}

// "the configured model, the model after step 2": DiagnoseResult::unconverged_models in words.
std::string unconverged_models_text(const DiagnoseResult& d) {
  std::string l;
  for (int k : d.unconverged_models)
    l += (l.empty() ? "" : ", ") + (k == 0 ? std::string("the configured model") : fmt::format("the model after step {}", k));
  return l;
}

std::string verdict_markdown(const DiagnoseResult& d) {
  std::string md = fmt::format("**Verdict: `{}`**", d.verdict);
  if (d.effects_added.size() > 1) {
    std::string l;
    for (const auto& s : d.effects_added) l += (l.empty() ? "" : ", ") + s;
    md += fmt::format(" (effects added in order: {})", l);
  }
  md += "\n\n";
  if (!d.steps.empty() && !d.steps.front().indistinguishable.empty()) {
    const DiagnoseStep& first = d.steps.front();
    md += fmt::format("The data cannot tell `{}` from {} (their best sub-models are within the BIC margin); "
                      "the simpler is named. What would separate them: for `{}`, {}",
                      d.verdict, names_of(first.indistinguishable), d.verdict,
                      effect_descriptions()[static_cast<std::size_t>(first.effect)].separated_by);
    for (Effect twin : first.indistinguishable)
      md += fmt::format("; for `{}`, {}", effect_name(twin),
                        effect_descriptions()[static_cast<std::size_t>(twin)].separated_by);
    md += ".\n\n";
  }
  if (d.stopped == DiagnoseStop::max_steps)
    md += fmt::format("**Stopped at --max-steps ({} steps) with `{}` still significant**: the model is "
                      "not complete; the final fit error is not the noise level.\n\n",
                      d.steps.size(), d.still_significant);
  if (!d.unconverged_models.empty())
    md += fmt::format("**Not converged**: {} still ended at the iteration limit after being fitted on from its "
                      "estimates to {} times the limit; the candidates were compared against it.\n\n",
                      unconverged_models_text(d), model_iteration_factor);
  if (!d.ill_conditioned.empty()) {
    std::string l;
    for (const auto& s : d.ill_conditioned) l += (l.empty() ? "" : ", ") + s;
    md += fmt::format("**Ill-conditioned estimates** (Cramer-Rao bound larger than the value): {}.\n\n", l);
  }
  return md;
}

std::string steps_markdown(const DiagnoseResult& d) {
  std::string md = "## Steps\n\n";
  if (d.steps.empty())
    return md + "No candidate effect is significant: the model is left as configured (verdict `none`).\n\n";
  md += "| step | effect | detail | LR / kappa | kappa | dp | p-value | threshold alpha/M (M) | delta BIC | "
        "fit error before | after | run RMS before | run RMS after | indistinguishable from |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const DiagnoseStep& s : d.steps)
    md += fmt::format("| {} | `{}` | {} | {:.1f} | {:.2f} | {} | {} | {:.3g} ({}) | {:.1f} | {} | {} | {} | {} | {} |\n",
                      s.step, effect_name(s.effect), s.detail, s.statistic, s.correlation_factor,
                      s.added_parameters, pval(s.p_value, s.log10_p), s.threshold, s.candidates_tested,
                      s.delta_bic, num(s.fit_error_before), num(s.fit_error_after), rms_list(s.run_rms_before),
                      rms_list(s.run_rms_after), s.indistinguishable.empty() ? "-" : names_of(s.indistinguishable));
  md += "\n";
  for (const DiagnoseStep& s : d.steps) {
    md += fmt::format("Step {} decided by `{}`", s.step, decision_rule_name(s.rule));
    if (s.rule == DecisionRule::leave_one_run_out)
      md += fmt::format(": held-out RMS per run (each run predicted by the model fitted to the others) {} "
                        "without it, {} with it; mean ln(MSE ratio) {:.3f} +- {:.3f} (its LR / kappa, p-value "
                        "and threshold are the likelihood-ratio rule's reading, for comparison: they did not "
                        "decide it)",
                        rms_list(s.held_out_rms_before), rms_list(s.held_out_rms_after), s.held_out_log_ratio,
                        s.held_out_standard_error);
    md += ".\n";
  }
  return md + "\n";
}

std::string held_out_markdown(const DiagnoseRound& r) {
  if (r.rule != DecisionRule::leave_one_run_out) return "";
  std::string md = fmt::format("Held-out tests (leave one run out; the model of this round predicts the runs at RMS {}):\n\n",
                               rms_list(r.held_out_base_rms));
  const auto& shares = r.held_out_scored_fraction;
  if (std::any_of(shares.begin(), shares.end(), [](double f) { return f < 1.0; })) {
    std::string list;
    for (double f : shares) list += (list.empty() ? "" : ", ") + fmt::format("{:.1f} %", 100.0 * f);
    md += fmt::format(
        "A left-out run is scored on its samples inside the angle range of the runs its fold fitted, widened by a "
        "tenth of its width at each end, or on all of them when fewer than a quarter are inside (beyond the range "
        "every fitted angle-dependent term is held at its edge, a static table alone following the angle: an "
        "extrapolation, not a test of the term): "
        "{} of each run's samples.\n\n", list);
  }
  md += "| effect | stage | terms | held-out RMS per run without | with | mean ln(MSE with / without) | SE | enters |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const HeldOutTest& t : r.held_out)
    md += fmt::format("| `{}` | {} | {} | {} | {} | {} | {} | {} |\n", effect_name(t.effect), t.stage, t.terms,
                      rms_list(t.rms_without), rms_list(t.rms_with), num(t.mean_log_ratio), num(t.standard_error),
                      t.enters ? "**yes**" : (t.message.empty() ? "no" : "no: " + t.message));
  return md + "\n";
}

std::string signature_markdown(const ResidualSignature& g) {
  std::string md = fmt::format(
      "Residual signatures (shares of the residual sum of squares): angle alone {:.3f} (static error), "
      "stroke direction {:.3f} (hysteresis: unsteady, delay), in phase with the rate {:.3f} (rotary, "
      "delay), per-run constant {:.3f} (bias).\n\n| run | RMS rate (deg/s) | hysteresis (RMS half up-down) | "
      "residual / rate gain | mean residual |\n|---|---|---|---|---|\n",
      g.angle_only, g.hysteresis, g.rate_in_phase, g.constant);
  for (std::size_t r = 0; r < g.run_mean.size(); ++r)
    md += fmt::format("| {} | {:.1f} | {} | {} | {} |\n", r + 1, g.run_rms_rate[r] * kRadToDeg,
                      num(g.run_hysteresis[r]), num(g.run_rate_gain[r]), num(g.run_mean[r]));
  return md + "\n";
}

std::string round_markdown(const DiagnoseRound& r) {
  std::string md = fmt::format("### Round {} (base fit error {}, M = {}, threshold {:.3g}){}\n\n", r.round,
                               num(r.base_fit_error), r.candidates_tested, r.threshold,
                               r.check_only ? ": the check after --max-steps (nothing added)"
                                            : (r.added ? "" : ": nothing significant"));
  md += fmt::format("Rule: `{}`{}.\n\n", decision_rule_name(r.rule), r.rule_note.empty() ? "" : " -- " + r.rule_note);
  md += signature_markdown(r.signature);
  md += "Best single term of each effect:\n\n| effect | best term | LR / kappa | kappa | dp | p-value | delta BIC | "
        "fit error | candidates |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const EffectDescription& ed : effect_descriptions()) {
    int best = -1, count = 0;
    for (std::size_t i = 0; i < r.candidates.size(); ++i) {
      const CandidateScore& c = r.candidates[i];
      if (c.effect != ed.effect) continue;
      ++count;
      if (c.status == CandidateStatus::fitted &&
          (best < 0 || c.log10_p < r.candidates[static_cast<std::size_t>(best)].log10_p))
        best = static_cast<int>(i);
    }
    if (count == 0) continue;
    if (best < 0) {
      md += fmt::format("| `{}` | (no fit) | | | | | | | {} |\n", ed.name, count);
      continue;
    }
    const CandidateScore& c = r.candidates[static_cast<std::size_t>(best)];
    md += fmt::format("| `{}` | {} | {:.1f} | {:.2f} | {} | {} | {:.1f} | {} | {} |\n", ed.name,
                      c.detail.empty() ? c.term : c.detail, c.statistic, c.correlation_factor,
                      c.added_parameters, pval(c.p_value, c.log10_p), c.delta_bic, num(c.fit_error), count);
  }
  if (!r.families.empty()) {
    md += "\nSignificant effects grown into sub-models (stepwise inside the effect) and compared by BIC "
          "(common N_eff):\n\n| effect | terms | dp | fit error | log10 p | delta BIC | |\n|---|---|---|---|---|---|---|\n";
    for (std::size_t i = 0; i < r.families.size(); ++i) {
      const FamilyResult& f = r.families[i];
      md += fmt::format("| `{}` | {} | {} | {} | {:.1f} | {:.1f} | {} |\n", effect_name(f.effect), f.detail,
                        f.added_parameters, num(f.fit_error), f.log10_p, f.delta_bic,
                        static_cast<int>(i) == r.winner ? "**added**" : "");
    }
  }
  md += "\n" + held_out_markdown(r);
  return md + "\n";
}

std::string vocabulary_markdown() {
  std::string md = "## The effects tested\n\n| effect | explains | written to the model as | signature | "
                   "separated from look-alikes by |\n|---|---|---|---|---|\n";
  for (const EffectDescription& ed : effect_descriptions())
    md += fmt::format("| `{}` | {} | {} | {} | {} |\n", ed.name, ed.description, ed.written_as, ed.signature,
                      ed.separated_by);
  return md + "\n";
}

std::string report_markdown(const DiagnoseResult& d, const Experiment& e, const DiagnoseOptions& o,
                            const RuntimeCheck& rc, const PlotSet& ps, const ReportOptions& ro) {
  std::string md = "# indicial diagnose\n\n";
  if (!ro.command_line.empty()) md += "`" + ro.command_line + "`\n\n";
  md += fmt::format("Experiment `{}`: {} of {} axis, {} runs, {} samples.\n\n",
                    ro.experiment_display.empty() ? e.path : ro.experiment_display, e.coefficient,
                    axis_name(e.axis), e.runs.size(), total_samples(e));
  md += verdict_markdown(d);
  md += input_as_read_markdown(ro);
  md += fmt::format("**Decision rule: `{}`** ({}).\n\n", decision_rule_name(d.rule), d.rule_reason);
  md += d.replication.source != NoiseSource::none
            ? fmt::format("**Noise from replication** (`{}`): {} -- sigma {}, lag-1 correlation {:.2f}.\n\n",
                          noise_source_name(d.replication.source), d.replication.detail, num(d.replication.sigma),
                          d.replication.lag1_correlation)
            : "**Noise**: " + d.replication.detail +
                  ". The levels below are the residual's short-lag structure, which is noise only where the "
                  "model is right; they are not used as the noise.\n\n";
  // Why the ratio's denominator: the replicates' sigma where there is replication (the noise);
  // otherwise the final residual's white-equivalent level, said to be that. The AR(1) marginal
  // level divides by (1 - phi) and at phi ~ 0.98 (a smooth model error) exceeds the fit error
  // itself: a trial read 0.348 from it, as if the model were complete, with the replicates at 0.0147.
  const bool replicated = d.replication.source != NoiseSource::none;
  const double noise = replicated ? d.replication.sigma : d.final_noise.white_equivalent;
  md += fmt::format("| | value |\n|---|---|\n| initial fit error s(v) | {} |\n| final fit error | {} |\n"
                    "| final fit error / {} | {:.3g} |\n"
                    "| residual's short-lag level, initial (AR(1) marginal; phi; white-equivalent) | {} ({:.2f}; {}) |\n"
                    "| residual's short-lag level, final (AR(1) marginal; phi; white-equivalent) | {} ({:.2f}; {}) |\n"
                    "| stopped | {} |\n| fits run | {} |\n| elapsed | {:.2f} s |\n\n",
                    num(d.initial_fit_error), num(d.final_fit_error),
                    replicated ? "noise from replication" : "final residual's white-equivalent level (not a noise "
                                                            "measurement)",
                    d.final_fit_error / noise, num(d.noise.sigma), d.noise.lag1_correlation,
                    num(d.noise.white_equivalent), num(d.final_noise.sigma), d.final_noise.lag1_correlation,
                    num(d.final_noise.white_equivalent), diagnose_stop_name(d.stopped), d.fits_run, d.elapsed_s);
  md += "The residual's short-lag level is the marginal standard deviation of AR(1) noise fitted to the "
        "residual's first and second differences, which a smooth model error hardly passes: phi = 1 + 2 r1 "
        "of the first difference, sigma^2 = mean (second difference)^2 / (2 (1 - phi) (3 - phi)). The "
        "white-equivalent level sqrt(mean (second difference)^2 / 6) is the white noise of the same "
        "short-lag power (equal for white noise; 0.38 of the level for AR(1) phi = 0.8). At phi = 0.98 (the "
        "clamp) the residual is too smooth to be told from model error and the marginal level means "
        "nothing. These levels come from the model's own residual: noise only where the model is right, so "
        "they are reported, not used as the noise" +
        std::string(replicated ? " (the noise is the replicates' spread, above)" : "") + ".\n\n";
  md += steps_markdown(d);
  if (d.rule == DecisionRule::leave_one_run_out)
    md += "This diagnose decided by held-out error (`leave_one_run_out`, above); a candidate reached its held-out "
          "test when its white LR (the LR below with kappa = 1, a cost screen) passed chi^2(dp) at alpha / M. The "
          "LR / kappa, p-value and threshold columns are the likelihood-ratio rule's reading, for comparison (the "
          "rule fewer runs get): a step's p-value may exceed its threshold. ";
  md += fmt::format("Likelihood-ratio test: LR = N ln(s0^2/s1^2) divided by kappa = (1 + r1) / (1 - r1), "
                    "r1 the lag-1 autocorrelation of the extended fit's residuals (colored residuals inflate LR "
                    "by about kappa), against chi^2(dp) (Boost.Math), N = {} samples. A first term enters when p < "
                    "alpha / M (Bonferroni, alpha = {}, M = every candidate of the round, knot positions "
                    "counted) and delta BIC (N_eff = N / kappa) < 0; the effect then grows terms of its own "
                    "kind while each passes alpha / (its scan) and lowers BIC, up to {} terms. Knot grid: "
                    "every {:.2f} deg inside the data's angle range.\n\n",
                    total_samples(e), o.alpha, o.max_family_terms, o.knot_spacing_deg);
  md += "## Plots\n\n";
  if (ps.images.empty()) md += ps.message + "\n\n";
  for (const std::string& img : ps.images) md += fmt::format("![{}]({})\n\n", img, img);
  md += "## Rounds\n\n";
  for (const DiagnoseRound& r : d.rounds) md += round_markdown(r);
  md += vocabulary_markdown();
  md += "## Final model\n\n```\n" + estimates_text_table(d.fits.back().parameters) + "```\n\n";
  md += fmt::format("model.coef: runtime {}{}; replay max |runtime - fitter| = {:.3g} over {} samples.\n",
                    runtime_fit_name(rc.fit), rc.detail.empty() ? "" : " (" + rc.detail + ")",
                    rc.max_abs_difference, rc.samples_compared);
  return md;
}

nlohmann::json signature_json(const ResidualSignature& g) {
  nlohmann::json j;
  j["angle_only"] = finite_or_null(g.angle_only);
  j["hysteresis"] = finite_or_null(g.hysteresis);
  j["rate_in_phase"] = finite_or_null(g.rate_in_phase);
  j["constant"] = finite_or_null(g.constant);
  j["run_hysteresis"] = g.run_hysteresis;
  j["run_rate_gain"] = g.run_rate_gain;
  j["run_mean"] = g.run_mean;
  j["run_rms_rate_radps"] = g.run_rms_rate;
  return j;
}

nlohmann::json step_json(const DiagnoseStep& s) {
  nlohmann::json k;
  k["effect"] = effect_name(s.effect);
  k["detail"] = s.detail;
  k["statistic"] = finite_or_null(s.statistic);
  k["p_value"] = s.p_value;
  k["log10_p_value"] = finite_or_null(s.log10_p);
  k["correlation_factor"] = finite_or_null(s.correlation_factor);
  k["threshold"] = s.threshold;
  k["candidates_tested"] = s.candidates_tested;
  k["added_parameters"] = s.added_parameters;
  k["delta_bic"] = finite_or_null(s.delta_bic);
  k["term"] = s.term;
  k["fit_error_before"] = finite_or_null(s.fit_error_before);
  k["fit_error_after"] = finite_or_null(s.fit_error_after);
  nlohmann::json rb = nlohmann::json::array(), ra = nlohmann::json::array(), ind = nlohmann::json::array();
  for (double v : s.run_rms_before) rb.push_back(finite_or_null(v));
  for (double v : s.run_rms_after) ra.push_back(finite_or_null(v));
  for (Effect e : s.indistinguishable) ind.push_back(effect_name(e));
  k["run_rms_before"] = rb;
  k["run_rms_after"] = ra;
  k["indistinguishable"] = ind;
  k["rule"] = decision_rule_name(s.rule);
  if (s.rule == DecisionRule::leave_one_run_out) {
    k["held_out_rms_before"] = s.held_out_rms_before;
    k["held_out_rms_after"] = s.held_out_rms_after;
    k["held_out_mean_log_mse_ratio"] = finite_or_null(s.held_out_log_ratio);
    k["held_out_standard_error"] = finite_or_null(s.held_out_standard_error);
  }
  if (!s.indistinguishable.empty()) {
    k["separated_by"] = effect_descriptions()[static_cast<std::size_t>(s.effect)].separated_by;
    // Each look-alike's own separating experiment, in the order of `indistinguishable`.
    nlohmann::json sep = nlohmann::json::array();
    for (Effect e : s.indistinguishable) sep.push_back(effect_descriptions()[static_cast<std::size_t>(e)].separated_by);
    k["indistinguishable_separated_by"] = sep;
  }
  return k;
}

nlohmann::json held_out_json(const HeldOutTest& t) {
  nlohmann::json k;
  k["effect"] = effect_name(t.effect);
  k["terms"] = t.terms;
  k["stage"] = t.stage;
  nlohmann::json a = nlohmann::json::array(), b = nlohmann::json::array();
  for (double v : t.rms_without) a.push_back(finite_or_null(v));
  for (double v : t.rms_with) b.push_back(finite_or_null(v));
  k["held_out_rms_without"] = a;
  k["held_out_rms_with"] = b;
  k["mean_log_mse_ratio"] = finite_or_null(t.mean_log_ratio);
  k["in_sample_log_mse_ratio"] = finite_or_null(t.in_sample_log_ratio);
  k["standard_error"] = finite_or_null(t.standard_error);
  k["enters"] = t.enters;
  if (!t.message.empty()) k["message"] = t.message;
  return k;
}

nlohmann::json round_json(const DiagnoseRound& r) {
  nlohmann::json k;
  k["round"] = r.round;
  k["base_fit_error"] = finite_or_null(r.base_fit_error);
  k["candidates_tested"] = r.candidates_tested;
  k["threshold"] = r.threshold;
  k["added"] = r.added;
  k["check_only"] = r.check_only;
  k["signature"] = signature_json(r.signature);
  k["rule"] = decision_rule_name(r.rule);
  if (!r.rule_note.empty()) k["rule_note"] = r.rule_note;
  if (r.rule == DecisionRule::leave_one_run_out) {
    nlohmann::json hb = nlohmann::json::array(), ht = nlohmann::json::array();
    for (double v : r.held_out_base_rms) hb.push_back(finite_or_null(v));
    for (const HeldOutTest& t : r.held_out) ht.push_back(held_out_json(t));
    k["held_out_base_rms"] = hb;
    k["held_out_scored_fraction"] = r.held_out_scored_fraction;
    k["held_out_tests"] = ht;
  }
  nlohmann::json cs = nlohmann::json::array(), fs_ = nlohmann::json::array();
  for (const CandidateScore& c : r.candidates) cs.push_back(candidate_json(c));
  for (std::size_t i = 0; i < r.families.size(); ++i) {
    const FamilyResult& f = r.families[i];
    fs_.push_back({{"effect", effect_name(f.effect)}, {"terms", f.terms}, {"added_parameters", f.added_parameters},
                   {"fit_error", finite_or_null(f.fit_error)}, {"log10_p_value", finite_or_null(f.log10_p)},
                   {"delta_bic", finite_or_null(f.delta_bic)}, {"added", static_cast<int>(i) == r.winner}});
    if (f.has_held_out) fs_.back()["held_out"] = held_out_json(f.held_out);
  }
  k["candidates"] = cs;
  k["families"] = fs_;
  return k;
}

}  // namespace

std::string diagnose_step_line(const DiagnoseStep& s) {
  std::string line = fmt::format("step {}: {} ({}): ", s.step, effect_name(s.effect), s.detail);
  if (s.rule == DecisionRule::leave_one_run_out)
    line += fmt::format("held-out mean ln(MSE ratio) {:.3f} +- {:.3f}", s.held_out_log_ratio,
                        s.held_out_standard_error);
  else
    line += fmt::format("LR/kappa {:.1f}, log10 p {:.1f} < {:.2f}", s.statistic, s.log10_p, std::log10(s.threshold));
  line += fmt::format(", fit error {:.6g} -> {:.6g}", s.fit_error_before, s.fit_error_after);
  if (!s.indistinguishable.empty()) {
    std::string names;
    for (Effect e : s.indistinguishable) names += (names.empty() ? "" : ", ") + std::string(effect_name(e));
    line += " (indistinguishable on these data from " + names + ": see report.md)";
  }
  return line;
}

std::vector<std::string> diagnose_warnings(const DiagnoseResult& d) {
  std::vector<std::string> w;
  std::string problem;
  source_run_file_format(d.experiment, &problem);
  if (!problem.empty()) w.push_back(problem);
  // Named by the experiment, as fit's warnings are (a Python experiment built in memory has no path).
  const std::string at = d.experiment.path.empty() ? "" : d.experiment.path + ": ";
  if (d.rule == DecisionRule::lr_residual) w.push_back(at + "decided without prediction or replication: " + d.rule_reason);
  if (d.stopped == DiagnoseStop::max_steps)
    w.push_back(at + fmt::format("stopped at --max-steps {} with {} still significant; the model is not complete",
                                 d.steps.size(), d.still_significant));
  if (!d.unconverged_models.empty())
    w.push_back(at + unconverged_models_text(d) +
                fmt::format(" still at the iteration limit after being fitted on to {} times the limit: the "
                            "candidates were compared against a model that had not converged",
                            model_iteration_factor));
  if (!d.ill_conditioned.empty()) {
    std::string l;
    for (const auto& n : d.ill_conditioned) l += (l.empty() ? "" : ", ") + n;
    w.push_back(at + "ill-conditioned final estimates (Cramer-Rao bound larger than the value): " + l);
  }
  // The final model's stall states against the periodic runs' cycle (report.hpp).
  if (!d.fits.empty()) {
    const std::vector<std::string> slow = slow_stall_state_warnings(d.fits.back(), d.experiment);
    w.insert(w.end(), slow.begin(), slow.end());
  }
  return w;
}

// The one writer of diagnosis.json.
nlohmann::json diagnosis_json(const DiagnoseResult& d, const Experiment& e, const DiagnoseOptions& o,
                              const RuntimeCheck* runtime) {
  nlohmann::json j;
  j["initial_fit_error"] = finite_or_null(d.initial_fit_error);
  // Why: the noise is the replicates' spread where there are replicates; otherwise the
  // residual's short-lag level, said to be that (noise_source "residual_differences").
  const bool replicated = d.replication.source != NoiseSource::none;
  j["noise_estimate"] = finite_or_null(replicated ? d.replication.sigma : d.noise.sigma);
  j["noise_source"] = replicated ? noise_source_name(d.replication.source) : "residual_differences";
  j["noise_source_detail"] = d.replication.detail;
  if (replicated) j["noise_replication_lag1_correlation"] = d.replication.lag1_correlation;
  j["rule"] = decision_rule_name(d.rule);
  j["rule_reason"] = d.rule_reason;
  if (d.rule == DecisionRule::leave_one_run_out) {
    j["cv_folds"] = d.cv_folds;
    j["cv_unit"] = cross_validation_unit_name(d.cv_unit);
    if (d.cv_unit == CrossValidationUnit::group) j["cv_groups"] = d.cv_groups;
    j["cv_min_gain"] = o.cv_min_gain;
    j["cv_min_gain_applied"] = diagnose_detail::min_gain_for_folds(o.cv_min_gain, d.cv_folds);
    j["cv_min_in_sample_gain"] = o.cv_min_in_sample_gain;
  }
  nlohmann::json steps = nlohmann::json::array();
  for (const DiagnoseStep& s : d.steps) steps.push_back(step_json(s));
  j["steps"] = steps;
  j["final_fit_error"] = finite_or_null(d.final_fit_error);
  j["verdict"] = d.verdict;
  j["effects_added"] = d.effects_added;
  j["stopped"] = diagnose_stop_name(d.stopped);
  if (d.stopped == DiagnoseStop::max_steps) j["still_significant"] = d.still_significant;
  j["ill_conditioned_parameters"] = d.ill_conditioned;
  j["unconverged_models"] = d.unconverged_models;
  j["alpha"] = o.alpha;
  // The search's limits, so that a diagnosis can be rerun as it was made (--max-steps,
  // --knot-spacing-deg, --max-family-terms, --stall-start-search).
  j["max_steps"] = o.max_steps;
  j["knot_spacing_deg"] = o.knot_spacing_deg;
  j["max_family_terms"] = o.max_family_terms;
  j["stall_start_search"] = stall_start_search_name(o.fit.stall_start_search);
  j["stall_prior"] = stall_prior_name(o.fit.stall_prior);
  j["test"] = d.rule == DecisionRule::leave_one_run_out
                  ? fmt::format("leave-one-run-out: a first or next term enters when mean_r ln(MSE_with / MSE_without) "
                                "of runs left out of both fits + its standard error < 0, the mean < ln(1 - {:.4g}), it "
                                "lowers more than half of the runs' errors and the fits to every run differ by "
                                "ln(MSE ratio) < ln(1 - {}); effects compared by the held-out ratio "
                                "(one-standard-error rule); the white LR passing alpha/M screens the first terms",
                                diagnose_detail::min_gain_for_folds(o.cv_min_gain, d.cv_folds), o.cv_min_in_sample_gain)
                  : "likelihood ratio N ln(s0^2/s1^2) / kappa ~ chi2(dp), kappa = (1 + r1) / (1 - r1) of the "
                    "extended fit's residuals (lr_residual) or of the replicates (lr_replication_noise); "
                    "Bonferroni alpha/M per round; delta BIC (N_eff = N / kappa) < 0; each effect grown "
                    "stepwise, effects compared by BIC";
  // Which method gave noise_estimate; the residual levels below (noise_lag1_correlation,
  // noise_white_equivalent, noise_estimate_per_run, final_noise_*) are always the residual's.
  j["noise_estimate_method"] =
      replicated ? std::string("the replicates' spread (") + noise_source_name(d.replication.source) + ": " +
                       d.replication.detail + "); the noise_* and final_noise_* levels besides are the residual's "
                       "AR(1) short-lag structure, reported, not used as the noise"
                 : std::string("the residual's AR(1) short-lag level (no replication; not a noise measurement): phi = "
                               "1 + 2 r1(d1), noise_estimate = marginal sigma = sqrt(mean d2^2 / (2 (1 - phi) "
                               "(3 - phi))); white-equivalent sqrt(mean d2^2 / 6)");
  j["final_fit_error_over_noise"] =
      finite_or_null(d.final_fit_error / (replicated ? d.replication.sigma : d.final_noise.white_equivalent));
  j["noise_lag1_correlation"] = d.noise.lag1_correlation;
  j["noise_white_equivalent"] = finite_or_null(d.noise.white_equivalent);
  nlohmann::json rn = nlohmann::json::array();
  for (double v : d.noise.run_sigma) rn.push_back(finite_or_null(v));
  j["noise_estimate_per_run"] = rn;
  j["final_noise_estimate"] = finite_or_null(d.final_noise.sigma);
  j["final_noise_lag1_correlation"] = d.final_noise.lag1_correlation;
  j["final_noise_white_equivalent"] = finite_or_null(d.final_noise.white_equivalent);
  j["samples"] = total_samples(e);
  nlohmann::json rounds = nlohmann::json::array();
  for (const DiagnoseRound& r : d.rounds) rounds.push_back(round_json(r));
  j["rounds"] = rounds;
  nlohmann::json params = nlohmann::json::array();
  for (const ParameterEstimate& p : d.fits.back().parameters)
    params.push_back({{"name", p.name}, {"value", p.value}, {"cr_bound", finite_or_null(p.cr_bound)}});
  j["final_parameters"] = params;
  j["fits_run"] = d.fits_run;
  j["threads"] = o.threads;  // the fits ran on this many threads (elapsed_s depends on it, the results do not)
  j["elapsed_s"] = d.elapsed_s;
  if (runtime) {
    nlohmann::json r;
    r["fit"] = runtime_fit_name(runtime->fit);
    r["detail"] = runtime->detail;
    r["max_abs_difference"] = finite_or_null(runtime->max_abs_difference);
    r["samples_compared"] = runtime->samples_compared;
    j["runtime_check"] = r;
  }
  return j;
}

std::string diagnosed_experiment_toml(const DiagnoseResult& d) {
  Experiment next = d.experiment;
  next.model = d.configs.back();
  // Absolute paths: the file is read from DIR, not from where the original experiment was.
  std::error_code ec;
  for (Run& r : next.runs) {
    r.path = fs::absolute(r.path, ec).string();
    for (std::string& f : r.source_files) f = fs::absolute(f, ec).string();
  }
  if (next.static_curve.kind == StaticKind::table)
    next.static_curve.table_path = fs::absolute(next.static_curve.table_path, ec).string();
  if (!next.model.stall.polar_path.empty())
    next.model.stall.polar_path = fs::absolute(next.model.stall.polar_path, ec).string();
  // Why the start value: a delay is a non-convex parameter (diagnose fits it from two starts);
  // the refit starts from the diagnosed estimate instead of 0.
  if (next.model.delay == DelayEstimation::estimated) {
    for (const ParameterEstimate& p : d.fits.back().parameters)
      if (p.id.kind == ParamKind::delay && std::isfinite(p.value)) next.model.delay_start_s = std::clamp(p.value, 0.0, 1.0);
  }
  // The same for the stall families' time constants and threshold (multimodal: `indicial fit`
  // runs its start grid around these): refitted from the configured starts, the fit reached
  // another minimum than the diagnosed model (a user's trial: C_m s(v) 0.0526 with T1 = 6
  // against the diagnosed 0.0578 with T1 = 3), so the file did not reproduce what diagnose said.
  if (next.model.stall.families != StallFamilies::none) {
    for (const StallStart& st : stall_starts())
      for (const ParameterEstimate& p : d.fits.back().parameters)
        if (p.name == st.parameter && std::isfinite(p.value) && start_in_bound(st, p.value))
          next.model.stall.*st.value = p.value;
  }
  std::string added;
  for (const std::string& x : d.effects_added) added += (added.empty() ? "" : ", ") + x;
  const std::vector<std::string> comments = {
      "written by indicial diagnose: the experiment with the diagnosed model structure",
      "(effects added: " + (added.empty() ? std::string("none") : added) +
          "); refit it with: indicial fit experiment.toml --out DIR"};
  return write_experiment_toml(next, comments, source_run_file_format(d.experiment));
}

DiagnoseOutputs write_diagnose_outputs(const DiagnoseResult& d, const Experiment& e,
                                       const DiagnoseOptions& o, const fs::path& dir,
                                       Overwrite overwrite, const ReportOptions& ro) {
  OutputDir out(dir, overwrite);
  DiagnoseOutputs w;
  w.dir = dir;
  const FitResult& final_fit = d.fits.back();
  w.model_coef = with_provenance_header(model_coef_text(final_fit, "model.coef"), ro.provenance);
  w.runtime = replay_in_runtime(final_fit, d.experiment, w.model_coef);
  w.diagnosis_json = with_provenance_and_warnings(diagnosis_json(d, e, o, &w.runtime), ro).dump(2) + "\n";
  const PlotSet ps = make_plots(d, out, ro);
  w.plots = ps.status;
  w.plot_message = ps.message;
  w.images = ps.images;
  w.report_md = report_markdown(d, e, o, w.runtime, ps, ro);
  w.experiment_toml = diagnosed_experiment_toml(d);
  out.write("diagnosis.json", w.diagnosis_json);
  out.write("experiment.toml", w.experiment_toml);
  out.write("model.coef", w.model_coef);
  out.write("report.md", w.report_md);
  out.commit();
  return w;
}

}  // namespace indicial
