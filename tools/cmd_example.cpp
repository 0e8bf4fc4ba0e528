// `indicial example`: the README's main job, end to end on the reference report's Example 1.
//
//   indicial example --out DIR [--force] [--seed N] [--tables 2|all] [--no-plots]
//
// For each table: simulate the tailless aircraft of Table I (the accurate reference
// integration, written as run CSVs + experiment.toml + truth.coef exactly like
// `indicial simulate --case`), fit it from those files (`indicial fit`'s code path: CSV and
// TOML ingest, equation error, ML output error, report), load the written model.coef into the
// runtime (indicial::Predictor) and replay every run, comparing with the fitter's model output
// (same equations: agreement at rounding level), then print our estimates and Cramer-Rao bounds
// beside the report's:
//   Table II   Model I, SNR 40 and SNR 20 (a(x) without a0, as in the report)
//   Table III  Model II data at SNR 40, fitted with Model II's b1(x) spline and with Model I's
//              constant b1 (the modelling error the table demonstrates)
//   Table IV   Model I data at SNR 40 with C_mq = -1.4 fixed, then with the two-stage loop
//              re-estimating C_mq(alpha) (candidates 1, alpha, alpha^2) from -1.4
// The report's numbers are quoted from its tables (Klein & Murphy, NASA 1998; its Table II
// SNR-40 A_1 bound misprints 0.044 as 0.44, corrected here); the truth comes from the simulated
// case's model. Exit status 2 if the runtime replay disagrees with the fitter by more than 1e-9.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fmt/format.h>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/montecarlo.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/fitter/simulate.hpp"

namespace fs = std::filesystem;

namespace {

constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
// Largest acceptable |runtime - fitter| difference: the same equations in the same order give
// rounding-level agreement (~1e-15); 1e-9 leaves room for compiler reordering, not for a bug.
constexpr double kRuntimeTolerance = 1e-9;

struct ExampleOptions {
  std::string out;
  bool force = false;
  std::uint64_t seed = 1;
  std::string tables = "all";
  bool no_plots = false;
};

// One row of a report table: our parameter name and the report's estimate and bound.
struct ReportRow {
  std::string name;
  std::string report_name;
  double report_value;
  double report_bound;
};

struct Column {
  std::string title;          // e.g. "Table II, Model I, SNR 40"
  std::string fit_dir;        // relative to DIR
  std::vector<ReportRow> rows;
  double report_fit_error;
};

struct ColumnResult {
  indicial::FitResult fit;
  indicial::RuntimeCheck runtime;
  double noise_sigma = 0.0;
};

std::string fmt_or_dash(double v, const char* spec = "{:.4g}") {
  return std::isfinite(v) ? fmt::format(fmt::runtime(spec), v) : std::string("-");
}

const indicial::ParameterEstimate* find_param(const indicial::FitResult& r, const std::string& name) {
  for (const auto& p : r.parameters)
    if (p.name == name) return &p;
  return nullptr;
}

// The table printed on the terminal and written to example.md.
std::string column_table(const Column& c, const ColumnResult& cr, const indicial::TruthModel& truth) {
  std::string t;
  t += fmt::format("{}\n", c.title);
  t += fmt::format("  {:<8} {:>8}   {:>17}   {:>19} {:>10} {:>11}\n", "param", "true", "report (bound)",
                   "indicial (CR bound)", "colored", "|err|/CR");
  for (const ReportRow& row : c.rows) {
    const double tv = indicial::true_parameter_value(truth, cr.fit.model, row.name);
    const auto* p = find_param(cr.fit, row.name);
    const std::string rep = std::isfinite(row.report_value)
                                ? fmt::format("{:.4g} ({:.2g})", row.report_value, row.report_bound)
                                : std::string("-");
    std::string ours = "-", col = "-", err = "-";
    if (p != nullptr) {
      ours = fmt::format("{:.5g} ({:.2g})", p->value, p->cr_bound);
      col = fmt_or_dash(p->cr_bound_colored, "{:.2g}");
      if (std::isfinite(tv) && p->cr_bound > 0) err = fmt::format("{:.2f}", std::fabs(p->value - tv) / p->cr_bound);
    }
    t += fmt::format("  {:<8} {:>8}   {:>17}   {:>19} {:>10} {:>11}\n", row.report_name, fmt_or_dash(tv), rep,
                     ours, col, err);
  }
  t += fmt::format("  {:<8} {:>8}   {:>17}   {:>19}\n", "s(v)", fmt::format("{:.4g}*", cr.noise_sigma),
                   fmt_or_dash(c.report_fit_error), fmt::format("{:.4g}", cr.fit.fit_error));
  t += fmt::format("  (* the noise standard deviation; ML {} after {} iterations, {:.2f} s; runtime replay of "
                   "model.coef: max |runtime - fitter| = {:.2g} over {} samples; outputs in {})\n",
                   indicial::termination_name(cr.fit.output_error.termination), cr.fit.output_error.iterations,
                   cr.fit.elapsed_s, cr.runtime.max_abs_difference, cr.runtime.samples_compared, c.fit_dir);
  return t;
}

// Simulates `case_name` at `snr` into DIR/<data_dir> (the `simulate --case` writer).
double simulate_into(const std::string& case_name, const fs::path& data_dir, double snr, std::uint64_t seed) {
  const indicial::SimulationCase& c = indicial::find_simulation_case(case_name);
  const std::vector<double> sigma =
      indicial::write_simulation_case(c, data_dir.string(), snr, seed, indicial::Overwrite::refuse);
  return sigma.empty() ? 0.0 : sigma[0];
}

// Rewrites an experiment file with a changed configuration (the runs stay the same files).
// load_experiment resolved the run paths; the file names them relative to itself again (they
// sit beside it), so the data set stays valid after the output directory is moved into place.
void write_variant(const indicial::Experiment& e, const fs::path& path, const std::string& comment) {
  indicial::Experiment rel = e;
  for (indicial::Run& r : rel.runs) r.path = fs::path(r.path).filename().string();
  indicial::write_text(path, indicial::write_experiment_toml(rel, {comment}));
}

ColumnResult fit_column(const fs::path& experiment, const fs::path& fit_dir, double sigma,
                        const ExampleOptions& o) {
  using namespace indicial;
  ColumnResult cr;
  cr.noise_sigma = sigma;
  const Experiment e = load_experiment(experiment.string());
  FitOptions fo;
  cr.fit = fit_experiment(e, fo);
  ReportOptions ro;
  ro.plots = o.no_plots ? PlotRequest::none : PlotRequest::gnuplot;
  const std::string shown = "../" + experiment.parent_path().filename().string() + "/" + experiment.filename().string();
  ro.command_line = "indicial fit " + shown + " --out " + fit_dir.filename().string();
  ro.experiment_display = shown;
  // Provenance as for that `indicial fit`, input paths as shown (the data set is still in the
  // staging directory now, under its final name later).
  ro.provenance = experiment_provenance(e, ro.command_line + " (by " + tools::invocation() + ")",
                                       tools::build_commit());
  for (InputDigest& d : ro.provenance.inputs)
    d.path = "../" + experiment.parent_path().filename().string() + "/" + fs::path(d.path).filename().string();
  write_fit_outputs(cr.fit, e, fo, fit_dir, Overwrite::refuse, ro);
  // The runtime loads the file as written on disk, not the in-memory text.
  cr.runtime = replay_in_runtime(cr.fit, e, read_text(fit_dir / "model.coef"));
  return cr;
}

void run_example(const ExampleOptions& o) {
  using namespace indicial;
  if (o.out.empty()) throw InputError("--out", 0, "an output directory is required");
  if (o.tables != "2" && o.tables != "all") throw InputError("--tables", 0, "expected 2 or all");
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  OutputDir out(o.out, overwrite);
  const fs::path stage = out.staging_dir();
  const TruthModel& truth1 = find_simulation_case("tailless-model-1").truth;
  const TruthModel& truth2 = find_simulation_case("tailless-model-2").truth;
  std::string md = "# indicial example: the reference report's Example 1\n\n";
  md += fmt::format("Seed {} for every data set. Columns: true value (the simulated model), the report's "
                    "estimate and Cramer-Rao bound, ours and our Cramer-Rao bound, our colored-residual bound, "
                    "and |ours - true| / our bound.\n\n```\n", o.seed);
  bool runtime_ok = true;
  auto emit = [&](const Column& c, const ColumnResult& cr, const TruthModel& truth) {
    const std::string t = column_table(c, cr, truth);
    std::fputs(t.c_str(), stdout);
    std::fputs("\n", stdout);
    std::fflush(stdout);
    md += t + "\n";
    if (!(cr.runtime.max_abs_difference <= kRuntimeTolerance) || cr.runtime.fit == RuntimeFit::refused ||
        cr.runtime.samples_compared == 0)
      runtime_ok = false;
  };

  const std::vector<ReportRow> model1_rows_40 = {{"b1_0", "b1", 2.503, 0.0032}, {"a1", "a1", 0.28, 0.010},
                                                 {"a2", "a2", -3.21, 0.022},    {"A1", "A1", 8.0, 0.044},
                                                 {"A2", "A2", -7.6, 0.20}};
  const std::vector<ReportRow> model1_rows_20 = {{"b1_0", "b1", 2.500, 0.0066}, {"a1", "a1", 0.27, 0.021},
                                                 {"a2", "a2", -3.17, 0.046},    {"A1", "A1", 7.91, 0.092},
                                                 {"A2", "A2", -6.8, 0.42}};
  std::printf("example: simulate -> fit -> runtime, seed %llu (outputs under %s)\n\n",
              static_cast<unsigned long long>(o.seed), o.out.c_str());

  // Table II: Model I at SNR 40 and 20, a(x) = a1 x + a2 x^2 + knots (no a0, as the report).
  double sigma_model1_snr40 = 0.0;
  for (double snr : {40.0, 20.0}) {
    const std::string tag = fmt::format("model1-snr{:.0f}", snr);
    const double sigma = simulate_into("tailless-model-1", stage / tag, snr, o.seed);
    if (snr == 40.0) sigma_model1_snr40 = sigma;
    Experiment e = load_experiment((stage / tag / "experiment.toml").string());
    e.model.a.powers = {1, 2};
    write_variant(e, stage / tag / "experiment.toml",
                  "Example 1, Model I, fitted as in the report's Table II: a(x) without a0");
    const ColumnResult cr = fit_column(stage / tag / "experiment.toml", stage / ("fit-table2-" + tag), sigma, o);
    emit(Column{fmt::format("Table II: Model I, SNR {:.0f}", snr), "fit-table2-" + tag,
                snr == 40.0 ? model1_rows_40 : model1_rows_20, snr == 40.0 ? 0.0041 : 0.0085},
         cr, truth1);
  }

  if (o.tables == "all") {
    // Table III: Model II data, fitted with Model II's b1(x) and with a constant b1 (Model I).
    const double sigma2 = simulate_into("tailless-model-2", stage / "model2-snr40", 40.0, o.seed);
    Experiment e2 = load_experiment((stage / "model2-snr40" / "experiment.toml").string());
    e2.model.a.powers = {1, 2};
    write_variant(e2, stage / "model2-snr40" / "experiment.toml",
                  "Example 1, Model II data fitted with Model II (report Table III)");
    Experiment e2m1 = e2;
    e2m1.model.b1.knots_rad.clear();
    write_variant(e2m1, stage / "model2-snr40" / "experiment-model1.toml",
                  "Example 1, Model II data fitted with Model I's constant b1 (report Table III)");
    const ColumnResult m2 = fit_column(stage / "model2-snr40" / "experiment.toml",
                                       stage / "fit-table3-model2", sigma2, o);
    emit(Column{"Table III: Model II data (SNR 40), Model II fitted", "fit-table3-model2",
                {{"b1_0", "b10", 2.513, 0.0069}, {"B1", "B1", -5.9, 0.12}, {"B2", "B2", 5.9, 0.21},
                 {"B3", "B3", 5.8, 0.28}, {"B4", "B4", -5.9, 0.39}, {"a1", "a1", 0.26, 0.013},
                 {"a2", "a2", -3.16, 0.029}, {"A1", "A1", 7.92, 0.059}, {"A2", "A2", -7.0, 0.25}},
                0.0045},
         m2, truth2);
    const ColumnResult m1 = fit_column(stage / "model2-snr40" / "experiment-model1.toml",
                                       stage / "fit-table3-model1", sigma2, o);
    emit(Column{"Table III: Model II data (SNR 40), Model I fitted (b1 constant: a modelling error)",
                "fit-table3-model1",
                {{"b1_0", "b10", 2.277, 0.0056}, {"a1", "a1", 0.67, 0.021}, {"a2", "a2", -4.25, 0.047},
                 {"A1", "A1", 10.06, 0.094}, {"A2", "A2", -9.2, 0.43}},
                0.0087},
         m1, truth2);

    // Table IV: Model I data at SNR 40 (the Table II data), C_mq = -1.4 fixed, then estimated.
    const fs::path d1 = stage / "model1-snr40";
    Experiment e4 = load_experiment((d1 / "experiment.toml").string());
    e4.rotary.polynomial = {-1.4};
    e4.rotary.estimate = false;
    write_variant(e4, d1 / "experiment-cmq-fixed.toml", "Report Table IV: C_mq = -1.4 (a modelling error)");
    e4.rotary.estimate = true;
    e4.rotary.candidates = SplineConfig{{0, 1, 2}, {}, 1};
    write_variant(e4, d1 / "experiment-cmq-estimated.toml",
                  "Report Table IV: C_mq(alpha) re-estimated by the two-stage loop from -1.4");
    const ColumnResult fixed = fit_column(d1 / "experiment-cmq-fixed.toml", stage / "fit-table4-cmq-fixed",
                                          sigma_model1_snr40, o);
    emit(Column{"Table IV: Model I data (SNR 40), C_mq = -1.4 fixed (a modelling error)", "fit-table4-cmq-fixed",
                {{"b1_0", "b1", 2.385, 0.0071}, {"a1", "a1", 0.55, 0.022}, {"a2", "a2", -3.62, 0.050},
                 {"A1", "A1", 8.49, 0.099}, {"A2", "A2", -8.1, 0.45}},
                0.0092},
         fixed, truth1);
    const ColumnResult est = fit_column(d1 / "experiment-cmq-estimated.toml",
                                        stage / "fit-table4-cmq-estimated", sigma_model1_snr40, o);
    emit(Column{fmt::format("Table IV: same data, C_mq(alpha) estimated by the two-stage loop from -1.4 "
                            "({} iterations)", est.fit.two_stage.size()),
                "fit-table4-cmq-estimated",
                {{"b1_0", "b1", 2.464, 0.0033}, {"a1", "a1", 0.32, 0.010}, {"a2", "a2", -3.26, 0.023},
                 {"A1", "A1", 8.08, 0.045}, {"A2", "A2", -7.6, 0.21}, {"Caq_0", "Cmq_0", -1.939, 0.0043},
                 {"Caq_1", "Cmq_1", kNone, kNone}, {"Caq_2", "Cmq_2", 0.804, 0.0072}},
                0.0042},
         est, truth1);
  }
  md += "```\n";
  out.write("example.md", md);
  out.commit();
  std::printf("example: wrote %s (data sets, fits with report.md and plots, example.md)\n", o.out.c_str());
  if (!runtime_ok) {
    std::fprintf(stderr, "indicial: error: the runtime's replay of model.coef differs from the fitter's model "
                         "output by more than %.0e (see the tables above)\n", kRuntimeTolerance);
    throw CLI::RuntimeError(2);
  }
}

const indicial::tools::RegisterCommand register_example([](CLI::App& app) {
  auto opt = std::make_shared<ExampleOptions>();
  CLI::App* sub = app.add_subcommand(
      "example",
      "The built-in example (the reference report's Example 1): simulate -> fit -> runtime replay,\n"
      "printing our estimates and bounds beside the report's Tables II (Model I, SNR 40 and 20),\n"
      "III (Model II data, Model II and Model I fits) and IV (two-stage C_mq estimation).\n"
      "Writes the data sets, every fit's fit.json / model.coef / report.md / plots and example.md\n"
      "under DIR. Exit status 2 if the runtime disagrees with the fitter.");
  sub->add_option("--out", opt->out, "output directory (refused if not empty, unless --force)")->required();
  sub->add_flag("--force", opt->force, "replace the contents of a non-empty output directory");
  sub->add_option("--seed", opt->seed, "noise seed for every data set (default 1)");
  sub->add_option("--tables", opt->tables, "2: Table II only; all: Tables II-IV (default)");
  sub->add_flag("--no-plots", opt->no_plots, "do not run gnuplot");
  sub->callback([opt]() { run_example(*opt); });
});

}  // namespace
