// `indicial diagnose`: the missing-effect workflow (fitter/include/indicial/fitter/diagnose.hpp).
//
//   indicial diagnose EXPERIMENT.toml --out DIR [--force] [--alpha 0.01] [--max-steps N]
//                     [--knot-spacing-deg D] [--rule auto|cv|lr] [--cv-min-runs N] [--cv-unit run|group]
//                     [--max-folds K] [--min-gain G]
//                     [--min-in-sample-gain G] [--threads N] [--stall-start-search configured|grid]
//                     [--stall-prior beddoes_leishman|none]
//                     [--no-plots] [--gnuplot EXE] [--quiet]
//
// The options' ranges are DiagnoseOptions::IsValid's (docs/diagnose.md, "Options").
//
// Writes DIR/diagnosis.json, DIR/model.coef (the final model), DIR/report.md and DIR/plots/.
// Exit status (DiagnoseExit): 0 done (whatever the verdict, "none" included); 1 bad input (one
// line "indicial: error: FILE:LINE: problem"; nothing written); 6 stopped at --max-steps with an
// effect still significant (outputs written, a warning line). A final model the runtime refuses
// is bad input too: one line naming DIR/model.coef and the reason, nothing written (exit 1).
// Ill-conditioned final estimates
// (bound larger than the value) are a warning line, exit 0.
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include "command.hpp"
#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/runtime_limits.hpp"

namespace {

enum class DiagnoseExit { done = 0, bad_input = 1, max_steps = 6 };

struct DiagnoseCliOptions {
  std::string experiment;
  std::string out;
  bool force = false;
  bool no_plots = false;
  bool quiet = false;
  std::string gnuplot = "gnuplot";
  std::string coefficient;  // of a multi-coefficient experiment
  indicial::DiagnoseOptions diag;
};

void run_diagnose(const DiagnoseCliOptions& o) {
  using namespace indicial;
  if (o.out.empty()) throw InputError("--out", 0, "an output directory is required");
  if (std::string bad; !o.diag.IsValid(&bad)) throw InputError(bad);  // before reading or writing anything
  const tools::StageClock clock("diagnose", o.quiet ? tools::Verbosity::quiet : tools::Verbosity::progress);
  Experiment e;
  clock.stage("reading the experiment and its runs", [&] { e = load_experiment(o.experiment, o.coefficient); });
  ReportOptions ro;
  ro.notes = e.notes;
  tools::print_notes(e.notes, clock.verbosity());
  ro.warnings = e.warnings;
  tools::print_warnings(ro.warnings);
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  { OutputDir probe(o.out, overwrite, experiment_input_paths(e)); }  // refuse before the long part
  DiagnoseResult d;
  clock.stage("diagnosing (fits of every candidate effect, round by round)",
              [&] { d = diagnose_experiment(e, o.diag); });
  // Never write (or exit 0 with) a model the runtime refuses: one line, nothing written.
  const RuntimeAcceptance accepted =
      require_runtime_accepts(d.fits.back().model, o.out + "/model.coef", ModelFile::to_write);
  if (accepted.capacity == RuntimeCapacity::fit_capacity_only) {
    ro.warnings.push_back(o.out + "/model.coef: " + accepted.reason);
    tools::print_warnings({ro.warnings.back()});
  }
  ro.plots = o.no_plots ? PlotRequest::none : PlotRequest::gnuplot;
  ro.gnuplot = o.gnuplot;
  ro.command_line = tools::invocation();
  ro.provenance = tools::provenance_of(e);
  const std::vector<std::string> after = diagnose_warnings(d);  // listed in diagnosis.json too
  ro.warnings.insert(ro.warnings.end(), after.begin(), after.end());
  DiagnoseOutputs w;
  clock.stage("writing the outputs (runtime check, report, plots)",
              [&] { w = write_diagnose_outputs(d, e, o.diag, o.out, overwrite, ro); });
  std::printf("diagnose: %s: initial fit error %.6g; rule %s (%s)\n", o.experiment.c_str(), d.initial_fit_error,
              decision_rule_name(d.rule), d.rule_reason.c_str());
  if (d.replication.source != NoiseSource::none)
    std::printf("diagnose: noise from replication (%s): %.6g, lag-1 correlation %.2f\n", d.replication.detail.c_str(),
                d.replication.sigma, d.replication.lag1_correlation);
  else
    std::printf("diagnose: no replication, the noise level is unknown (the residual's short-lag level %.6g, "
                "AR(1) phi %.2f, is noise only where the model is right)\n",
                d.noise.white_equivalent, d.noise.lag1_correlation);
  for (const DiagnoseStep& s : d.steps) std::printf("diagnose: %s\n", diagnose_step_line(s).c_str());
  // The verdict is the first (principal) effect; every effect added is said beside it.
  std::string added;
  for (const std::string& x : d.effects_added) added += (added.empty() ? "" : ", ") + x;
  std::printf("diagnose: verdict %s%s; final fit error %.6g (%d fits, %.2f s)\n", d.verdict.c_str(),
              d.effects_added.size() > 1 ? (" (effects added: " + added + ")").c_str() : "", d.final_fit_error,
              d.fits_run, d.elapsed_s);
  std::printf("diagnose: wrote %s/diagnosis.json, model.coef, report.md (%s)\n", o.out.c_str(),
              w.plot_message.c_str());
  std::fflush(stdout);
  tools::print_warnings(after);
  if (w.plots == PlotStatus::gnuplot_not_found || w.plots == PlotStatus::gnuplot_failed)
    std::fprintf(stderr, "indicial: warning: %s\n", w.plot_message.c_str());
  if (d.stopped == DiagnoseStop::max_steps) throw CLI::RuntimeError(static_cast<int>(DiagnoseExit::max_steps));
}

const indicial::tools::RegisterCommand register_diagnose([](CLI::App& app) {
  auto opt = std::make_shared<DiagnoseCliOptions>();
  CLI::App* sub = app.add_subcommand(
      "diagnose",
      "The missing-effect workflow: fit the configured model, test every candidate effect\n(" +
          indicial::effect_names_list() +
          "):\nwith 3 or more runs an effect enters only when it lowers the error of runs left out of\n"
          "its fit (leave-one-run-out); with fewer, likelihood ratio / kappa (from replicates, else\n"
          "the residual) with a Bonferroni guard and BIC; each effect grown into its best sub-model,\n"
          "the best added; repeat. The noise comes from replication (runs at one condition, cycles).\n"
      "Writes DIR/diagnosis.json, DIR/model.coef (final model), DIR/report.md and DIR/plots/.\n"
      "Exit status: 0 done (any verdict, 'none' included); 1 bad input, or a final model the\n"
      "runtime refuses (one line, nothing written); 6 stopped at --max-steps with an effect still\n"
      "significant (outputs written).");
  sub->add_option("experiment", opt->experiment, "experiment file (TOML)")->required();
  sub->add_option("--out", opt->out, "output directory (refused if not empty, unless --force)")->required();
  sub->add_flag("--force", opt->force, "replace the contents of a non-empty output directory");
  sub->add_option("--alpha", opt->diag.alpha,
                  "family-wise significance level per round (default 0.01; Bonferroni over every "
                  "candidate and scanned knot)");
  sub->add_option("--max-steps", opt->diag.max_steps,
                  "effects added at most (default 6); reached with an effect still significant: exit 6");
  sub->add_option("--max-family-terms", opt->diag.max_family_terms,
                  "terms one effect's sub-model may have, e.g. b1(x) knots (default 4)");
  sub->add_option("--knot-spacing-deg", opt->diag.knot_spacing_deg,
                  "knot scan grid spacing in degrees of the model angle (default 5)");
  sub->add_option("--rule", opt->diag.rule,
                  "auto (default): leave-one-run-out with 3 (--cv-min-runs) or more runs, else likelihood "
                  "ratio; cv: leave-one-run-out (an error with fewer runs); lr: likelihood ratio")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, indicial::RuleChoice>{{"auto", indicial::RuleChoice::automatic},
                                                      {"cv", indicial::RuleChoice::leave_one_run_out},
                                                      {"lr", indicial::RuleChoice::likelihood_ratio}},
          CLI::ignore_case));
  sub->add_option("--cv-min-runs", opt->diag.cv_min_runs,
                  "runs --rule auto needs for leave-one-run-out, and --rule cv requires (default 3; >= 2)");
  sub->add_option("--cv-unit", opt->diag.cv_unit,
                  "cross-validation: what a fold leaves out: run (default) or group (whole groups of runs: "
                  "every runs entry needs a group = \"...\", the tunnel entry, campaign or session; at least two)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, indicial::CrossValidationUnit>{{"run", indicial::CrossValidationUnit::run},
                                                               {"group", indicial::CrossValidationUnit::group}},
          CLI::ignore_case));
  sub->add_option("--max-folds", opt->diag.cv_max_folds,
                  "cross-validation with more runs than this: the runs dealt into this many folds (run r "
                  "into fold r mod K), each left out at once (default 10; fewer runs: one run per fold)");
  sub->add_option("--min-gain", opt->diag.cv_min_gain,
                  "cross-validation: an effect must lower the held-out mean square error by at least this "
                  "fraction with three folds or fewer, G 3 / K with K > 3 folds (default 0.10; in [0, 1); 0: the "
                  "standard-error and majority conditions alone)");
  sub->add_option("--min-in-sample-gain", opt->diag.cv_min_in_sample_gain,
                  "cross-validation: an effect must also lower the fit error of all runs by at least this "
                  "fraction of the mean square error (default 0.04; in [0, 1), 0: off)");
  sub->add_option("--threads", opt->diag.threads, "fits run in parallel (default 2)");
  sub->add_option("--stall-start-search", opt->diag.fit.stall_start_search,
                  "a stall candidate's own start: configured (default: the stall_*_start keys) or grid (as "
                  "indicial fit's default: 18 starts of the time constants, the lowest cost kept; slower)")
      ->transform(indicial::tools::stall_start_search_words());
  sub->add_option("--stall-prior", opt->diag.fit.stall_prior,
                  "every fit's a priori stall values: beddoes_leishman (default, docs/formats.md) or none")
      ->transform(indicial::tools::stall_prior_words());
  sub->add_flag("--no-plots", opt->no_plots, "do not run gnuplot");
  sub->add_flag("--quiet", opt->quiet,
                "no progress lines or input-reader notes on stderr (warnings and errors are still printed; "
                "report.md lists the notes)");
  sub->add_option("--coefficient", opt->coefficient,
                  "with an experiment listing several coefficients: the one to diagnose (e.g. Cm)");
  sub->add_option("--gnuplot", opt->gnuplot, "gnuplot executable (default: gnuplot on PATH)");
  sub->callback([opt]() { run_diagnose(*opt); });
});

}  // namespace
