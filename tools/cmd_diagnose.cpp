// `indicial diagnose`: the missing-effect workflow (fitter/include/indicial/fitter/diagnose.hpp).
//
//   indicial diagnose EXPERIMENT.toml --out DIR [--force] [--alpha 0.01] [--max-steps N]
//                     [--knot-spacing-deg D] [--no-plots] [--gnuplot EXE]
//
// Writes DIR/diagnosis.json, DIR/model.coef (the final model), DIR/report.md and DIR/plots/.
// Exit status: 0 done (whatever the verdict, "none" included); 1 bad input (one line
// "indicial: error: FILE:LINE: problem"; nothing written).
#include <cstdio>
#include <memory>
#include <string>

#include "command.hpp"
#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"

namespace {

struct DiagnoseCliOptions {
  std::string experiment;
  std::string out;
  bool force = false;
  bool no_plots = false;
  std::string gnuplot = "gnuplot";
  std::string coefficient;  // of a multi-coefficient experiment
  indicial::DiagnoseOptions diag;
};

void run_diagnose(const DiagnoseCliOptions& o, const std::string& command_line) {
  using namespace indicial;
  if (o.out.empty()) throw InputError("--out", 0, "an output directory is required");
  if (!(o.diag.alpha > 0.0 && o.diag.alpha < 1.0))
    throw InputError("--alpha", 0, "the significance level must be in (0, 1)");
  if (o.diag.max_steps < 0) throw InputError("--max-steps", 0, "must be >= 0");
  if (!(o.diag.knot_spacing_deg > 0.0)) throw InputError("--knot-spacing-deg", 0, "must be > 0");
  const Experiment e = load_experiment(o.experiment, o.coefficient);
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  { OutputDir probe(o.out, overwrite); }  // refuse a non-empty DIR before the long part
  const DiagnoseResult d = diagnose_experiment(e, o.diag);
  ReportOptions ro;
  ro.plots = o.no_plots ? PlotRequest::none : PlotRequest::gnuplot;
  ro.gnuplot = o.gnuplot;
  ro.command_line = command_line;
  const DiagnoseOutputs w = write_diagnose_outputs(d, e, o.diag, o.out, overwrite, ro);
  std::printf("diagnose: %s: initial fit error %.6g, noise estimate %.6g\n", o.experiment.c_str(),
              d.initial_fit_error, d.noise.sigma);
  for (const DiagnoseStep& s : d.steps)
    std::printf("diagnose: step %d: %s (%s): LR %.1f, p %.3g < %.3g, fit error %.6g -> %.6g\n", s.step,
                effect_name(s.effect), s.detail.c_str(), s.statistic, s.p_value, s.threshold,
                s.fit_error_before, s.fit_error_after);
  std::printf("diagnose: verdict %s; final fit error %.6g (%d fits, %.2f s)\n", d.verdict.c_str(),
              d.final_fit_error, d.fits_run, d.elapsed_s);
  std::printf("diagnose: wrote %s/diagnosis.json, model.coef, report.md (%s)\n", o.out.c_str(),
              w.plot_message.c_str());
  if (w.runtime.fit == RuntimeFit::refused)
    std::printf("diagnose: WARNING: the runtime refuses model.coef: %s\n", w.runtime.detail.c_str());
  if (w.plots == PlotStatus::gnuplot_not_found || w.plots == PlotStatus::gnuplot_failed)
    std::fprintf(stderr, "indicial: warning: %s\n", w.plot_message.c_str());
  std::fflush(stdout);
}

const indicial::tools::RegisterCommand register_diagnose([](CLI::App& app) {
  auto opt = std::make_shared<DiagnoseCliOptions>();
  CLI::App* sub = app.add_subcommand(
      "diagnose",
      "The missing-effect workflow: fit the configured model, test every candidate effect\n"
      "(b1_alpha, a_alpha, rotary_alpha, bias, time_delay, second_lag, static_error) by a\n"
      "likelihood-ratio test with a Bonferroni guard and BIC, add the most significant, repeat.\n"
      "Writes DIR/diagnosis.json, DIR/model.coef (final model), DIR/report.md and DIR/plots/.\n"
      "Exit status: 0 done (any verdict, 'none' included); 1 bad input (nothing written).");
  sub->add_option("experiment", opt->experiment, "experiment file (TOML)")->required();
  sub->add_option("--out", opt->out, "output directory (refused if not empty, unless --force)")->required();
  sub->add_flag("--force", opt->force, "replace the contents of a non-empty output directory");
  sub->add_option("--alpha", opt->diag.alpha,
                  "family-wise significance level per round (default 0.01; Bonferroni over every "
                  "candidate and scanned knot)");
  sub->add_option("--max-steps", opt->diag.max_steps, "effects added at most (default 6)");
  sub->add_option("--knot-spacing-deg", opt->diag.knot_spacing_deg,
                  "knot scan grid spacing in degrees of the model angle (default 5)");
  sub->add_flag("--no-plots", opt->no_plots, "do not run gnuplot");
  sub->add_option("--coefficient", opt->coefficient,
                  "with an experiment listing several coefficients: the one to diagnose (e.g. Cm)");
  sub->add_option("--gnuplot", opt->gnuplot, "gnuplot executable (default: gnuplot on PATH)");
  sub->callback([opt]() {
    std::string cl = "indicial diagnose " + opt->experiment + " --out " + opt->out;
    if (opt->force) cl += " --force";
    run_diagnose(*opt, cl);
  });
});

}  // namespace
