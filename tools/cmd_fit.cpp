// `indicial fit`: identify the model of an experiment and write fit.json, model.coef,
// report.md and plots.
//
//   indicial fit EXPERIMENT.toml --out DIR [--force] [--f-to-enter F] [--f-to-remove F]
//                [--max-iterations N] [--stall-start-search grid|configured]
//                [--stall-prior beddoes_leishman|none] [--threads N]
//                [--state-derivative smoothed|modulating] [--no-plots] [--quiet]
//
// Warnings (input warnings of the experiment, and a fit error far above the data's noise
// level) go to stderr as "indicial: warning: ..." lines and into fit.json "warnings"; a
// stage that runs past 2 s gets progress lines on stderr (not with --quiet).
//
// Exit status (also in --help and the README):
//   0  converged (or the iteration limit was reached: a "warning:" line says so; the best
//      estimate is written)
//   1  bad input: one line "indicial: error: FILE:LINE: problem"; nothing written. Also when
//      the fitted model is one the runtime refuses ("DIR/model.coef: not written: the runtime
//      refuses the model: <reason>"): nothing written
//   4  the output-error iteration diverged: the best estimate found IS written, and a
//      "warning:" line says so
//   5  the information matrix is rank deficient: outputs written, the parameters that cannot
//      be identified are named (bounds null in fit.json)
// With several coefficients (`coefficients = ["CL", "Cm"]`) each is fitted into DIR/<name>/, the
// models are merged into DIR/model.coef, and the status is the first non-zero one of them.
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/provenance.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/fitter/runtime_limits.hpp"

namespace {

struct FitCliOptions {
  std::string experiment;
  std::string out;
  bool force = false;
  bool no_plots = false;
  bool quiet = false;
  std::string gnuplot = "gnuplot";
  std::string state_derivative = "smoothed";
  std::vector<std::string> start_values;  // NAME=VALUE
  indicial::FitOptions fit = with_two_threads();
  static indicial::FitOptions with_two_threads() {
    indicial::FitOptions o;
    o.threads = 2;  // as diagnose's --threads; the library's default is 1
    return o;
  }
};

// Exit codes of `indicial fit` when outputs were written (see the file comment).
enum class FitExit : int { ok = 0, diverged = 4, rank_deficient = 5 };

indicial::FitOptions checked_fit_options(const FitCliOptions& o) {
  using namespace indicial;
  if (o.out.empty()) throw InputError("--out", 0, "an output directory is required");
  FitOptions fo = o.fit;
  if (o.state_derivative == "smoothed") fo.state_derivative = StateDerivative::smoothed_difference;
  else if (o.state_derivative == "modulating") fo.state_derivative = StateDerivative::modulating_function;
  else
    throw InputError("--state-derivative", 0,
                     "expected 'smoothed' or 'modulating', found '" + o.state_derivative + "'");
  for (const std::string& sv : o.start_values) {
    const std::size_t eq = sv.find('=');
    std::size_t used = 0;
    double value = 0.0;
    try {
      if (eq != std::string::npos && eq > 0) value = std::stod(sv.substr(eq + 1), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (eq == std::string::npos || eq == 0 || used == 0 || used != sv.size() - eq - 1)
      throw InputError("--start-value", 0, "expected NAME=VALUE with a number (e.g. b1_0=3), found '" + sv + "'");
    fo.start_values.emplace_back(sv.substr(0, eq), value);
  }
  // Every range (a non-finite start value included) is FitOptions::IsValid's, with its message,
  // before the experiment is read.
  if (std::string bad; !fo.IsValid(&bad)) throw InputError(bad);
  return fo;
}

// Notes and warnings of the experiments, each line once (several coefficients share runs);
// returns the warnings for fit.json.
std::vector<std::string> input_messages(const std::vector<indicial::Experiment>& es,
                                        indicial::tools::Verbosity verbosity) {
  std::set<std::string> seen;
  std::vector<std::string> notes, warnings;
  for (const auto& e : es) {
    for (const std::string& n : e.notes)
      if (seen.insert(n).second) notes.push_back(n);
    for (const std::string& x : e.warnings)
      if (seen.insert(x).second) warnings.push_back(x);
  }
  indicial::tools::print_notes(notes, verbosity);
  indicial::tools::print_warnings(warnings);
  return warnings;
}

void print_fit_summary(const FitCliOptions& o, const indicial::Experiment& e, const indicial::FitResult& r,
                       const indicial::FitOutputs& w, const std::string& where) {
  using namespace indicial;
  const OutputErrorSummary& oe = r.output_error;
  std::size_t samples = 0;
  for (const Run& run : e.runs) samples += run.size();
  std::printf("fit: %s: %zu runs, %zu samples, %s of %s\n", o.experiment.c_str(), e.runs.size(), samples,
              e.coefficient.c_str(), axis_name(e.axis));
  std::printf("fit: output error %s after %d iterations, s(v) = %.6g (%.2f s)\n",
              termination_name(oe.termination), oe.iterations, r.fit_error, r.elapsed_s);
  std::fputs(estimates_text_table(r.parameters).c_str(), stdout);
  std::printf("fit: wrote %s/fit.json, model.coef, report.md (%s)\n", where.c_str(), w.plot_message.c_str());
  if (w.runtime.fit == RuntimeFit::refused)
    std::printf("fit: WARNING: the runtime refuses model.coef: %s\n", w.runtime.detail.c_str());
  else
    std::printf("fit: runtime replay of model.coef: max |runtime - fitter| = %.3g over %zu steps (the samples "
                "after each of %zu runs' first, its initial state)%s\n",
                w.runtime.max_abs_difference, w.runtime.samples_compared, w.runtime.runs_replayed,
                w.runtime.fit == RuntimeFit::needs_fit_capacity ? " (needs Predictor<double, FitCapacity>)" : "");
  if (w.plots == PlotStatus::gnuplot_not_found || w.plots == PlotStatus::gnuplot_failed)
    std::fprintf(stderr, "indicial: warning: %s\n", w.plot_message.c_str());
  std::fflush(stdout);
}

// What to do when the output-error start cannot be propagated (OutputErrorSummary::start).
constexpr const char* start_advice =
    ". What to do: give that start value (fit --start-value NAME=VALUE), start from a constant b1 (b1_degree = 0, "
    "no b1 knots), fewer a(x) terms, or --stepwise-refinement output_error; check the angle and rate units and "
    "columns";

// The warning line of a fit that did not converge and its exit status (0: none).
int termination_exit(const FitCliOptions& o, const indicial::FitOptions& fo, const indicial::FitResult& r,
                     const std::string& what) {
  using namespace indicial;
  const OutputErrorSummary& oe = r.output_error;
  switch (oe.termination) {
    case Termination::converged: return 0;
    case Termination::iteration_limit:
      std::fprintf(stderr, "indicial: warning: %s: output error stopped at the iteration limit (%d) before "
                   "converging; the best estimate was written to %s\n", what.c_str(), fo.max_iterations,
                   o.out.c_str());
      return 0;
    case Termination::diverged:
      std::fprintf(stderr, "indicial: warning: %s: the output-error iteration diverged; the best estimate "
                   "was written to %s: %s%s\n", what.c_str(), o.out.c_str(), oe.message.c_str(),
                   oe.start == StartOutcome::not_propagated ? start_advice : "");
      return static_cast<int>(FitExit::diverged);
    case Termination::rank_deficient: {
      std::string names;
      for (const std::string& n : oe.unidentifiable) names += (names.empty() ? "" : ", ") + n;
      std::fprintf(stderr, "indicial: warning: %s: rank-deficient information matrix; not identifiable: %s "
                   "(outputs written to %s)\n", what.c_str(), names.c_str(), o.out.c_str());
      return static_cast<int>(FitExit::rank_deficient);
    }
  }
  return 0;
}

indicial::ReportOptions report_options(const FitCliOptions& o, const indicial::Experiment& e,
                                      const std::vector<std::string>& warnings) {
  indicial::ReportOptions ro;
  ro.plots = o.no_plots ? indicial::PlotRequest::none : indicial::PlotRequest::gnuplot;
  ro.gnuplot = o.gnuplot;
  ro.command_line = indicial::tools::invocation();
  ro.provenance = indicial::tools::provenance_of(e);
  ro.warnings = warnings;
  ro.notes = e.notes;
  return ro;
}

// Never write (or exit 0 with) a model the runtime refuses: throws (one line, nothing written);
// returns the post-fit warnings (fit error far above the noise, a model only FitCapacity holds).
// `coefficient_named`: several coefficients of one file are fitted, so a warning naming the
// experiment file names the coefficient too ("experiment.toml (Cm): ...").
std::vector<std::string> checked_fit(const indicial::FitResult& r, const indicial::Experiment& e,
                                     const std::string& coef_path, bool coefficient_named = false) {
  using namespace indicial;
  const std::string site = coefficient_named ? e.path + " (" + e.coefficient + ")" : e.path;
  // Printed under --quiet too: it says how the model was chosen, not what a reader did.
  if (!r.stepwise_fallback.empty()) tools::print_notes({site + ": " + r.stepwise_fallback});
  const RuntimeAcceptance accepted = require_runtime_accepts(r.model, coef_path, ModelFile::to_write);
  std::vector<std::string> after_fit = fit_warnings(r, e);
  for (std::string& w : after_fit)
    if (coefficient_named && w.rfind(e.path + ": ", 0) == 0) w = site + w.substr(e.path.size());
  if (accepted.capacity == RuntimeCapacity::fit_capacity_only) after_fit.push_back(coef_path + ": " + accepted.reason);
  tools::print_warnings(after_fit);
  return after_fit;
}

void run_fit_one(const FitCliOptions& o, const indicial::FitOptions& fo, const indicial::Experiment& e,
                 std::vector<std::string> warnings, const indicial::tools::StageClock& clock) {
  using namespace indicial;
  // Refuse a non-empty DIR before the (possibly long) fit, not after it.
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  { OutputDir probe(o.out, overwrite, experiment_input_paths(e)); }
  FitResult r;
  clock.stage("fitting (equation error, stepwise, output error)", [&] { r = fit_experiment(e, fo); });
  const std::vector<std::string> after_fit = checked_fit(r, e, o.out + "/model.coef");
  warnings.insert(warnings.end(), after_fit.begin(), after_fit.end());
  FitOutputs w;
  clock.stage("writing the outputs (runtime check, report, plots)",
              [&] { w = write_fit_outputs(r, e, fo, o.out, overwrite, report_options(o, e, warnings)); });
  print_fit_summary(o, e, r, w, o.out);
  const int status = termination_exit(o, fo, r, o.experiment);
  if (status != 0) throw CLI::RuntimeError(status);
}

// The provenance of several coefficients' merged model: the first experiment's, with every
// other experiment's inputs not already listed.
indicial::Provenance merged_provenance(const std::vector<indicial::Experiment>& es) {
  indicial::Provenance p = indicial::tools::provenance_of(es.front());
  for (std::size_t i = 1; i < es.size(); ++i)
    for (const indicial::InputDigest& d : indicial::tools::provenance_of(es[i]).inputs) {
      bool listed = false;
      for (const indicial::InputDigest& have : p.inputs) listed = listed || (have.role == d.role && have.path == d.path);
      if (!listed) p.inputs.push_back(d);
    }
  return p;
}

std::vector<std::string> with_after(std::vector<std::string> w, const std::vector<std::string>& more) {
  w.insert(w.end(), more.begin(), more.end());
  return w;
}

// Several coefficients: each fitted by fit_experiment into DIR/<coefficient>/ (its own
// fit.json, model.coef, report.md), the models merged into DIR/model.coef, and DIR/fit.json
// listing per coefficient the contract's keys (docs/formats.md).
void run_fit_several(const FitCliOptions& o, const indicial::FitOptions& fo,
                     const std::vector<indicial::Experiment>& es, const std::vector<std::string>& warnings,
                     const indicial::tools::StageClock& clock) {
  using namespace indicial;
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  std::vector<std::string> inputs;
  for (const Experiment& e : es) {
    const std::vector<std::string> more = experiment_input_paths(e);
    inputs.insert(inputs.end(), more.begin(), more.end());
  }
  { OutputDir probe(o.out, overwrite, inputs); }
  std::vector<FitResult> results;
  std::vector<std::vector<std::string>> after(es.size());
  for (std::size_t i = 0; i < es.size(); ++i) {
    clock.stage("fitting " + es[i].coefficient + " (equation error, stepwise, output error)",
                [&] { results.push_back(fit_experiment(es[i], fo)); });
    after[i] = checked_fit(results[i], es[i], o.out + "/" + es[i].coefficient + "/model.coef", true);
  }
  OutputDir out(o.out, overwrite);
  std::vector<NamedModelSet> parts;
  nlohmann::json j = {{"experiment", o.experiment}, {"model_coef", "model.coef"}, {"coefficients", nlohmann::json::array()}};
  int status = 0;
  for (std::size_t i = 0; i < es.size(); ++i) {
    const std::string sub = es[i].coefficient;
    const FitOutputs w = write_fit_outputs(results[i], es[i], fo, out.path(sub), Overwrite::refuse,
                                           report_options(o, es[i], with_after(warnings, after[i])));
    print_fit_summary(o, es[i], results[i], w, o.out + "/" + sub);
    const nlohmann::json one = nlohmann::json::parse(w.fit_json);
    nlohmann::json entry = {{"coefficient", sub}, {"directory", sub}};
    for (const char* key : {"converged", "iterations", "fit_error", "parameters", "two_stage", "termination"})
      if (one.contains(key)) entry[key] = one[key];
    j["coefficients"].push_back(entry);
    parts.push_back({o.out + "/" + sub + "/model.coef", &results[i].model});
    const int s = termination_exit(o, fo, results[i], o.experiment + " (" + sub + ")");
    if (s != 0 && status == 0) status = s;
  }
  const ModelMerge merged = merge_model_sets(parts);
  tools::print_warnings(merged.warnings);
  require_runtime_accepts(merged.model, o.out + "/model.coef", ModelFile::to_write);
  // The merged model carries the fit's provenance (version, command line, every input's digest)
  // as each coefficient's own model.coef does.
  out.write("model.coef", with_provenance_header(coef_file_text(merged.model, o.out + "/model.coef"),
                                                  merged_provenance(es)));
  out.write("fit.json", j.dump(2) + "\n");
  out.commit();
  std::printf("fit: wrote %s/model.coef (%d coefficients) and %s/fit.json\n", o.out.c_str(),
              merged.model.n_coefficients, o.out.c_str());
  if (status != 0) throw CLI::RuntimeError(status);
}

void run_fit(const FitCliOptions& o) {
  using namespace indicial;
  const FitOptions fo = checked_fit_options(o);
  const tools::StageClock clock("fit", o.quiet ? tools::Verbosity::quiet : tools::Verbosity::progress);
  std::vector<Experiment> es;
  clock.stage("reading the experiment and its runs", [&] { es = load_experiments(o.experiment); });
  const std::vector<std::string> warnings = input_messages(es, clock.verbosity());
  if (es.size() == 1) run_fit_one(o, fo, es.front(), warnings, clock);
  else run_fit_several(o, fo, es, warnings, clock);
}

const indicial::tools::RegisterCommand register_fit([](CLI::App& app) {
  auto opt = std::make_shared<FitCliOptions>();
  CLI::App* sub = app.add_subcommand(
      "fit",
      "Identify the model of an experiment (equation error, stepwise, ML output error, two-stage)\n"
      "and write DIR/fit.json, DIR/model.coef, DIR/report.md and DIR/plots/.\n"
      "Exit status: 0 converged, or iteration limit reached (a warning line; outputs written);\n"
      "  1 bad input, or a fitted model the runtime refuses (one-line message, nothing written);\n"
      "  4 output error diverged (best estimate\n"
      "  written, warning line); 5 rank-deficient information matrix (outputs written, the\n"
      "  unidentifiable parameters named).");
  sub->add_option("experiment", opt->experiment, "experiment file (TOML)")->required();
  sub->add_option("--out", opt->out, "output directory (refused if not empty, unless --force)")->required();
  sub->add_flag("--force", opt->force, "replace the contents of a non-empty output directory");
  sub->add_option("--f-to-enter", opt->fit.f_to_enter, "stepwise: partial F to enter (default 4)");
  sub->add_option("--f-to-remove", opt->fit.f_to_remove, "stepwise: partial F to remove (default 4)");
  sub->add_option("--stepwise-refinement", opt->fit.stepwise_refinement,
                  "stepwise: none (default: the regression's selection, as the report) or output_error "
                  "(then terms enter and leave by the output-error fit; for large candidate pools)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, indicial::StepwiseRefinement>{
          {"none", indicial::StepwiseRefinement::none},
          {"output_error", indicial::StepwiseRefinement::output_error}}));
  sub->add_option("--stepwise-significance", opt->fit.stepwise_significance,
                  "stepwise F tests: colored (default: each partial F corrected by the term's colored-residual "
                  "variance; unchanged on white residuals) or white (the textbook F, which accepts nearly every "
                  "term on autocorrelated residuals)")
      ->transform(CLI::CheckedTransformer(std::map<std::string, indicial::StepwiseSignificance>{
          {"colored", indicial::StepwiseSignificance::colored_residuals},
          {"white", indicial::StepwiseSignificance::white_residuals}}));
  sub->add_option("--stepwise-fallback", opt->fit.stepwise_fallback,
                  "stepwise: automatic (default: when the equation-error regression selects no term or its "
                  "R^2 < --fallback-r-squared, the output-error stepwise selects the structure; a note on stderr "
                  "and fit.json's stepwise_fallback say why) or off")
      ->transform(CLI::CheckedTransformer(std::map<std::string, indicial::StepwiseFallback>{
          {"automatic", indicial::StepwiseFallback::automatic}, {"off", indicial::StepwiseFallback::off}}));
  sub->add_option("--fallback-r-squared", opt->fit.fallback_r_squared,
                  "stepwise: the equation-error R^2 below which the fallback runs (default 0.9)");
  sub->add_option("--start-value", opt->start_values,
                  "NAME=VALUE: the output-error start value of a parameter instead of the equation error's "
                  "(repeatable; names as in fit.json: a1, A2, b1_0, y0_1, ...)");
  sub->add_option("--max-iterations", opt->fit.max_iterations, "output-error iteration limit (default 50; 0: the estimates and bounds at the start values)");
  sub->add_option("--stall-start-search", opt->fit.stall_start_search,
                  "with model.stall: grid (default: the configured stall starts and 17 more, T1 x {1/2,1,2}, "
                  "Tv x {1/2,1,2}, T2 x {1/3,1}, the lowest cost kept; fit.json's stall_start_search lists them) "
                  "or configured (the stall_*_start keys only)")
      ->transform(indicial::tools::stall_start_search_words());
  sub->add_option("--stall-prior", opt->fit.stall_prior,
                  "with model.stall: beddoes_leishman (default: each stall parameter a priori at its default "
                  "start, docs/formats.md) or none (maximum likelihood alone)")
      ->transform(indicial::tools::stall_prior_words());
  sub->add_option("--threads", opt->fit.threads, "fits run in parallel (the stall start grid; default 2)");
  sub->add_option("--state-derivative", opt->state_derivative,
                  "equation error's y_E': smoothed (Savitzky-Golay, default) or modulating (ref. 12)");
  sub->add_flag("--no-plots", opt->no_plots, "do not run gnuplot");
  sub->add_flag("--quiet", opt->quiet,
                "no progress lines or input-reader notes on stderr (warnings, errors and the stepwise "
                "fallback's note are still printed; report.md lists the notes)");
  sub->add_option("--gnuplot", opt->gnuplot, "gnuplot executable (default: gnuplot on PATH)");
  sub->callback([opt]() { run_fit(*opt); });
});

}  // namespace
