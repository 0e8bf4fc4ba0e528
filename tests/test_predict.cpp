// Prediction with the runtime (fitter/.../predict.hpp) and `indicial predict`.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>
#include <unistd.h>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/fitter/prediction_output.hpp"
#include "indicial/fitter/simulate.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;

// 30 deg + A sin(2 pi 0.7 t), sampled at 100 Hz: a motion Model II was never built around.
indicial::MotionSpec sine_at_0_7_hz(double amplitude_deg, int cycles) {
  indicial::MotionSpec s;
  s.kind = indicial::MotionKind::sine;
  s.mean_rad = 30.0 * kDeg;
  s.amplitude_rad = amplitude_deg * kDeg;
  s.freq_hz = 0.7;
  s.cycles = cycles;
  s.dt_s = 0.01;
  return s;
}

using indicial::testing::TempDir;

int run(const std::string& cmd) { return std::system((cmd + " > /dev/null 2>&1").c_str()); }

std::string slurp_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("predict: metrics on hand-checked values") {
  const auto perfect = indicial::score_prediction({1.0, -2.0, 3.0}, {1.0, -2.0, 3.0});
  CHECK(perfect.rms_error == 0.0);
  CHECK(perfect.max_error == 0.0);
  CHECK(perfect.theil_inequality == 0.0);
  // e = (0, 2): RMS = sqrt(2), max 2; RMS(m) = 1, RMS(p) = 1 -> TIC = sqrt(2) / 2.
  const auto m = indicial::score_prediction({1.0, -1.0}, {1.0, 1.0});
  CHECK(m.rms_error == doctest::Approx(std::sqrt(2.0)));
  CHECK(m.max_error == doctest::Approx(2.0));
  CHECK(m.theil_inequality == doctest::Approx(std::sqrt(2.0) / 2.0));
  // Theil's decomposition: mean e = 1, e - mean e = (-1, 1): RMS about it 1, U^M = 1 / 2.
  CHECK(m.mean_error == doctest::Approx(1.0));
  CHECK(m.rms_about_mean == doctest::Approx(1.0));
  CHECK(m.bias_proportion == doctest::Approx(0.5));
  CHECK(perfect.mean_error == 0.0);
  CHECK(perfect.bias_proportion == 0.0);
  // A pure offset is all bias; a zero-mean error none, and RMS^2 = bias^2 + spread^2.
  const auto offset = indicial::score_prediction({0.3, -0.1, 0.7}, {0.35, -0.05, 0.75});
  CHECK(offset.mean_error == doctest::Approx(0.05));
  CHECK(offset.rms_about_mean == doctest::Approx(0.0).scale(1.0).epsilon(1e-12));
  CHECK(offset.bias_proportion == doctest::Approx(1.0));
  const auto spread = indicial::score_prediction({0.0, 0.0, 0.0, 0.0}, {0.1, -0.1, 0.3, -0.3});
  CHECK(spread.mean_error == doctest::Approx(0.0).scale(1.0).epsilon(1e-15));
  CHECK(spread.bias_proportion == doctest::Approx(0.0).scale(1.0).epsilon(1e-15));
  const auto mixed = indicial::score_prediction({1.0, 2.0, 3.0}, {1.5, 2.1, 3.7});
  CHECK(mixed.rms_error * mixed.rms_error ==
        doctest::Approx(mixed.mean_error * mixed.mean_error + mixed.rms_about_mean * mixed.rms_about_mean));
  // p = -m is the worst case: TIC = 1; p = 0 also gives 1.
  CHECK(indicial::score_prediction({0.3, -0.1, 0.7}, {-0.3, 0.1, -0.7}).theil_inequality ==
        doctest::Approx(1.0));
  CHECK(indicial::score_prediction({0.3, -0.1, 0.7}, {0.0, 0.0, 0.0}).theil_inequality ==
        doctest::Approx(1.0));
  CHECK_THROWS_AS(indicial::score_prediction({1.0}, {1.0, 2.0}), std::invalid_argument);
}

TEST_CASE("predict: the runtime's prediction follows the reference integration on a new motion") {
  // Model II of Example 1 on a motion it was never built around: 20 deg amplitude, 0.7 Hz.
  const auto& c = indicial::find_simulation_case("tailless-model-2");
  const indicial::SimulatedRun sim = indicial::simulate_reference(c.truth, sine_at_0_7_hz(20.0, 3));
  indicial::Prediction p =
      indicial::predict_motion(c.truth, sim.time_s, sim.motion_angle_rad, sim.rate_radps,
                               c.truth.airspeed_mps);
  REQUIRE(p.coefficients.size() == 1);
  CHECK(p.clamped_samples == 0);
  p.coefficients[0].measured = sim.coefficient_true[0];
  indicial::score_coefficients(p);
  const auto& cp = p.coefficients[0];
  MESSAGE("runtime vs reference integration: RMS " << cp.model_metrics.rms_error << ", max "
                                                   << cp.model_metrics.max_error << ", TIC "
                                                   << cp.model_metrics.theil_inequality);
  MESSAGE("quasi-steady vs reference: RMS " << cp.quasi_steady_metrics.rms_error << ", TIC "
                                            << cp.quasi_steady_metrics.theil_inequality);
  // The runtime's update is second order in dt: measured RMS 1.6e-5, max 3.4e-5 at dt = 0.01 s
  // (tolerance 1e-4 / 2e-4); the quasi-steady model misses the whole unsteady part (~0.14).
  CHECK(cp.model_metrics.rms_error < 1e-4);
  CHECK(cp.model_metrics.max_error < 2e-4);
  CHECK(cp.quasi_steady_metrics.rms_error > 0.05);
  // The quasi-steady column is exactly static + rotary at the sample.
  const auto& m = c.truth.coefficients[0];
  for (std::size_t i = 0; i < sim.time_s.size(); i += 37) {
    const double qs = indicial::spline_value(m.static_curve.polynomial, sim.x_rad[i]) +
                      c.truth.reference_length_m / c.truth.airspeed_mps *
                          indicial::spline_value(m.rotary, sim.x_rad[i]) * sim.rate_radps[i];
    CHECK(cp.quasi_steady[i] == doctest::Approx(qs).epsilon(1e-12));
  }
}

TEST_CASE("predict: score_from_s scores the samples from that time on, predicts them all") {
  // A start-up transient (here a measured column off by 1 over its first 40 samples, as a log
  // that starts before the tunnel settled) dominates the RMS over every sample and is left out
  // from the first time scored on. The scored tail's metrics are score_prediction's on it.
  const auto& c = indicial::find_simulation_case("tailless-model-2");
  const indicial::SimulatedRun sim = indicial::simulate_reference(c.truth, sine_at_0_7_hz(10.0, 2));
  indicial::Prediction p = indicial::predict_motion(c.truth, sim.time_s, sim.motion_angle_rad, sim.rate_radps,
                                                    c.truth.airspeed_mps);
  std::vector<double> measured = sim.coefficient_true[0];
  for (std::size_t i = 0; i < 40; ++i) measured[i] += 1.0;
  p.coefficients[0].measured = measured;
  indicial::score_coefficients(p);
  CHECK(p.scored_samples == sim.time_s.size());
  CHECK(p.first_scored == 0);
  CHECK(p.coefficients[0].model_metrics.rms_error > 0.1);
  indicial::score_coefficients(p, sim.time_s[40] - 0.001);  // between samples 39 and 40
  CHECK(p.first_scored == 40);
  CHECK(p.scored_samples == sim.time_s.size() - 40);
  CHECK(p.coefficients[0].predicted.size() == sim.time_s.size());  // every sample still predicted
  CHECK(p.coefficients[0].model_metrics.rms_error < 1e-4);
  const std::vector<double> tail_m(measured.begin() + 40, measured.end());
  const std::vector<double> tail_q(p.coefficients[0].quasi_steady.begin() + 40, p.coefficients[0].quasi_steady.end());
  CHECK(p.coefficients[0].quasi_steady_metrics.rms_error ==
        doctest::Approx(indicial::score_prediction(tail_m, tail_q).rms_error).epsilon(1e-15));
  // Past the last sample but one, or NaN: refused, naming the option and the data's range.
  const auto score_error = [&p](double from_s) {
    try {
      indicial::score_coefficients(p, from_s);
    } catch (const indicial::InputError& e) {
      return std::string(e.what());
    }
    return std::string("(nothing thrown)");
  };
  CHECK_HAS(score_error(sim.time_s.back()), "--score-from-s");
  CHECK_HAS(score_error(sim.time_s.back()), "leaves 1 sample(s)");
  CHECK_HAS(score_error(std::nan("")), "--score-from-s");
}

TEST_CASE("predict: angles outside the envelope are clamped and counted") {
  const auto& c = indicial::find_simulation_case("tailless-model-1");  // envelope 0..70 deg
  std::vector<double> t, a, q;
  for (int i = 0; i < 200; ++i) {
    t.push_back(0.01 * i);
    a.push_back((60.0 + 0.1 * i) * kDeg);  // reaches 79.9 deg
    q.push_back(10.0 * kDeg);
  }
  const auto p = indicial::predict_motion(c.truth, t, a, q, c.truth.airspeed_mps);
  CHECK(p.clamped_samples == 99);  // 70.1 .. 79.9 deg
  CHECK(indicial::prediction_warnings(p).at(0).find("99 of 200 samples are outside the model's envelope") == 0);
}

TEST_CASE("predict: outside the envelope a static table is used at the true angle, the rest at the edge") {
  // CL of the example: a static table 0..70 deg; the envelope narrowed to 0..40 deg, as if the
  // training cycles had stayed below 40 deg.
  auto model = indicial::read_model_file(std::string(INDICIAL_SOURCE_DIR) + "/examples/synthetic-lift-moment.coef");
  model.x_max_rad = 40 * kDeg;
  std::vector<double> t, a, q;
  for (int i = 0; i < 300; ++i) {
    t.push_back(0.01 * i);
    a.push_back((10.0 + 50.0 * std::sin(kPi * 0.01 * i / 3.0)) * kDeg);  // 10 .. 60 deg
    q.push_back(50.0 * kPi / 3.0 * std::cos(kPi * 0.01 * i / 3.0) * kDeg);
  }
  const auto p = indicial::predict_motion(model, t, a, q, model.airspeed_mps);
  CHECK(p.clamped_samples > 100);
  const auto& cl = model.coefficients[0];
  const double l_over_v = model.reference_length_m / model.airspeed_mps;
  int outside = 0;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const double edge = std::min(a[i], model.x_max_rad);
    const double qs = indicial::static_value(cl.static_curve, a[i]) + indicial::spline_value(cl.static_correction, edge) +
                      l_over_v * indicial::spline_value(cl.rotary, edge) * q[i];
    CHECK(p.coefficients[0].quasi_steady[i] == doctest::Approx(qs).epsilon(1e-12));
    CHECK(std::isfinite(p.coefficients[0].predicted[i]));
    CHECK(std::isfinite(p.coefficients[1].predicted[i]));
    outside += a[i] > model.x_max_rad;
  }
  CHECK(outside == static_cast<int>(p.clamped_samples));
  // At 60 deg the table (0.9) is far from its value at the envelope's edge, 40 deg (1.05).
  CHECK(indicial::static_value(cl.static_curve, 60 * kDeg) - indicial::static_value(cl.static_curve, 40 * kDeg) < -0.1);
}

TEST_CASE("predict: CLI writes the CSV and metrics and plot and refuses overwrite and bad input") {
  TempDir tmp;
  const std::string exe = INDICIAL_EXE;
  const std::string sim_dir = (tmp.path / "sim").string();
  REQUIRE(run(exe + " simulate --case tailless-model-2 --out " + sim_dir + " --snr 40 --seed 3") == 0);
  const std::string coef = sim_dir + "/truth.coef";
  const std::string data = sim_dir + "/run_f0.50.csv";
  const std::string out = (tmp.path / "pred.csv").string();
  const std::string png = (tmp.path / "pred.png").string();
  const std::string cmd = exe + " predict " + coef + " " + data + " --out " + out + " --plot " + png;
  REQUIRE(run(cmd) == 0);

  // Columns: time_s, alpha_deg as given, Cm_pred, Cm_quasi_steady, Cm.
  std::ifstream in(out);
  std::string line, header;
  std::vector<std::vector<double>> rows;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (header.empty()) {
      header = line;
      continue;
    }
    std::stringstream ss(line);
    std::string cell;
    std::vector<double> r;
    while (std::getline(ss, cell, ',')) r.push_back(std::stod(cell));
    rows.push_back(r);
  }
  CHECK(header == "time_s,alpha_deg,Cm_pred,Cm_quasi_steady,Cm");
  const indicial::Run run_in =
      indicial::read_run_csv(data, indicial::Axis::pitch, "Cm", indicial::CoefficientPresence::required);
  REQUIRE(rows.size() == run_in.size());
  for (std::size_t i = 0; i < rows.size(); i += 50) {
    CHECK(rows[i][1] == doctest::Approx(run_in.motion_angle_rad[i] / kDeg).epsilon(1e-14));
    CHECK(rows[i][4] == run_in.coefficient[i]);
  }
  // The metrics file agrees with the library on the same data.
  const auto model = indicial::read_model_file(coef);
  indicial::Prediction p = indicial::predict_motion(model, run_in.time_s, run_in.motion_angle_rad,
                                                    run_in.rate_radps, model.airspeed_mps);
  p.coefficients[0].measured = run_in.coefficient;
  indicial::score_coefficients(p);
  std::ifstream jf((tmp.path / "pred.metrics.json").string());
  REQUIRE(jf.good());
  const nlohmann::json j = nlohmann::json::parse(jf);
  const auto& jc = j["coefficients"][0];
  CHECK(jc["name"] == "Cm");
  // The file holds the in-process numbers to rounding: relative 1e-12 (scale 0). doctest's default
  // is an absolute ~1.2e-5, 0.3 % of this rms_error (~0.0035).
  CHECK(jc["model"]["rms_error"].get<double>() ==
        doctest::Approx(p.coefficients[0].model_metrics.rms_error).epsilon(1e-12).scale(0));
  CHECK(jc["quasi_steady"]["theil_inequality"].get<double>() ==
        doctest::Approx(p.coefficients[0].quasi_steady_metrics.theil_inequality).epsilon(1e-12).scale(0));
  CHECK(jc["model"]["rms_about_mean"].get<double>() ==
        doctest::Approx(p.coefficients[0].model_metrics.rms_about_mean).epsilon(1e-12).scale(0));
  CHECK(jc["quasi_steady"]["mean_error"].get<double>() ==
        doctest::Approx(p.coefficients[0].quasi_steady_metrics.mean_error).epsilon(1e-12).scale(0));
  CHECK(jc["model"]["bias_proportion"].get<double>() ==
        doctest::Approx(p.coefficients[0].model_metrics.bias_proportion).epsilon(1e-12).scale(0));
  // With the true model on noisy data the model's error is the noise (SNR 40: sigma ~ 0.0035).
  CHECK(jc["model"]["rms_error"].get<double>() < 0.006);
  CHECK(jc["model"]["rms_error"].get<double>() < jc["quasi_steady"]["rms_error"].get<double>() / 5);
  CHECK(fs::file_size(png) > 1000);

  CHECK(run(cmd) != 0);                // exists: refused without --force
  CHECK(run(cmd + " --force") == 0);
  // The plot cannot be drawn (--gnuplot names a missing executable): exit 1 and nothing written
  // (the plot is made first), no temporary left.
  const std::string out3 = (tmp.path / "nogp.csv").string();
  CHECK(run(exe + " predict " + coef + " " + data + " --out " + out3 + " --plot " + (tmp.path / "nogp.png").string() +
            " --gnuplot /nonexistent/gnuplot") != 0);
  CHECK_FALSE(fs::exists(out3));
  CHECK_FALSE(fs::exists(tmp.path / "nogp.png"));
  CHECK_FALSE(fs::exists(tmp.path / "nogp.metrics.json"));
  for (const auto& entry : fs::directory_iterator(tmp.path))
    CHECK(entry.path().filename().string().find(".tmp-") == std::string::npos);
  CHECK(run(exe + " predict " + coef + " " + sim_dir + "/nope.csv --out " + out + "x") != 0);
  CHECK(run(exe + " predict " + data + " " + data + " --out " + out + "y") != 0);  // not a model
  // --force replaces outputs, never an input: --out onto the DATA file or the model is refused.
  const std::string data_before = slurp_file(data), coef_before = slurp_file(coef);
  CHECK(run(exe + " predict " + coef + " " + data + " --out " + data + " --force") != 0);
  CHECK(run(exe + " predict " + coef + " " + data + " --out " + out + " --metrics " + coef + " --force") != 0);
  CHECK(slurp_file(data) == data_before);
  CHECK(slurp_file(coef) == coef_before);

  // No measured column: prediction only, no metrics file.
  const std::string motion = (tmp.path / "motion.csv").string();
  {
    std::ofstream f(motion);
    f << "# a motion without a coefficient\ntime_s,alpha_rad\n";
    for (int i = 0; i < 100; ++i) f << 0.01 * i << "," << 0.3 + 0.2 * std::sin(0.05 * i) << "\n";
  }
  const std::string out2 = (tmp.path / "pred2.csv").string();
  REQUIRE(run(exe + " predict " + coef + " " + motion + " --out " + out2) == 0);
  CHECK_FALSE(fs::exists(tmp.path / "pred2.metrics.json"));
  std::ifstream in2(out2);
  std::string h2;
  while (std::getline(in2, h2))
    if (!h2.empty() && h2[0] != '#') break;
  CHECK(h2 == "time_s,alpha_rad,Cm_pred,Cm_quasi_steady");

  // Beyond the envelope (0..70 deg): the warning goes to stderr with the prefix, stdout has none.
  const std::string beyond = (tmp.path / "beyond.csv").string();
  {
    std::ofstream f(beyond);
    f << "time_s,alpha_deg\n";
    for (int i = 0; i < 50; ++i) f << 0.01 * i << "," << 60 + 0.4 * i << "\n";
  }
  const std::string so = (tmp.path / "so.txt").string(), se = (tmp.path / "se.txt").string();
  REQUIRE(std::system((exe + " predict " + coef + " " + beyond + " --out " + (tmp.path / "b.csv").string() + " > " + so +
                       " 2> " + se).c_str()) == 0);
  auto slurp = [](const std::string& f) {
    std::ifstream i(f);
    return std::string(std::istreambuf_iterator<char>(i), std::istreambuf_iterator<char>());
  };
  CHECK(slurp(se).find("of 50 samples are outside the model's envelope") != std::string::npos);
  CHECK(slurp(se).find("indicial: warning: ") != std::string::npos);
  CHECK(slurp(so).find("warning") == std::string::npos);
}

// The dynamic-stall case's cycles in `sim` and its C_L fit in `fit`: the model.coef's path.
std::string fit_dynamic_stall_cl(const fs::path& sim, const fs::path& fit) {
  const std::string exe = INDICIAL_EXE;
  REQUIRE(run(exe + " simulate --case dynamic-stall --out " + sim.string()) == 0);
  REQUIRE(run(exe + " fit " + (sim / "experiment-CL.toml").string() + " --out " + fit.string() + " --no-plots") == 0);
  return (fit / "model.coef").string();
}

// --run reads the model's coefficients that E does not model from E's run files where they are
// (a C_m experiment's cycle carries C_L): scored as the same file given as DATA scores them;
// where a file lacks one, a note says so and the prediction is still written.
TEST_CASE("predict: --run scores the model's coefficients the experiment does not model") {
  TempDir tmp;
  const std::string exe = INDICIAL_EXE;
  const fs::path sim = tmp.path / "sim";
  const std::string coef = fit_dynamic_stall_cl(sim, tmp.path / "fit");  // a C_L model
  const fs::path by_run = tmp.path / "run.csv", by_file = tmp.path / "file.csv";
  REQUIRE(run(exe + " predict " + coef + " --experiment " + (sim / "experiment-Cm.toml").string() +
              " --run 2 --out " + by_run.string()) == 0);
  REQUIRE(run(exe + " predict " + coef + " " + (sim / "a8_k0.080_v30.csv").string() +
              " --reduced-frequency 0.08 --airspeed-mps 30 --out " + by_file.string()) == 0);
  const std::string a = slurp_file(by_run.string()), b = slurp_file(by_file.string());
  auto data_of = [](const std::string& text) { return text.substr(text.find("\ntime_s")); };
  CHECK(data_of(a).rfind("\ntime_s,alpha_deg,CL_pred,CL_quasi_steady,CL\n", 0) == 0);
  CHECK(data_of(a) == data_of(b));  // the same samples, predictions and measured C_L
  const nlohmann::json j = nlohmann::json::parse(slurp_file((tmp.path / "run.metrics.json").string()));
  CHECK(j["coefficients"][0]["measured"] == true);
  // A held-out cycle with no C_L column: predicted, not scored, and said.
  {
    std::ofstream f(tmp.path / "cm_only.csv");
    f << "phase_rad,alpha_deg,Cm\n";
    for (int i = 0; i < 64; ++i) {
      const double ph = 2 * 3.141592653589793 * i / 64;
      f << ph << "," << 8 + 6 * std::sin(ph) << "," << -0.01 * std::sin(ph) << "\n";
    }
  }
  const fs::path held = tmp.path / "held.toml", err = tmp.path / "err.txt", out = tmp.path / "cm.csv";
  std::ofstream(held) << "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.15\nairspeed_mps = 30\n"
                         "runs = [{file = \"cm_only.csv\", reduced_frequency = 0.08}]\n";
  REQUIRE(std::system((exe + " predict " + coef + " --experiment " + held.string() + " --run 1 --out " + out.string() +
                       " 2> " + err.string()).c_str()) == 0);
  const std::string said = slurp_file(err.string());
  CHECK(said.find("indicial: note: " + (tmp.path / "cm_only.csv").string() + ": no CL column: CL predicted, not scored (" +
                  held.string() + " does not model it)") != std::string::npos);
  // A C_L column that is there is read as fit reads it: a bad value is refused, not skipped.
  {
    std::ofstream f(tmp.path / "bad_cl.csv");
    f << "phase_rad,alpha_deg,Cm,CL\n";
    for (int i = 0; i < 64; ++i) {
      const double ph = 2 * 3.141592653589793 * i / 64;
      f << ph << "," << 8 + 6 * std::sin(ph) << "," << -0.01 * std::sin(ph) << "," << (i == 20 ? "0.5x" : "0.5") << "\n";
    }
  }
  const fs::path bad = tmp.path / "bad.toml";
  std::ofstream(bad) << "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.15\nairspeed_mps = 30\n"
                        "runs = [{file = \"cm_only.csv\", reduced_frequency = 0.08}, "
                        "{file = \"bad_cl.csv\", reduced_frequency = 0.08}]\n";
  const fs::path bad_out = tmp.path / "bad_out.csv";
  REQUIRE(std::system((exe + " predict " + coef + " --experiment " + bad.string() + " --run 1 --out " +
                       bad_out.string() + " 2> " + err.string()).c_str()) != 0);
  CHECK(slurp_file(err.string()).find("bad_cl.csv:22: column 'CL'") != std::string::npos);
  CHECK_FALSE(fs::exists(bad_out));
  CHECK(slurp_file(out.string()).find("CL_pred") != std::string::npos);
  CHECK_FALSE(fs::exists(tmp.path / "cm.metrics.json"));
}

// --all-runs: every run of E predicted as --run N predicts it, into one directory (all or
// nothing), with summary.csv's row per run the numbers of that run's own metrics file.
TEST_CASE("predict: --all-runs predicts every run of the experiment as --run N does") {
  TempDir tmp;
  const std::string exe = INDICIAL_EXE;
  const fs::path sim = tmp.path / "sim";
  const std::string coef = fit_dynamic_stall_cl(sim, tmp.path / "fit");
  const std::string e = (sim / "experiment-CL.toml").string();
  const fs::path all = tmp.path / "all";
  REQUIRE(run(exe + " predict " + coef + " --experiment " + e + " --all-runs --out " + all.string() + " --quiet") == 0);
  std::ifstream summary(all / "summary.csv");
  std::string line;
  std::getline(summary, line);
  CHECK(line == "run,name,coefficient,n_samples,clamped_samples,rms_error,quasi_steady_rms_error,"
                "ratio_to_quasi_steady,mean_error,rms_about_mean,max_error");
  int rows = 0;
  while (std::getline(summary, line)) {
    ++rows;
    std::vector<std::string> f;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) f.push_back(cell);
    REQUIRE(f.size() == 11);
    CHECK(f[0] == std::to_string(rows));
    CHECK(f[2] == "CL");
    // The same run by --run N: the same prediction file's data and metrics.
    const fs::path one = tmp.path / ("one" + f[0] + ".csv");
    REQUIRE(run(exe + " predict " + coef + " --experiment " + e + " --run " + f[0] + " --out " + one.string() +
                " --quiet") == 0);
    const std::string a = slurp_file(one.string()), b = slurp_file((all / ("run" + f[0] + ".csv")).string());
    CHECK(a.substr(a.find("\ntime_s")) == b.substr(b.find("\ntime_s")));
    const nlohmann::json j = nlohmann::json::parse(slurp_file((tmp.path / ("one" + f[0] + ".metrics.json")).string()));
    const auto& m = j["coefficients"][0]["model"];
    CHECK(std::stod(f[5]) == m["rms_error"].get<double>());
    CHECK(std::stod(f[6]) == j["coefficients"][0]["quasi_steady"]["rms_error"].get<double>());
    CHECK(std::stod(f[7]) == doctest::Approx(std::stod(f[5]) / std::stod(f[6])).epsilon(1e-15));
    CHECK(std::stod(f[8]) == m["mean_error"].get<double>());
    CHECK(std::stod(f[9]) == m["rms_about_mean"].get<double>());
  }
  CHECK(rows == 3);
  // All or nothing: a non-empty directory is refused without --force, replaced with it; the
  // options that name one file, and --run beside it, are refused and nothing is written.
  CHECK(run(exe + " predict " + coef + " --experiment " + e + " --all-runs --out " + all.string() + " --quiet") != 0);
  CHECK(run(exe + " predict " + coef + " --experiment " + e + " --all-runs --out " + all.string() +
            " --quiet --force") == 0);
  const fs::path none = tmp.path / "none";
  for (const std::string extra : {" --run 1", " --plot p.png", " --metrics m.json", " --airspeed-mps 30", " --periodic"})
    CHECK(run(exe + " predict " + coef + " --experiment " + e + " --all-runs --out " + none.string() + extra) != 0);
  CHECK(run(exe + " predict " + coef + " " + (sim / "a8_k0.080_v30.csv").string() + " --all-runs --out " +
            none.string()) != 0);
  // A run refused part-way (--score-from-s beyond the second run's cycle, 0.39 s): the error
  // names that run and its file, and nothing is written, not even the runs predicted before it.
  const fs::path err = tmp.path / "err.txt";
  CHECK(std::system((exe + " predict " + coef + " --experiment " + e + " --all-runs --score-from-s 0.5 --quiet --out " +
                     none.string() + " > /dev/null 2> " + err.string()).c_str()) != 0);
  CHECK(slurp_file(err.string()).find("--all-runs: run 2 (" + (sim / "a8_k0.080_v30.csv").string() + "): ") !=
        std::string::npos);
  CHECK_FALSE(fs::exists(none));
}

// A phase cycle carries no airspeed: without --airspeed-mps it is predicted at the model's
// reference airspeed, and says so (a user's trial predicted cycles at 27 and 54 m/s at 40 m/s
// without a word); with it nothing is said. --quiet silences the notes, not the warning.
TEST_CASE("predict: a phase cycle without --airspeed-mps is warned") {
  TempDir tmp;
  const std::string exe = INDICIAL_EXE;
  const fs::path sim = tmp.path / "sim";
  const std::string coef = fit_dynamic_stall_cl(sim, tmp.path / "fit");
  const std::string cycle = (sim / "a8_k0.080_v30.csv").string();
  const std::string se = (tmp.path / "se.txt").string();
  auto stderr_of = [&](const std::string& args) {
    REQUIRE(std::system((exe + " predict " + coef + " " + cycle + args + " --out " + (tmp.path / "p.csv").string() +
                         " --force > /dev/null 2> " + se).c_str()) == 0);
    return slurp_file(se);
  };
  const std::string warned = stderr_of(" --reduced-frequency 0.08");
  CHECK(warned.find("indicial: warning: " + cycle + ": no --airspeed-mps: the cycle is predicted at the model's "
                    "reference airspeed, 30 m/s") != std::string::npos);
  CHECK(stderr_of(" --reduced-frequency 0.08 --airspeed-mps 30").find("--airspeed-mps") == std::string::npos);
  // --quiet: the reader's notes (the snapped phase grid) are not printed; warnings still are.
  CHECK(stderr_of(" --reduced-frequency 0.08 --airspeed-mps 30").find("indicial: note: ") != std::string::npos);
  const std::string quiet = stderr_of(" --reduced-frequency 0.08 --quiet");
  CHECK(quiet.find("indicial: note: ") == std::string::npos);
  CHECK(quiet.find("indicial: warning: " + cycle + ": no --airspeed-mps") != std::string::npos);
}

// A log with dropped samples (irregular steps of 1-3 x 0.01 s): refused as it stands (the
// interface's uniform step), predicted with --time-grid nonuniform, where the runtime steps
// with each sample's own dt. Truth: the reference integration (noise-free simulate output).
TEST_CASE("predict: --time-grid nonuniform predicts a log with dropped samples, without it, refused") {
  TempDir tmp;
  const std::string exe = INDICIAL_EXE;
  const std::string sim_dir = (tmp.path / "sim").string();
  REQUIRE(run(exe + " simulate --case tailless-model-2 --out " + sim_dir) == 0);  // no noise
  const std::string coef = sim_dir + "/truth.coef";
  std::ifstream in(sim_dir + "/run_f0.50.csv");
  std::string line;
  std::vector<std::vector<std::string>> rows;
  bool header_seen = false;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    if (!header_seen) {  // time_s,alpha_deg,q_degps,Cm,Cm_true,y_true
      REQUIRE(line.rfind("time_s,alpha_deg,q_degps,Cm,", 0) == 0);
      header_seen = true;
      continue;
    }
    std::stringstream ss(line);
    std::string cell;
    std::vector<std::string> r;
    while (std::getline(ss, cell, ',')) r.push_back(cell);
    rows.push_back(r);
  }
  REQUIRE(rows.size() > 500);
  // Drop rows 3 mod 7 and 5 mod 11 (about 23 %): steps of 0.01, 0.02 and 0.03 s, irregularly.
  auto write_log = [&](const fs::path& path, bool with_rate) {
    std::ofstream f(path);
    f << "time_s,alpha_deg," << (with_rate ? "q_degps," : "") << "Cm\n";
    for (std::size_t i = 0; i < rows.size(); ++i) {
      if (i % 7 == 3 || i % 11 == 5) continue;
      f << rows[i][0] << "," << rows[i][1] << "," << (with_rate ? rows[i][2] + "," : "") << rows[i][3] << "\n";
    }
  };
  const fs::path with_q = tmp.path / "log_q.csv", without_q = tmp.path / "log.csv";
  write_log(with_q, true);
  write_log(without_q, false);

  // As it stands: refused, naming the file and the first irregular row.
  const fs::path err = tmp.path / "err.txt";
  const std::string refused = exe + " predict " + coef + " " + with_q.string() + " --out " +
                              (tmp.path / "no.csv").string();
  CHECK(std::system((refused + " > /dev/null 2> " + err.string()).c_str()) != 0);
  std::ifstream ef(err);
  const std::string message((std::istreambuf_iterator<char>(ef)), std::istreambuf_iterator<char>());
  CHECK(message.find(with_q.string() + ":5: non-uniform time step") != std::string::npos);
  CHECK_FALSE(fs::exists(tmp.path / "no.csv"));

  for (const fs::path& log : {with_q, without_q}) {
    CAPTURE(log.string());
    const fs::path out = tmp.path / (log.stem().string() + "_pred.csv");
    const fs::path metrics = tmp.path / (log.stem().string() + "_pred.json");
    REQUIRE(run(exe + " predict " + coef + " " + log.string() + " --time-grid nonuniform --out " +
                out.string() + " --metrics " + metrics.string()) == 0);
    std::ifstream jf(metrics);
    const nlohmann::json j = nlohmann::json::parse(jf);
    const double model_rms = j["coefficients"][0]["model"]["rms_error"].get<double>();
    const double qs_rms = j["coefficients"][0]["quasi_steady"]["rms_error"].get<double>();
    MESSAGE(log.filename().string() << ": model RMS " << model_rms << ", quasi-steady RMS " << qs_rms);
    // The true model on noise-free data: what is left is the discrete update's error at steps
    // of up to 0.03 s (and, without q, the derivative of the angle in time).
    CHECK(model_rms < 2e-4);
    CHECK(model_rms < qs_rms / 100.0);
  }
  CHECK(run(exe + " predict " + coef + " " + with_q.string() + " --time-grid sometimes --out " +
            (tmp.path / "x.csv").string()) != 0);
}

// Several DATA files are one cycle whose quantities are at their own phases, resampled as the
// fit resamples a runs entry `files = [...]` (a user's trial: a held-out digitized cycle could
// not be predicted without resampling it by hand). Here the angle and rate at the cycle's 128
// phases and C_L at every other one: on the same phase grid the prediction is the one-file
// prediction (the periodic interpolation returns its nodes exactly); the measured C_L is
// interpolated between its 64 phases.
TEST_CASE("predict: several DATA files are one cycle at their own phases, as the fit's files = [...]") {
  TempDir tmp;
  const std::string exe = INDICIAL_EXE;
  const fs::path sim = tmp.path / "sim";
  const std::string coef = fit_dynamic_stall_cl(sim, tmp.path / "fit");
  const fs::path cycle = sim / "a8_k0.080_v30.csv";  // phase_rad,alpha_deg,q_degps,CL,Cm,...
  std::ifstream in(cycle);
  std::ofstream angle(tmp.path / "angle.csv"), lift(tmp.path / "lift.csv");
  angle << "phase_rad,alpha_deg,q_degps\n";
  lift << "phase_rad,CL\n";
  int row = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#' || line[0] == 'p') continue;
    std::stringstream ss(line);
    std::vector<std::string> c;
    for (std::string cell; std::getline(ss, cell, ',');) c.push_back(cell);
    // The exact phase 2 pi i / 128: the file's is rounded to 0.01 rad, which its reader snaps to
    // this grid, and a series at its own phases takes as given.
    const std::string phase = indicial::format_double(2 * kPi * row / 128.0);
    angle << phase << "," << c[1] << "," << c[2] << "\n";
    if (row++ % 2 == 0) lift << phase << "," << c[3] << "\n";
  }
  angle.close();
  lift.close();
  const std::string k = " --reduced-frequency 0.08 --airspeed-mps 30";
  const fs::path one = tmp.path / "one.csv", two = tmp.path / "two.csv";
  REQUIRE(run(exe + " predict " + coef + " " + cycle.string() + k + " --out " + one.string()) == 0);
  REQUIRE(run(exe + " predict " + coef + " " + (tmp.path / "angle.csv").string() + " " +
              (tmp.path / "lift.csv").string() + k + " --samples 128 --out " + two.string()) == 0);
  auto columns = [](const fs::path& p) {
    std::ifstream f(p);
    std::vector<std::vector<double>> rows;
    for (std::string line; std::getline(f, line);) {
      if (line.empty() || line[0] == '#' || line[0] == 't') continue;
      std::stringstream ss(line);
      std::vector<double> r;
      for (std::string cell; std::getline(ss, cell, ',');) r.push_back(std::stod(cell));
      rows.push_back(r);
    }
    return rows;
  };
  const auto a = columns(one), b = columns(two);  // time_s, alpha_deg, CL_pred, CL_quasi_steady, CL
  REQUIRE(a.size() == 128);
  REQUIRE(b.size() == 128);
  double worst_pred = 0, worst_measured = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    worst_pred = std::max(worst_pred, std::abs(a[i][2] - b[i][2]));
    worst_measured = std::max(worst_measured, std::abs(a[i][4] - b[i][4]));
    if (i % 2 == 0) CHECK(b[i][4] == doctest::Approx(a[i][4]).epsilon(1e-12));  // C_L's own phases
  }
  MESSAGE("largest difference: prediction " << worst_pred << ", measured C_L " << worst_measured);
  CHECK(worst_pred < 1e-9);
  CHECK(worst_measured < 0.02);
  // The same cycle kept in an experiment file as a digitizer exports it (every file headed x,y,
  // each with its own column map) and predicted by --run: the same prediction (--run reads the
  // run as fit does; predict's DATA files could not say which y is which).
  for (const char* name : {"angle", "lift"}) {
    std::ifstream named(tmp.path / (std::string(name) + ".csv"));
    std::ofstream xy(tmp.path / (std::string(name) + "_xy.csv"));
    std::string line;
    std::getline(named, line);  // our header, replaced by x,y[,z]
    xy << (std::string(name) == "angle" ? "x,y,z\n" : "x,y\n");
    while (std::getline(named, line)) xy << line << "\n";
  }
  const fs::path held = tmp.path / "held.toml", three = tmp.path / "three.csv";
  std::ofstream(held) << "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.15\nairspeed_mps = 30\n"
                         "runs = [{files = [{file = \"angle_xy.csv\", columns = {phase_rad = \"x\", alpha_deg = \"y\", "
                         "q_degps = \"z\"}}, {file = \"lift_xy.csv\", columns = {phase_rad = \"x\", CL = \"y\"}}], "
                         "reduced_frequency = 0.08, airspeed_mps = 30, samples = 128}]\n";  // no [static]: MODEL's
  REQUIRE(run(exe + " predict " + coef + " --experiment " + held.string() + " --run 1 --out " + three.string()) == 0);
  const auto c3 = columns(three);
  REQUIRE(c3.size() == 128);
  for (std::size_t i = 0; i < c3.size(); ++i) {
    CHECK(c3[i][2] == doctest::Approx(b[i][2]).epsilon(1e-12));
    CHECK(c3[i][4] == doctest::Approx(b[i][4]).epsilon(1e-12));
  }
  // --run names a run that is there, of the model's axis, and takes its frequency and airspeed
  // from the entry; each refusal says why and writes nothing.
  const fs::path no = tmp.path / "no.csv", err = tmp.path / "err.txt";
  auto refusal = [&](const std::string& args) {
    CHECK(std::system((exe + " predict " + coef + args + " --out " + no.string() + " > /dev/null 2> " + err.string())
                          .c_str()) != 0);
    CHECK_FALSE(fs::exists(no));
    return slurp_file(err.string());
  };
  const std::string with_held = " --experiment " + held.string();
  CHECK(refusal(with_held + " --run 2").find("held.toml has 1 run(s): give 1..1") != std::string::npos);
  CHECK(refusal(with_held + " --run 0").find("--run: must be >= 1") != std::string::npos);
  CHECK(refusal(with_held + " --run 1 --airspeed-mps 30").find("do not apply") != std::string::npos);
  CHECK(refusal(" --run 1").find("needs --experiment") != std::string::npos);
  CHECK(refusal("").find("give the run file(s) to predict, or --experiment E.toml --run N") != std::string::npos);
  const fs::path yaw = tmp.path / "yaw.toml";
  std::ofstream(yaw) << "axis = \"yaw\"\ncoefficient = \"Cn\"\nalpha0_deg = 10\nreference_length_m = 0.15\n"
                        "airspeed_mps = 30\nruns = [{files = [{file = \"angle_xy.csv\", columns = {phase_rad = \"x\", "
                        "psi_deg = \"y\"}}, {file = \"lift_xy.csv\", columns = {phase_rad = \"x\", Cn = \"y\"}}], "
                        "reduced_frequency = 0.08}]\n";
  CHECK(refusal(" --experiment " + yaw.string() + " --run 1").find("is a yaw experiment; the model is pitch") !=
        std::string::npos);
  // Without a frequency, or --samples with one file: refused, nothing written.
  CHECK(run(exe + " predict " + coef + " " + (tmp.path / "angle.csv").string() + " " + (tmp.path / "lift.csv").string() +
            " --out " + no.string()) != 0);
  CHECK(run(exe + " predict " + coef + " " + cycle.string() + k + " --samples 64 --out " + no.string()) != 0);
  CHECK_FALSE(fs::exists(no));
}
