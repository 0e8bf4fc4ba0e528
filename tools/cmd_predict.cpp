// `indicial predict`: run a model on the motion of a run CSV with the embedded runtime.
//
//   indicial predict MODEL.coef DATA.csv [DATA2.csv ...] --out FILE.csv [--plot FILE.png [--gnuplot EXE]]
//                    [--metrics FILE.json] [--airspeed-mps V] [--time-grid uniform|nonuniform] [--periodic]
//                    [--frequency-hz F | --reduced-frequency K] [--samples N] [--experiment E.toml]
//                    [--score-from-s T] [--force] [--quiet]
//   indicial predict MODEL.coef --experiment E.toml --run N --out FILE.csv [...]
//   indicial predict MODEL.coef --experiment E.toml --all-runs --out DIR [--score-from-s T] [--force] [--quiet]
//
// --run N predicts the experiment's run N exactly as fit and diagnose read it (its files, its
// [columns] and each file's own map, its frequency, airspeed and periodicity): a held-out
// cycle kept in an experiment file, such as digitized files headed x,y.
//
// Several DATA files are one cycle whose quantities are at their own phases (digitized
// histories: an experiment's runs entry `files = [...]`, phase_resample.hpp), resampled onto
// --samples uniform phases (default: the most rows of any file) as the fit resamples its runs.
//
// Writes time_s, the angle column as given, <c>_pred, <c>_quasi_steady and the measured <c>
// where DATA.csv has it; where measured, prints the metrics (RMS, max, Theil's inequality
// coefficient, for the model and for the quasi-steady model) and writes them to the CSV's
// comment lines and to FILE.metrics.json (or --metrics). See fitter/.../predict.hpp.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "command.hpp"
#include "indicial/fitter/experiment_checks.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/phase_resample.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/fitter/prediction_output.hpp"
#include "indicial/fitter/runtime_limits.hpp"

namespace {

struct PredictOptions {
  std::string model_path;
  std::vector<std::string> data_paths;  // one run file, or one cycle's files at their own phases
  std::string data_label;               // data_paths joined by " + " (messages, comments)
  int samples = 0;                      // several DATA files: the uniform phases (0: most rows)
  std::string out;
  std::string plot;
  std::string metrics;
  double score_from_s = -std::numeric_limits<double>::infinity();  // --score-from-s
  std::string gnuplot = "gnuplot";
  double airspeed_mps = 0.0;  // 0: the model's reference airspeed
  indicial::TimeGrid grid = indicial::TimeGrid::uniform;
  bool grid_given = false;         // --time-grid on the command line
  std::string experiment;          // read DATA with this experiment's [columns] and [csv]
  int run = 0;                     // --run N (1-based): predict run N of --experiment, read as fit reads it
  bool run_given = false;          // --run on the command line (0 and negatives are refused)
  bool all_runs = false;           // --all-runs: every run of --experiment into the directory --out
  bool force = false;
  bool periodic = false;
  bool quiet = false;              // --quiet: no input notes on stderr
  double frequency_hz = 0.0;       // for a phase column
  double reduced_frequency = 0.0;  // or k = 2 pi f l / V
};

std::string default_metrics_path(const std::string& out) {
  std::filesystem::path p(out);
  if (p.extension() == ".csv") p.replace_extension("");
  return p.string() + ".metrics.json";
}

// Several DATA files: one cycle whose quantities are at their own phases, resampled onto one
// uniform phase grid per coefficient (the measured column is optional for each), as the fit
// reads a runs entry `files = [...]`.
std::vector<indicial::Run> read_cycle_of_files(const PredictOptions& o, const indicial::ModelSet<double, indicial::FitCapacity>& model,
                                               const indicial::RunCsvOptions& read) {
  using namespace indicial;
  if (!(read.frequency_hz > 0.0))
    throw InputError(o.data_label, 0, "several DATA files are one cycle at their own phases: give --frequency-hz or "
                                      "--reduced-frequency");
  if (o.grid_given)
    throw InputError("--time-grid", 0, "does not apply to several DATA files (the cycle is resampled onto --samples "
                                       "uniform phases)");
  if (o.samples != 0 && (o.samples < min_run_samples || o.samples > 100000))
    throw InputError("--samples", 0, "must be " + std::to_string(min_run_samples) + "..100000");
  std::vector<std::vector<PhaseSeries>> series(static_cast<std::size_t>(model.n_coefficients));
  int samples = o.samples;  // one grid for every coefficient: by default the most rows of any file
  for (int c = 0; c < model.n_coefficients; ++c) {
    for (const std::string& path : o.data_paths) {
      series[static_cast<std::size_t>(c)].push_back(read_phase_series(path, model.axis, model.coefficients[c].name, read));
      if (o.samples == 0)
        samples = std::max(samples, static_cast<int>(series[static_cast<std::size_t>(c)].back().phase_rad.size()));
    }
  }
  std::vector<Run> runs;
  for (int c = 0; c < model.n_coefficients; ++c)
    runs.push_back(resample_phase_series(series[static_cast<std::size_t>(c)], model.coefficients[c].name,
                                         CoefficientPresence::optional, read.frequency_hz, samples, o.data_label));
  return runs;
}

// --experiment E.toml with --run N or --all-runs: E's runs as its readers make them, per
// coefficient: E's own, and the model's others read from E's files where a run has them
// (experiment_run notes the runs that do not).
std::vector<indicial::Experiment> read_experiment_runs(const PredictOptions& o,
                                                       const indicial::ModelSet<double, indicial::FitCapacity>& model) {
  using namespace indicial;
  const std::string flag = o.all_runs ? "--all-runs" : "--run";
  if (o.experiment.empty()) throw InputError(flag, 0, "needs --experiment E.toml (the experiment whose runs it predicts)");
  if (!o.data_paths.empty())
    throw InputError(flag, 0, "predicts runs of --experiment: give it or DATA files, not both");
  if (o.all_runs && o.run_given) throw InputError("--all-runs", 0, "predicts every run: --run N does not apply");
  if (o.frequency_hz != 0.0 || o.reduced_frequency != 0.0 || o.samples != 0 || o.grid_given || o.airspeed_mps != 0.0 ||
      o.periodic)
    throw InputError(flag, 0, "the run's frequency, samples, time grid, airspeed and periodicity are its entry's in " +
                                  o.experiment + ": --frequency-hz, --reduced-frequency, --samples, --time-grid, "
                                  "--airspeed-mps and --periodic do not apply");
  // The runs only: a held-out cycle's experiment need not have a [static] table covering it, or
  // knots inside it (the model predicted is MODEL's, not the experiment's).
  // The model's other coefficients too, where the run's files have them (a C_L experiment's
  // cycle carries Cm): scored, not only predicted.
  std::vector<std::string> names;
  for (int c = 0; c < model.n_coefficients; ++c) names.push_back(model.coefficients[c].name);
  const std::vector<Experiment> es = load_experiment_runs(o.experiment, names);
  if (es.front().axis != model.axis)
    throw InputError(flag, 0, o.experiment + " is a " + axis_name(es.front().axis) + " experiment; the model is " +
                                  axis_name(model.axis));
  if (model.axis != Axis::pitch && es.front().alpha0_rad != model.alpha0_rad)
    tools::print_warnings({o.experiment + ": alpha0 " + deg_text(es.front().alpha0_rad) + " deg differs from the model's " +
                           deg_text(model.alpha0_rad) + " deg: the run is predicted at the model's"});
  return es;
}

// Run `index` (0-based) of E's runs, one per model coefficient (read_experiment_runs read each
// one; where the run's files lack one it is predicted only, said in a note).
std::vector<indicial::Run> experiment_run(const PredictOptions& o, const std::vector<indicial::Experiment>& es,
                                          std::size_t index,
                                          const indicial::ModelSet<double, indicial::FitCapacity>& model) {
  using namespace indicial;
  std::vector<Run> runs;
  std::vector<std::string> notes;
  for (int c = 0; c < model.n_coefficients; ++c) {
    const std::string& name = model.coefficients[c].name;
    const auto same = std::find_if(es.begin(), es.end(), [&](const Experiment& e) { return e.coefficient == name; });
    // Why the fallback: load_experiment_runs reads every name asked; E's first run's motion,
    // unmeasured, should that ever change.
    runs.push_back((same != es.end() ? *same : es.front()).runs[index]);
    if (same == es.end()) runs.back().coefficient.clear();
    if (runs.back().coefficient.empty())
      notes.push_back(runs.back().path + ": no " + name + " column: " + name + " predicted, not scored (" +
                      o.experiment + " does not model it)");
  }
  tools::print_notes(notes, o.quiet ? tools::Verbosity::quiet : tools::Verbosity::progress);
  return runs;
}

// The run files a prediction read (never overwritten, even with --force).
std::vector<std::string> run_inputs(const indicial::Run& run) {
  std::vector<std::string> inputs = run.source_files;
  if (inputs.empty()) inputs.push_back(run.path);
  return inputs;
}

// One run predicted and scored: the prediction, its metric lines and warnings, and the CSV's
// comment lines.
struct PredictedRun {
  indicial::Prediction p;
  std::vector<std::string> lines;     // prediction_metrics_lines
  std::vector<std::string> warnings;  // prediction_warnings (unnamed)
  std::vector<std::string> comments;  // the CSV's # lines
  std::string angle_column;
  bool any_measured = false;
};

// Predicts the run (one per model coefficient: the measured column where present) at the
// airspeed and scores it, printing the reader's notes and warnings.
PredictedRun predict_run(const PredictOptions& o, const indicial::ModelSet<double, indicial::FitCapacity>& model,
                         const std::vector<indicial::Run>& runs, double airspeed, const std::string& data_label,
                         const std::string& command) {
  using namespace indicial;
  const Run& run = runs.front();
  tools::print_notes(run.notes, o.quiet ? tools::Verbosity::quiet : tools::Verbosity::progress);
  tools::print_warnings(run.warnings);
  // A phase cycle carries no airspeed, and the airspeed sets its lags' and stall states' time
  // constants (l / V) and, with --reduced-frequency, its frequency: without --airspeed-mps it is
  // predicted at the model's reference airspeed, said (a user's trial predicted 27 and 54 m/s
  // cycles at 40 m/s without a word).
  if (o.airspeed_mps == 0.0 && o.run == 0 && !o.all_runs && run.time_source == TimeSource::phase_column) {
    tools::print_warnings({data_label + ": no --airspeed-mps: the cycle is predicted at the model's reference "
                                          "airspeed, " + format_double(airspeed) + " m/s (give the cycle's own)"});
  }
  // A phase column is one ensemble-averaged cycle: periodic whether or not --periodic is given.
  // (An experiment's run, --run, is periodic as its entry says.)
  const bool from_experiment = o.run > 0 || o.all_runs;
  const bool periodic = o.periodic || run.time_source == TimeSource::phase_column || (from_experiment && run.periodic);
  if (o.periodic && run.time_source == TimeSource::time_column) {
    const std::string problem = periodic_closure_problem(run);
    if (!problem.empty()) throw InputError(data_label, 0, "--periodic: the file is " + problem);
  }
  PredictedRun r;
  r.angle_column = run.angle_column;  // echoed in the unit the file used
  require_runtime_accepts(model, o.model_path, ModelFile::read);  // a refused model names the file
  r.p = periodic ? predict_periodic(model, run.time_s, run.motion_angle_rad, run.rate_radps, airspeed, o.model_path)
                 : predict_motion(model, run.time_s, run.motion_angle_rad, run.rate_radps, airspeed, o.model_path);
  for (std::size_t c = 0; c < r.p.coefficients.size(); ++c) {
    r.p.coefficients[c].measured = runs[c].coefficient;
    r.any_measured = r.any_measured || !runs[c].coefficient.empty();
  }
  score_coefficients(r.p, o.score_from_s);
  r.lines = prediction_metrics_lines(r.p);
  r.comments = {"indicial predict " + o.model_path + " " + command,
                periodic ? "predicted with the runtime (indicial::Predictor): the cycle's periodic steady state"
                         : "predicted with the runtime (indicial::Predictor), reset to the steady state at the first "
                           "sample"};
  for (const auto& l : r.lines) r.comments.push_back(l);
  r.warnings = prediction_warnings(r.p);
  for (const auto& w : r.warnings) r.comments.push_back("warning: " + w);
  return r;
}

// Predicts the run and writes the outputs (all or none), as `predict` prints them.
void predict_and_write(const PredictOptions& o, const indicial::ModelSet<double, indicial::FitCapacity>& model,
                       const std::vector<indicial::Run>& runs, double airspeed, const std::string& data_label,
                       const std::vector<std::string>& data_inputs) {
  using namespace indicial;
  const Overwrite overwrite = o.force ? Overwrite::replace : Overwrite::refuse;
  const std::string command = o.run > 0 ? "--experiment " + o.experiment + " --run " + std::to_string(o.run) + " (" +
                                               data_label + ")"
                                         : data_label;
  const PredictedRun r = predict_run(o, model, runs, airspeed, data_label, command);
  const Prediction& p = r.p;
  const bool any_measured = r.any_measured;
  const std::vector<std::string>& lines = r.lines;
  const std::vector<std::string>& warnings = r.warnings;

  // Refuse before writing anything, so that outputs appear all or none (barring disk errors).
  const std::string metrics_path =
      any_measured ? (o.metrics.empty() ? default_metrics_path(o.out) : o.metrics) : std::string();
  if (overwrite == Overwrite::refuse) {
    for (const std::string& f : {o.out, metrics_path, o.plot})
      if (!f.empty() && std::filesystem::exists(f))
        throw InputError(f, 0, "output file exists (use --force to replace it)");
  }
  // --force replaces outputs, never an input (the model, a DATA file, the experiment).
  std::vector<std::string> inputs = data_inputs;
  inputs.push_back(o.model_path);
  inputs.push_back(o.experiment);
  for (const std::string& f : {o.out, metrics_path, o.plot}) refuse_output_onto_input(f, inputs);
  if (!o.plot.empty()) {
    write_prediction_plot(p, o.plot, "indicial predict: " + std::filesystem::path(data_label).filename().string(),
                          overwrite, o.gnuplot);
  }
  if (!metrics_path.empty()) write_file_atomically(metrics_path, prediction_metrics_json(p), overwrite);
  write_file_atomically(o.out, prediction_csv(p, r.angle_column, r.comments), overwrite);

  std::printf("predict: %zu samples, %zu coefficient(s) -> %s\n", p.time_s.size(),
              p.coefficients.size(), o.out.c_str());
  for (const auto& l : lines) std::printf("predict: %s\n", l.c_str());
  // On stderr named by the data, as every other warning is (the CSV's comment lines need no name).
  std::vector<std::string> named;
  for (const std::string& w : warnings) named.push_back(data_label + ": " + w);
  tools::print_warnings(named);
  if (!metrics_path.empty()) std::printf("predict: metrics -> %s\n", metrics_path.c_str());
  if (!o.plot.empty()) std::printf("predict: plot -> %s\n", o.plot.c_str());
}

// A summary.csv field: quoted as RFC 4180 when it holds a comma, quote or newline (a file name).
std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string q = "\"";
  for (char ch : text) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
  return q + "\"";
}

// --all-runs: the summary table, one row per run and scored coefficient.
std::string all_runs_summary_csv(const std::vector<std::vector<std::string>>& rows) {
  std::string out =
      "run,name,coefficient,n_samples,clamped_samples,rms_error,quasi_steady_rms_error,ratio_to_quasi_steady,"
      "mean_error,rms_about_mean,max_error\n";
  for (const auto& row : rows) {
    for (std::size_t i = 0; i < row.size(); ++i) out += (i ? "," : "") + row[i];
    out += "\n";
  }
  return out;
}

// Every run of --experiment predicted as --run N predicts it, into the directory --out (all or
// nothing): run<N>.csv and run<N>.metrics.json per run, summary.csv (one row per run and scored
// coefficient: RMS, quasi-steady RMS, their ratio, the bias and the RMS about it), and the
// table on stdout with, per coefficient, the mean RMS ratio and the runs at <= 0.5x.
void predict_all_runs(const PredictOptions& o, const indicial::ModelSet<double, indicial::FitCapacity>& model) {
  using namespace indicial;
  if (!o.plot.empty() || !o.metrics.empty())
    throw InputError("--all-runs", 0, "writes run<N>.csv, run<N>.metrics.json and summary.csv into the directory "
                                      "--out: --plot and --metrics do not apply");
  const std::vector<Experiment> es = read_experiment_runs(o, model);
  std::vector<std::string> inputs = {o.model_path, o.experiment};
  for (const Run& r : es.front().runs)
    for (const std::string& f : run_inputs(r)) inputs.push_back(f);
  OutputDir dir(o.out, o.force ? Overwrite::replace : Overwrite::refuse, inputs);
  std::vector<std::vector<std::string>> rows;
  std::map<std::string, std::vector<double>> ratios;  // per coefficient, over the scored runs
  for (std::size_t i = 0; i < es.front().runs.size(); ++i) {
    const std::vector<Run> runs = experiment_run(o, es, i, model);
    const double airspeed = runs.front().airspeed_mps > 0.0 ? runs.front().airspeed_mps : model.airspeed_mps;
    const std::string n = std::to_string(i + 1);
    PredictedRun r;
    try {
      r = predict_run(o, model, runs, airspeed, runs.front().path,
                      "--experiment " + o.experiment + " --run " + n + " (" + runs.front().path + ")");
    } catch (const InputError& err) {  // which run, then why; nothing is written (the directory is staged)
      throw InputError("--all-runs: run " + n + " (" + runs.front().path + "): " + err.what());
    }
    dir.write("run" + n + ".csv", prediction_csv(r.p, r.angle_column, r.comments));
    if (r.any_measured) dir.write("run" + n + ".metrics.json", prediction_metrics_json(r.p));
    std::vector<std::string> named;
    for (const std::string& w : r.warnings) named.push_back(runs.front().path + ": " + w);
    tools::print_warnings(named);
    for (const CoefficientPrediction& c : r.p.coefficients) {
      if (c.scored != CoefficientPrediction::Scored::scored) continue;
      const ErrorMetrics& m = c.model_metrics;
      const double qs = c.quasi_steady_metrics.rms_error;
      const double ratio = qs > 0.0 ? m.rms_error / qs : std::numeric_limits<double>::quiet_NaN();
      ratios[c.name].push_back(ratio);
      rows.push_back({n, csv_field(runs.front().path), c.name, std::to_string(m.n_samples),
                      std::to_string(r.p.clamped_samples), format_double(m.rms_error), format_double(qs),
                      format_double(ratio), format_double(m.mean_error), format_double(m.rms_about_mean),
                      format_double(m.max_error)});
      std::printf("%s", fmt::format("predict: run {} {}: RMS {:.6g} (quasi-steady {:.6g}, ratio {:.3g}), bias {:.6g}\n",
                                    n, c.name, m.rms_error, qs, ratio, m.mean_error).c_str());
    }
  }
  dir.write("summary.csv", all_runs_summary_csv(rows));
  dir.commit();
  for (const auto& [name, rs] : ratios) {
    std::size_t half = 0, finite = 0;
    double sum = 0.0;
    for (double v : rs) {
      if (!std::isfinite(v)) continue;  // a quasi-steady RMS of 0 has no ratio
      ++finite;
      half += v <= 0.5 ? 1 : 0;
      sum += v;
    }
    std::printf("predict: %s over %zu run(s): mean ratio to quasi-steady %.3g, %zu at <= 0.5x%s\n", name.c_str(),
                finite, finite > 0 ? sum / static_cast<double>(finite) : std::nan(""), half,
                finite < rs.size() ? fmt::format(" ({} without a ratio: quasi-steady RMS 0)", rs.size() - finite).c_str()
                                   : "");
  }
  std::printf("predict: %zu run(s) -> %s (run<N>.csv, summary.csv)\n", es.front().runs.size(), o.out.c_str());
}

void run_predict(const PredictOptions& o) {
  using namespace indicial;
  if (o.out.empty()) throw InputError("--out", 0, "an output CSV path is required");
  if (std::filesystem::is_directory(o.model_path))
    throw InputError(o.model_path + " is a directory, expected a coefficient file (.coef)");
  for (const std::string& f : o.data_paths)
    if (std::filesystem::is_directory(f)) throw InputError(f + " is a directory, expected a CSV file");
  if (o.run_given && o.run < 1) throw InputError("--run", 0, "must be >= 1 (runs are numbered from 1)");
  if (o.data_paths.empty() && o.run == 0 && !o.all_runs)
    throw InputError("DATA", 0, "give the run file(s) to predict, or --experiment E.toml --run N (or --all-runs)");
  if (o.data_paths.size() == 1 && o.samples != 0)
    throw InputError("--samples", 0, "is for several DATA files (one cycle at their own phases); one run file is "
                                     "predicted at its own samples");
  const auto model = std::make_unique<ModelSet<double, FitCapacity>>(read_model_file(o.model_path));
  if (o.airspeed_mps < 0.0) throw InputError("--airspeed-mps", 0, "must be > 0");
  if (o.all_runs) {
    predict_all_runs(o, *model);
    return;
  }
  if (o.run > 0) {
    const std::vector<Experiment> es = read_experiment_runs(o, *model);
    const std::size_t n_runs = es.front().runs.size();
    if (static_cast<std::size_t>(o.run) > n_runs)
      throw InputError("--run", 0, o.experiment + " has " + std::to_string(n_runs) + " run(s): give 1.." +
                                       std::to_string(n_runs));
    const std::vector<Run> runs = experiment_run(o, es, static_cast<std::size_t>(o.run - 1), *model);
    const double airspeed = runs.front().airspeed_mps > 0.0 ? runs.front().airspeed_mps : model->airspeed_mps;
    predict_and_write(o, *model, runs, airspeed, runs.front().path, run_inputs(runs.front()));
    return;
  }
  const double airspeed = o.airspeed_mps > 0.0 ? o.airspeed_mps : model->airspeed_mps;

  // One read per coefficient: the measured column is optional for each.
  RunCsvOptions read;
  if (!o.experiment.empty()) read = run_file_format(o.experiment);
  if (o.grid_given) read.grid = o.grid;
  read.frequency_source = FrequencySource::command_line;
  if (o.frequency_hz < 0.0 || o.reduced_frequency < 0.0 || (o.frequency_hz > 0.0 && o.reduced_frequency > 0.0))
    throw InputError("--frequency-hz", 0, "give one of --frequency-hz and --reduced-frequency, > 0");
  // k = 2 pi f l / V with the model's reference length and the run's airspeed.
  read.frequency_hz = o.reduced_frequency > 0.0
                          ? frequency_hz_from_reduced(o.reduced_frequency, airspeed, model->reference_length_m)
                          : o.frequency_hz;
  std::vector<Run> runs;
  if (o.data_paths.size() > 1) {
    runs = read_cycle_of_files(o, *model, read);
  } else {
    for (int c = 0; c < model->n_coefficients; ++c)
      runs.push_back(read_run_csv(o.data_paths.front(), model->axis, model->coefficients[c].name,
                                  CoefficientPresence::optional, read));
  }
  predict_and_write(o, *model, runs, airspeed, o.data_label, o.data_paths);
}

const indicial::tools::RegisterCommand register_predict([](CLI::App& app) {
  auto opt = std::make_shared<PredictOptions>();
  CLI::App* sub = app.add_subcommand(
      "predict",
      "Predict the coefficient(s) of a model for the motion in a run CSV, with the runtime.\n"
      "Writes time_s, the angle column, <c>_pred (static + rotary + unsteady), <c>_quasi_steady\n"
      "(static + rotary) and the measured <c> where present. Where measured, prints and writes\n"
      "RMS error, maximum error and Theil's inequality coefficient\n"
      "  TIC = sqrt(mean e^2) / (sqrt(mean m^2) + sqrt(mean p^2))   (0 perfect, 1 worst)\n"
      "and the bias, mean e (e = predicted - measured), with the RMS about it (a run's zero drift\n"
      "apart from the error in the shape), for the model and for the quasi-steady model.");
  sub->add_option("MODEL", opt->model_path, "coefficient file (.coef)")->required();
  sub->add_option("DATA", opt->data_paths,
                  "run CSV: time_s (or a phase column), the angle column, optional rate and coefficients; or "
                  "several files, one cycle whose quantities are at their own phases (each file its own phase "
                  "column: a digitized history, an experiment's files = [...]), with --frequency-hz or "
                  "--reduced-frequency (or none: --experiment E.toml --run N)");
  sub->add_option("--out", opt->out, "output CSV (with --all-runs: an output directory)")->required();
  sub->add_option("--plot", opt->plot, "overlay plot PNG (gnuplot): against time and against angle");
  sub->add_option("--gnuplot", opt->gnuplot, "gnuplot executable (default: gnuplot on PATH)");
  sub->add_option("--metrics", opt->metrics, "metrics JSON (default: OUT with .metrics.json)");
  sub->add_option("--airspeed-mps", opt->airspeed_mps,
                  "tunnel airspeed of the run (default: the model's reference airspeed)");
  sub->add_option("--time-grid", opt->grid,
                  "uniform (default: the step is checked to 1e-6 relative) or nonuniform (a log with "
                  "timestamp jitter or dropped samples: the runtime steps with each sample's own dt; "
                  "an absent rate column is a local least-squares derivative in time)")
      ->transform(CLI::CheckedTransformer(
          std::map<std::string, indicial::TimeGrid>{{"uniform", indicial::TimeGrid::uniform},
                                                    {"nonuniform", indicial::TimeGrid::nonuniform}}));
  sub->add_flag("--quiet", opt->quiet,
                "no notes on stderr on what the reader did (warnings and errors are still printed): for loops over "
                "many cycles");
  sub->add_flag("--periodic", opt->periodic,
                "DATA is one cycle of a periodic motion (an ensemble-averaged cycle): predict its periodic "
                "steady state (the cycle closes on its last sample if it repeats the first angle, else "
                "with one more mean step back to the first)");
  sub->add_option("--frequency-hz", opt->frequency_hz,
                  "the cycle's frequency, for a DATA file with a phase_rad/phase_deg/phase_cycles column (then --periodic "
                  "is implied)");
  sub->add_option("--reduced-frequency", opt->reduced_frequency,
                  "or its reduced frequency k = 2 pi f l / V (l: the model's reference length, V: the airspeed)");
  sub->add_option("--samples", opt->samples,
                  "several DATA files: the uniform phases they are resampled onto (default: the most rows of any "
                  "file)");
  sub->add_option("--experiment", opt->experiment,
                  "read DATA as the experiment file E.toml reads its runs: its [columns] map (file column -> "
                  "ours, e.g. Cnormal = \"Cn\") and its [csv] dialect");
  sub->add_option("--run", opt->run,
                  "with --experiment and no DATA: predict the experiment's run N (1-based) exactly as fit reads "
                  "it -- its files, [columns] and each file's own map, frequency, airspeed and periodicity (a "
                  "held-out cycle kept in an experiment file; digitized files headed x,y)");
  sub->add_flag("--all-runs", opt->all_runs,
                "with --experiment and no DATA: predict every run of the experiment as --run N does, into the "
                "directory --out: run<N>.csv and run<N>.metrics.json, and summary.csv (per run and coefficient: RMS, "
                "quasi-steady RMS, their ratio, bias, RMS about the bias, max error); a held-out experiment scored "
                "in one command");
  sub->add_option("--score-from-s", opt->score_from_s,
                  "score (RMS, max, TIC) only the samples at time >= T s; every sample is still predicted and "
                  "written (a raw multi-cycle log: leave out the start-up transient of the initial state)");
  sub->add_flag("--force", opt->force, "replace existing outputs");
  sub->callback([opt, sub]() {
    opt->grid_given = sub->get_option("--time-grid")->count() > 0;
    opt->run_given = sub->get_option("--run")->count() > 0;
    opt->data_label.clear();
    for (const std::string& f : opt->data_paths) opt->data_label += (opt->data_label.empty() ? "" : " + ") + f;
    run_predict(*opt);
  });
});

}  // namespace
