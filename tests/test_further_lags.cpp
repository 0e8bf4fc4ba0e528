// A second lag with its own angle-dependent b2(x), configured by the [model] keys b2_degree /
// b2_powers / b2_knots_deg (docs/formats.md), identified from simulated data.
//
// Truth (pitch, x = alpha in rad, 0..~0.6 rad):
//   y1' = -b1 y1 - a(x) x',           b1 = 1.5 1/s            (slow)
//   y2' = -b2(x) y2 - c2 a(x) x',     b2(x) = 12 + 30 x 1/s   (fast, 12..30 1/s), c2 = 0.8
//   a(x) = 0.5 + 1.0 x
// integrated by the simulator's Dormand-Prince reference (simulate_reference), never by the
// fitter's discretization; white noise at SNR 50. The data reach the fitter as run CSV files
// and an experiment.toml, so the keys are read as a user's file would be.
#include <doctest/doctest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/report.hpp"
#include "indicial/fitter/simulate.hpp"
#include "fit_test_data.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;
constexpr double kAirspeed = 20.0;  // m/s
constexpr double kB1 = 1.5, kB2_0 = 12.0, kB2_1 = 30.0, kC2 = 0.8;

indicial::TruthModel two_lag_truth() {
  return indicial::testing::polynomial_pitch_truth({"Cm", 0.3, kAirspeed, 0.0, 40.0 * kDeg,
                                                    {0.0, 0.4, -0.3}, {0.5, 1.0},
                                                    {{{kB1}}, {{kB2_0, kB2_1}, kC2}}});
}

// Sines at several means, amplitudes and frequencies, so b2(x) is seen at small and large x
// and over time scales around both lags'.
std::vector<indicial::MotionSpec> motions() {
  std::vector<indicial::MotionSpec> out;
  const double means_deg[] = {8.0, 20.0, 28.0};
  const double amps_deg[] = {6.0, 10.0, 6.0};
  const double freqs_hz[] = {0.3, 1.0, 3.0};
  for (int i = 0; i < 3; ++i) {
    for (double f : freqs_hz) {
      indicial::MotionSpec s;
      s.kind = indicial::MotionKind::sine;
      s.mean_rad = means_deg[i] * kDeg;
      s.amplitude_rad = amps_deg[i] * kDeg;
      s.freq_hz = f;
      s.cycles = f < 0.5 ? 2.0 : 4.0;
      s.dt_s = 0.005;
      out.push_back(s);
    }
  }
  return out;
}

const char* kExperiment = R"(axis = "pitch"
coefficient = "Cm"
reference_length_m = 0.3
airspeed_mps = 20.0
runs = [RUNS]

[static]
polynomial = [0.0, 0.4, -0.3]

[model]
a_degree = 1
b1_degree = 0
lags = 2
b2_degree = 1
further_lag_start = "at_rest"
)";

// Writes the runs and the experiment into dir; returns the experiment's path.
std::string write_case(const std::filesystem::path& dir) {
  const indicial::TruthModel truth = two_lag_truth();
  std::vector<indicial::SimulatedRun> sims;
  for (const auto& m : motions()) sims.push_back(indicial::simulate_reference(truth, m));
  indicial::add_measurement_noise(sims, 50.0, 20240917);
  std::string runs;
  for (std::size_t i = 0; i < sims.size(); ++i) {
    const std::string name = "run" + std::to_string(i) + ".csv";
    std::ofstream(dir / name) << indicial::simulated_run_csv(truth, sims[i], {});
    runs += (i ? ", \"" : "\"") + name + "\"";
  }
  std::string toml = kExperiment;
  toml.replace(toml.find("RUNS"), 4, runs);
  std::ofstream(dir / "experiment.toml") << toml;
  return (dir / "experiment.toml").string();
}

const indicial::ParameterEstimate& estimate(const indicial::FitResult& r, const std::string& name) {
  for (const auto& p : r.parameters)
    if (p.name == name) return p;
  FAIL("no parameter " << name);
  return r.parameters.front();
}

}  // namespace

TEST_CASE("two lags: an angle-dependent b2(x) from [model] b2_degree is recovered within 3 Cramer-Rao bounds") {
  indicial::testing::TempDir dir("further-lags");
  const std::string path = write_case(dir.path);
  const indicial::Experiment e = indicial::load_experiment(path);
  REQUIRE(e.model.lags == 2);
  REQUIRE(e.model.further_lag_b.size() == 1);
  CHECK(e.model.further_lag_b[0].powers == std::vector<int>{0, 1});

  const indicial::FitResult r = indicial::fit_experiment(e, indicial::FitOptions{});
  REQUIRE(r.output_error.termination == indicial::Termination::converged);
  const struct {
    const char* name;
    double truth;
  } expected[] = {{"b2_0", kB2_0}, {"b2_1", kB2_1}, {"c2", kC2}, {"b1_0", kB1}, {"a0", 0.5}, {"a1", 1.0}};
  for (const auto& x : expected) {
    const indicial::ParameterEstimate& p = estimate(r, x.name);
    INFO(std::string(x.name) << " = " << p.value << " +- " << p.cr_bound << " (truth " << x.truth << ")");
    REQUIRE(p.cr_bound > 0.0);
    CHECK(std::abs(p.value - x.truth) < 3.0 * p.cr_bound);
  }

  // The written model loads in the runtime (DefaultCapacity: 2 lags) and predicts the noise-free
  // truth of a run far more closely than the noise.
  const std::string text = indicial::model_coef_text(r, path);
  indicial::Predictor<double> predictor;
  REQUIRE(predictor.load(text.data(), text.size()) == indicial::LoadStatus::ok);
  const indicial::TruthModel truth = two_lag_truth();
  const indicial::SimulatedRun sim = indicial::simulate_reference(truth, motions()[4]);
  REQUIRE(predictor.reset(sim.motion_angle_rad[0], kAirspeed) == indicial::StepStatus::ok);
  double sum_sq = 0.0, sum_sq_y = 0.0;
  for (std::size_t k = 1; k < sim.time_s.size(); ++k) {
    indicial::Predictor<double>::Outputs out;
    const indicial::StepStatus s =
        predictor.step({sim.motion_angle_rad[k], sim.rate_radps[k], kAirspeed}, sim.time_s[k] - sim.time_s[k - 1], &out);
    REQUIRE((s == indicial::StepStatus::ok || s == indicial::StepStatus::angle_clamped));
    sum_sq += std::pow(out.value[0] - sim.coefficient_true[0][k], 2);
    sum_sq_y += std::pow(sim.y_true[0][k], 2);
  }
  // Noise sigma is RMS(y) / 50; the model's error must be well under it: at the scale the
  // estimates' scatter sets, sigma sqrt(p / N) (p = 15 parameters, N = 7206 samples: 0.046
  // sigma), twice that (measured 0.017 sigma; the former bound, sigma itself, was 58x looser).
  std::size_t n_samples = 0;
  for (const auto& run : r.runs) n_samples += run.time_s.size();
  REQUIRE(n_samples > 0);
  const double scatter = std::sqrt(static_cast<double>(r.parameters.size()) / static_cast<double>(n_samples));
  CHECK(std::sqrt(sum_sq / sum_sq_y) < 2.0 * scatter / 50.0);
}

TEST_CASE("[model] b_k keys: refused beyond model.lags, more lags than the runtime holds refused at input") {
  indicial::testing::TempDir dir("further-lags-bad");
  const std::string path = write_case(dir.path);
  auto with_model = [&](const std::string& from, const std::string& to) {
    std::ifstream in(path);
    std::string toml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    toml.replace(toml.find(from), from.size(), to);
    std::ofstream(path) << toml;
  };
  with_model("lags = 2\n", "lags = 1\n");
  CHECK_THROWS_WITH(indicial::load_experiment(path),
                    (path + ":14: 'model.b2_degree' is for lag 2 but model.lags = 1: set 'lags = 2' or remove it").c_str());
  with_model("lags = 1\n", "lags = 3\n");
  CHECK_THROWS_WITH(indicial::load_experiment(path),
                    (path + ":13: 'model.lags' needs 3 lags; the runtime (indicial::DefaultCapacity) holds at most 2").c_str());
}

TEST_CASE("[model] b_k keys: written back by write_experiment_toml and read again") {
  indicial::testing::TempDir dir("further-lags-write");
  const std::string path = write_case(dir.path);
  indicial::Experiment e = indicial::load_experiment(path);
  e.model.further_lag_b[0] = indicial::SplineConfig{{0, 2}, {20.0 * kDeg}, 1};
  for (auto& run : e.runs) run.path = std::filesystem::path(run.path).filename().string();
  const std::string text = indicial::write_experiment_toml(e, {});
  CHECK(text.find("b2_powers = [0, 2]\nb2_knots_deg = [20]\n") != std::string::npos);
  std::ofstream(dir.path / "again.toml") << text;
  const indicial::Experiment back = indicial::load_experiment((dir.path / "again.toml").string());
  REQUIRE(back.model.further_lag_b.size() == 1);
  CHECK(back.model.further_lag_b[0].powers == std::vector<int>{0, 2});
  CHECK(back.model.further_lag_b[0].knots_rad.size() == 1);
  CHECK(back.model.lags == 2);
}
