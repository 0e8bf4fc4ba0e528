// diagnose_output.cpp -- the outputs of `indicial diagnose`: diagnosis.json (one function,
// diagnosis_json), report.md, the residual plots (gnuplot) and the diagnosed experiment file.
// No numerics here beyond formatting (the algorithm is diagnose.cpp).
#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "diagnose_internal.hpp"
#include "fit_internal.hpp"
#include "indicial/fitter/io.hpp"

namespace indicial {

namespace fs = std::filesystem;
using diagnose_detail::kRadToDeg;
using diagnose_detail::total_samples;

// ==========================================================================================
// Outputs
// ==========================================================================================
namespace {

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
    j["p_value"] = c.p_value;
    j["log10_p_value"] = finite_or_null(c.log10_p);
    j["delta_bic"] = finite_or_null(c.delta_bic);
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

std::string report_markdown(const DiagnoseResult& d, const Experiment& e, const DiagnoseOptions& o,
                            const RuntimeCheck& rc, const PlotSet& ps, const ReportOptions& ro) {
  std::string md;
  md += "# indicial diagnose\n\n";
  if (!ro.command_line.empty()) md += "`" + ro.command_line + "`\n\n";
  md += fmt::format("Experiment `{}`: {} of {} axis, {} runs, {} samples.\n\n",
                    ro.experiment_display.empty() ? e.path : ro.experiment_display, e.coefficient,
                    axis_name(e.axis), e.runs.size(), total_samples(e));
  md += fmt::format("**Verdict: `{}`**", d.verdict);
  if (d.effects_added.size() > 1) {
    std::string l;
    for (const auto& s : d.effects_added) l += (l.empty() ? "" : ", ") + s;
    md += fmt::format(" (effects added in order: {})", l);
  }
  md += "\n\n";
  md += fmt::format("| | value |\n|---|---|\n| initial fit error s(v) | {} |\n| noise estimate (initial "
                    "residuals) | {} |\n| final fit error | {} |\n| noise estimate (final residuals) | {} |\n"
                    "| fits run | {} |\n| elapsed | {:.2f} s |\n\n",
                    num(d.initial_fit_error), num(d.noise.sigma), num(d.final_fit_error),
                    num(d.final_noise.sigma), d.fits_run, d.elapsed_s);
  md += "The noise estimate is sqrt(mean (second difference of the residual)^2 / 6): white noise "
        "passes the second difference with variance 6 sigma^2, a smooth model error is filtered "
        "out. When the fit error is well above it, the model is missing something.\n\n";
  md += "## Steps\n\n";
  if (d.steps.empty()) {
    md += "No candidate effect is significant: the model is left as configured (verdict `none`).\n\n";
  } else {
    md += "| step | effect | detail | LR statistic | dp | p-value | threshold alpha/M (M) | delta BIC | "
          "fit error before | after | run RMS before | run RMS after |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const DiagnoseStep& s : d.steps)
      md += fmt::format("| {} | `{}` | {} | {:.1f} | {} | {} | {:.3g} ({}) | {:.1f} | {} | {} | {} | {} |\n",
                        s.step, effect_name(s.effect), s.detail, s.statistic, s.added_parameters,
                        pval(s.p_value, s.log10_p), s.threshold, s.candidates_tested, s.delta_bic,
                        num(s.fit_error_before), num(s.fit_error_after), rms_list(s.run_rms_before),
                        rms_list(s.run_rms_after));
    md += "\n";
  }
  md += fmt::format("Test: LR = N ln(s0^2/s1^2) against chi^2(dp) (Boost.Math), N = {} samples. An effect "
                    "enters when p < alpha / M (Bonferroni, alpha = {}, M = every candidate model of the "
                    "round, each scanned knot position counted) and delta BIC = N ln(s1^2/s0^2) + dp ln N "
                    "< 0. Knot grid: every {:.2f} deg inside the data's angle range.\n\n",
                    total_samples(e), o.alpha, o.knot_spacing_deg);
  md += "## Plots\n\n";
  if (ps.images.empty()) md += ps.message + "\n\n";
  for (const std::string& img : ps.images) md += fmt::format("![{}]({})\n\n", img, img);
  md += "## Candidates per round (best of each effect)\n\n";
  for (const DiagnoseRound& r : d.rounds) {
    md += fmt::format("### Round {} (base fit error {}, M = {}, threshold {:.3g}){}\n\n", r.round,
                      num(r.base_fit_error), r.candidates_tested, r.threshold,
                      r.added ? "" : ": nothing significant");
    md += "| effect | best term | LR | dp | p-value | delta BIC | fit error | candidates |\n|---|---|---|---|---|---|---|---|\n";
    for (int k = 0; k < effect_count; ++k) {
      const Effect ef = static_cast<Effect>(k);
      int best = -1, count = 0;
      for (std::size_t i = 0; i < r.candidates.size(); ++i) {
        const CandidateScore& c = r.candidates[i];
        if (c.effect != ef) continue;
        ++count;
        if (c.status != CandidateStatus::fitted) continue;
        if (best < 0 || c.log10_p < r.candidates[static_cast<std::size_t>(best)].log10_p)
          best = static_cast<int>(i);
      }
      if (count == 0) continue;
      if (best < 0) {
        md += fmt::format("| `{}` | (no fit) | | | | | | {} |\n", effect_name(ef), count);
        continue;
      }
      const CandidateScore& c = r.candidates[static_cast<std::size_t>(best)];
      md += fmt::format("| `{}` | {} | {:.1f} | {} | {} | {:.1f} | {} | {} |\n", effect_name(ef),
                        c.detail.empty() ? c.term : c.detail, c.statistic, c.added_parameters,
                        pval(c.p_value, c.log10_p), c.delta_bic, num(c.fit_error), count);
    }
    md += "\n";
  }
  md += "## Final model\n\n```\n" + estimates_text_table(d.fits.back().parameters) + "```\n\n";
  md += fmt::format("model.coef: runtime {}{}; replay max |runtime - fitter| = {:.3g} over {} samples.\n",
                    runtime_fit_name(rc.fit), rc.detail.empty() ? "" : " (" + rc.detail + ")",
                    rc.max_abs_difference, rc.samples_compared);
  return md;
}

}  // namespace

nlohmann::json diagnosis_json(const DiagnoseResult& d, const Experiment& e, const DiagnoseOptions& o,
                              const RuntimeCheck* runtime) {
  nlohmann::json j;
  j["initial_fit_error"] = finite_or_null(d.initial_fit_error);
  j["noise_estimate"] = finite_or_null(d.noise.sigma);
  nlohmann::json steps = nlohmann::json::array();
  for (const DiagnoseStep& s : d.steps) {
    nlohmann::json k;
    k["effect"] = effect_name(s.effect);
    k["detail"] = s.detail;
    k["statistic"] = finite_or_null(s.statistic);
    k["p_value"] = s.p_value;
    k["log10_p_value"] = finite_or_null(s.log10_p);
    k["threshold"] = s.threshold;
    k["candidates_tested"] = s.candidates_tested;
    k["added_parameters"] = s.added_parameters;
    k["delta_bic"] = finite_or_null(s.delta_bic);
    k["term"] = s.term;
    k["fit_error_before"] = finite_or_null(s.fit_error_before);
    k["fit_error_after"] = finite_or_null(s.fit_error_after);
    nlohmann::json rb = nlohmann::json::array(), ra = nlohmann::json::array();
    for (double v : s.run_rms_before) rb.push_back(finite_or_null(v));
    for (double v : s.run_rms_after) ra.push_back(finite_or_null(v));
    k["run_rms_before"] = rb;
    k["run_rms_after"] = ra;
    steps.push_back(k);
  }
  j["steps"] = steps;
  j["final_fit_error"] = finite_or_null(d.final_fit_error);
  j["verdict"] = d.verdict;
  j["effects_added"] = d.effects_added;
  j["alpha"] = o.alpha;
  j["test"] = "likelihood ratio N ln(s0^2/s1^2) ~ chi2(dp); Bonferroni alpha/M per round; delta BIC < 0";
  j["noise_estimate_method"] = "second difference of the residual: sqrt(sum d2^2 / (6 n))";
  nlohmann::json rn = nlohmann::json::array();
  for (double v : d.noise.run_sigma) rn.push_back(finite_or_null(v));
  j["noise_estimate_per_run"] = rn;
  j["final_noise_estimate"] = finite_or_null(d.final_noise.sigma);
  j["samples"] = total_samples(e);
  nlohmann::json rounds = nlohmann::json::array();
  for (const DiagnoseRound& r : d.rounds) {
    nlohmann::json k;
    k["round"] = r.round;
    k["base_fit_error"] = finite_or_null(r.base_fit_error);
    k["candidates_tested"] = r.candidates_tested;
    k["threshold"] = r.threshold;
    k["added"] = r.added;
    nlohmann::json cs = nlohmann::json::array();
    for (const CandidateScore& c : r.candidates) cs.push_back(candidate_json(c));
    k["candidates"] = cs;
    rounds.push_back(k);
  }
  j["rounds"] = rounds;
  nlohmann::json params = nlohmann::json::array();
  for (const ParameterEstimate& p : d.fits.back().parameters) {
    nlohmann::json q;
    q["name"] = p.name;
    q["value"] = p.value;
    q["cr_bound"] = finite_or_null(p.cr_bound);
    params.push_back(q);
  }
  j["final_parameters"] = params;
  j["fits_run"] = d.fits_run;
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
  for (Run& r : next.runs) r.path = fs::absolute(r.path, ec).string();
  if (next.static_curve.kind == StaticKind::table)
    next.static_curve.table_path = fs::absolute(next.static_curve.table_path, ec).string();
  // Why the start value: a delay is a non-convex parameter (diagnose fits it from two starts);
  // the refit starts from the diagnosed estimate instead of 0.
  if (next.model.delay == DelayEstimation::estimated) {
    for (const ParameterEstimate& p : d.fits.back().parameters)
      if (p.name == "delay_s" && std::isfinite(p.value)) next.model.delay_start_s = std::clamp(p.value, 0.0, 1.0);
  }
  std::string added;
  for (const std::string& x : d.effects_added) added += (added.empty() ? "" : ", ") + x;
  const std::vector<std::string> comments = {
      "written by indicial diagnose: the experiment with the diagnosed model structure",
      "(effects added: " + (added.empty() ? std::string("none") : added) +
          "); refit it with: indicial fit experiment.toml --out DIR"};
  return write_experiment_toml(next, comments);
}

DiagnoseOutputs write_diagnose_outputs(const DiagnoseResult& d, const Experiment& e,
                                       const DiagnoseOptions& o, const fs::path& dir,
                                       Overwrite overwrite, const ReportOptions& ro) {
  OutputDir out(dir, overwrite);
  DiagnoseOutputs w;
  w.dir = dir;
  const FitResult& final_fit = d.fits.back();
  w.model_coef = model_coef_text(final_fit, "model.coef");
  w.runtime = replay_in_runtime(final_fit, d.experiment, w.model_coef);
  w.diagnosis_json = diagnosis_json(d, e, o, &w.runtime).dump(2) + "\n";
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
