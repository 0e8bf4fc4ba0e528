// A phase-averaged file's spread column as the noise from replication (issue 21 item 1, its
// third source; docs/formats.md "Phase-averaged cycles with a spread column"): the reader takes
// `<coefficient>_std` and the runs entry's `cycles_averaged`, refuses bad values at their file
// and line, and fit / diagnose report `spread_column` and decide with it.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "diagnose_test_matrix.hpp"
#include "fit_test_data.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/replication.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt): diagnoses below

using namespace indicial;
using namespace indicial::testing;

namespace {

// One averaged cycle of n samples: alpha = 10 + 5 sin(phase) deg, CL a smooth response, and the
// spread CL_std = s0 (1 + 0.5 cos(phase)) (or `bad` at row `bad_row`).
std::string cycle_csv(int n, double s0, const std::string& bad = "", int bad_row = -1) {
  std::string s = "phase_rad,alpha_deg,CL,CL_std\n";
  for (int k = 0; k < n; ++k) {
    const double ph = 2.0 * kPi * k / n;
    char row[160];
    std::snprintf(row, sizeof row, "%.17g,%.17g,%.17g,%.17g\n", ph, 10.0 + 5.0 * std::sin(ph),
                  0.1 * (10.0 + 5.0 * std::sin(ph)) + 0.05 * std::cos(ph), s0 * (1.0 + 0.5 * std::cos(ph)));
    std::string line = row;
    if (k == bad_row) line = line.substr(0, line.rfind(',') + 1) + bad + "\n";
    s += line;
  }
  return s;
}

std::string experiment(const std::string& runs) {
  return "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.55\nairspeed_mps = 40.0\n"
         "runs = [" + runs + "]\n[static]\npolynomial = [0.0, 5.7]\n";
}

std::string load_error(const TempDir& dir, const std::string& name, const std::string& text) {
  return load_experiment_error(testing::write_text(dir.path / name, text));
}

}  // namespace

TEST_CASE("spread column: a file with a known spread gives sigma = sqrt(mean(spread^2) / cycles)") {
  TempDir dir("spread");
  const int n = 64;
  testing::write_text(dir.path / "k1.csv", cycle_csv(n, 0.04));
  testing::write_text(dir.path / "k2.csv", cycle_csv(n, 0.02));
  const Experiment e = load_experiment(testing::write_text(
      dir.path / "e.toml", experiment("{file = \"k1.csv\", frequency_hz = 1.0, cycles_averaged = 16}, "
                                      "{file = \"k2.csv\", frequency_hz = 2.0, cycles_averaged = 16}")));
  REQUIRE(e.runs.size() == 2);
  CHECK(e.runs[0].coefficient_spread.size() == static_cast<std::size_t>(n));
  CHECK(e.runs[0].ensemble_count == 16.0);
  // mean of (s0 (1 + 0.5 cos))^2 over a whole cycle = s0^2 (1 + 0.125); pooled over both runs.
  const double expected = std::sqrt((0.04 * 0.04 + 0.02 * 0.02) * 1.125 / 2.0 / 16.0);
  const ReplicationNoise rn = replication_noise(e);
  MESSAGE("spread column: sigma ", rn.sigma, " expected ", expected, " (", rn.detail, ")");
  CHECK(rn.source == NoiseSource::spread_column);
  CHECK(rn.sigma == doctest::Approx(expected).epsilon(1e-12));
  CHECK(rn.lag1_correlation == 0.0);
  // The writer writes the count back, and the file reads back the same.
  const std::string toml = write_experiment_toml(e, {});
  CHECK_HAS(toml, "cycles_averaged = 16");
  // A file without the spread column: a warning, and no replication from it.
  testing::write_text(dir.path / "plain.csv", "phase_rad,alpha_deg,CL\n" + [&] {
    std::string s;
    for (int k = 0; k < n; ++k) s += std::to_string(2.0 * kPi * k / n) + "," + std::to_string(10 + k % 7) + ",1\n";
    return s;
  }());
  const Experiment p = load_experiment(testing::write_text(
      dir.path / "p.toml", experiment("{file = \"plain.csv\", frequency_hz = 1.0, cycles_averaged = 8}")));
  std::string warnings;
  for (const std::string& w : p.warnings) warnings += w + "\n";
  CHECK_HAS(warnings, "p.toml:5: run 'plain.csv' gives 'cycles_averaged' but has no 'CL_std' column");
  CHECK(replication_noise(p).source == NoiseSource::none);
}

TEST_CASE("spread column: negative, NaN, a missing count and a count below 2 name the file and line") {
  TempDir dir("spread-bad");
  testing::write_text(dir.path / "neg.csv", cycle_csv(32, 0.04, "-0.01", 6));
  testing::write_text(dir.path / "nan.csv", cycle_csv(32, 0.04, "nan", 3));
  testing::write_text(dir.path / "ok.csv", cycle_csv(32, 0.04));
  // Line numbers: the header is line 1, row k is line k + 2.
  CHECK_HAS(load_error(dir, "a.toml", experiment("{file = \"neg.csv\", frequency_hz = 1.0, cycles_averaged = 4}")),
            "neg.csv:8: column 'CL_std': spread -0.01 is negative");
  CHECK_HAS(load_error(dir, "b.toml", experiment("{file = \"nan.csv\", frequency_hz = 1.0, cycles_averaged = 4}")),
            "nan.csv:5: column 'CL_std': NaN or Inf value 'nan'");
  CHECK_HAS(load_error(dir, "c.toml", experiment("{file = \"ok.csv\", frequency_hz = 1.0}")),
            "c.toml:5: run 'ok.csv' has a spread column 'CL_std' but its entry gives no 'cycles_averaged'");
  CHECK_HAS(load_error(dir, "d.toml", experiment("{file = \"ok.csv\", frequency_hz = 1.0, cycles_averaged = 1}")),
            "d.toml:5: 'runs.cycles_averaged' must be an integer 2..1000000");
  CHECK_HAS(load_error(dir, "e.toml", experiment("{file = \"ok.csv\", frequency_hz = 1.0, cycles_averaged = 2.5}")),
            "e.toml:5:");
  CHECK_HAS(load_error(dir, "f.toml", experiment("{files = [\"ok.csv\"], frequency_hz = 1.0, cycles_averaged = 4}")),
            "f.toml:5: 'runs.cycles_averaged' is not used with 'runs.files'");
  // [columns] maps another name to the spread column.
  std::string renamed = cycle_csv(32, 0.04);
  renamed.replace(renamed.find("CL_std"), 6, "sigma_CL");
  testing::write_text(dir.path / "renamed.csv", renamed);
  const Experiment m = load_experiment(testing::write_text(
      dir.path / "m.toml", experiment("{file = \"renamed.csv\", frequency_hz = 1.0, cycles_averaged = 4}") +
                               "[columns]\nCL_std = \"sigma_CL\"\n"));
  CHECK(replication_noise(m).source == NoiseSource::spread_column);
}

// Two runs (too few to leave one out): without replication diagnose takes kappa from each
// candidate's residual (lr_residual); with a spread column it decides by the likelihood ratio
// with the replicates' kappa (1: a spread gives no correlation), and reports the spread's sigma.
// The truth's noise is white, the spread the noise's true sigma times sqrt(cycles).
TEST_CASE("spread column: diagnose decides with it (lr_replication_noise), names the hidden effect, and nothing on a complete model") {
  auto with_spread = [](Experiment e, double sigma) {
    e.runs.resize(2);
    for (Run& r : e.runs) {
      r.coefficient_spread.assign(r.size(), sigma * std::sqrt(25.0));
      r.ensemble_count = 25.0;
    }
    return e;
  };
  double sigma = 0.0;
  const MatrixCase hidden{"Cm", "b1_alpha", "b1_alpha", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 31};
  Experiment plain = matrix_experiment(hidden, &sigma);
  plain.runs.resize(2);
  DiagnoseOptions rule_only;  // the rule is decided before any step: no step needed to read it
  rule_only.max_steps = 0;
  CHECK(diagnose_experiment(plain, rule_only).rule == DecisionRule::lr_residual);
  const Experiment hidden_e = matrix_experiment(hidden, &sigma);
  const DiagnoseResult d = diagnose_experiment(with_spread(hidden_e, sigma), DiagnoseOptions{});
  MESSAGE("hidden b1_alpha, spread column: verdict ", d.verdict, ", rule ", std::string(decision_rule_name(d.rule)),
          ", replication sigma ", d.replication.sigma, " (true ", sigma, ")");
  CHECK(d.rule == DecisionRule::lr_replication_noise);
  CHECK(d.replication.source == NoiseSource::spread_column);
  CHECK(d.replication.sigma == doctest::Approx(sigma).epsilon(1e-12));
  CHECK(d.verdict == "b1_alpha");
  for (const DiagnoseStep& s : d.steps) CHECK(s.rule == DecisionRule::lr_replication_noise);
  const nlohmann::json j = diagnosis_json(d, d.experiment, DiagnoseOptions{}, nullptr);
  CHECK(j["noise_source"] == "spread_column");
  CHECK(j["noise_estimate"].get<double>() == doctest::Approx(sigma).epsilon(1e-12));
  CHECK(j["rule"] == "lr_replication_noise");
  double s0 = 0.0;
  const MatrixCase complete{"Cm", "none", "none", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 32};
  const Experiment complete_e = matrix_experiment(complete, &s0);
  const DiagnoseResult n = diagnose_experiment(with_spread(complete_e, s0), DiagnoseOptions{});
  CHECK(n.rule == DecisionRule::lr_replication_noise);
  CHECK(n.verdict == "none");
}
