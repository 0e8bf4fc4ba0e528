// The dynamic-stall campaign generator (dynamic_stall.hpp): a truth outside the model class,
// checked against properties it must have whatever the model: the static limit, the
// airspeed invariance of a reduced-frequency cycle, periodicity, the SNR convention, and the
// written phase-averaged files.
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "cli_test_support.hpp"
#include "indicial/fitter/dynamic_stall.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/validation_realistic.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace ds = indicial::dynamic_stall;

namespace {

using indicial::testing::kPi;

ds::Campaign one_cycle_campaign(double k, double airspeed_mps, double amplitude_deg = 8.0) {
  ds::Campaign c = ds::default_campaign();
  c.cycles.clear();
  ds::PitchCycle p;
  p.amplitude_deg = amplitude_deg;
  p.reduced_frequency = k;
  p.airspeed_mps = airspeed_mps;
  p.file = "cycle.csv";
  c.cycles.push_back(p);
  return c;
}

double max_abs_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
  return m;
}

}  // namespace

TEST_CASE("dynamic stall: the static separation curve is Leishman-Beddoes' (continuous at alpha1)") {
  const ds::AirfoilConstants a;
  const double a1 = a.alpha1_deg * kPi / 180.0;
  CHECK(ds::static_separation(a, a1) == doctest::Approx(0.7));
  CHECK(ds::static_separation(a, std::nextafter(a1, 1.0)) == doctest::Approx(0.7));
  CHECK(ds::static_separation(a, 0.0) > 0.98);
  CHECK(ds::static_separation(a, 30.0 * kPi / 180.0) < 0.05);
  // Fully attached flow at small angles: C_L = C_Nalpha sin(a) cos(a) + eta C_Nalpha sin^3(a).
  const ds::Coefficients c = ds::airfoil_coefficients(a, 0.05, 1.0);
  CHECK(c.lift == doctest::Approx(a.normal_force_slope_per_rad * (std::sin(0.05) * std::cos(0.05) +
                                                                  a.suction_recovery * std::pow(std::sin(0.05), 3))));
}

TEST_CASE("dynamic stall: a very slow cycle follows the static polar, a fast one shows hysteresis") {
  const auto slow = ds::simulate_campaign(one_cycle_campaign(0.0005, 30.0), INFINITY, 1, indicial::NoiseModel{});
  const auto fast = ds::simulate_campaign(one_cycle_campaign(0.1, 30.0), INFINITY, 1, indicial::NoiseModel{});
  // Quasi-static: the lag is tau1 + tau2 = 4.7 semichords against a period of 2 pi / k.
  CHECK(max_abs_difference(slow[0].lift_true, slow[0].lift_static) < 0.02);
  CHECK(max_abs_difference(fast[0].lift_true, fast[0].lift_static) > 0.2);
}

TEST_CASE("dynamic stall: a cycle at one reduced frequency is the same curve at every airspeed") {
  // The time constants are in semichord times, so the averaged cycle against phase must not
  // depend on V (the property the indicial model's b(x) V / V_ref scaling relies on).
  const auto a = ds::simulate_campaign(one_cycle_campaign(0.08, 25.0), INFINITY, 1, indicial::NoiseModel{});
  const auto b = ds::simulate_campaign(one_cycle_campaign(0.08, 40.0), INFINITY, 1, indicial::NoiseModel{});
  CHECK(a[0].frequency_hz != doctest::Approx(b[0].frequency_hz));
  CHECK(max_abs_difference(a[0].lift_true, b[0].lift_true) < 1e-8);
  CHECK(max_abs_difference(a[0].moment_true, b[0].moment_true) < 1e-8);
}

TEST_CASE("dynamic stall: the averaged truth is the periodic steady state") {
  ds::Campaign c = one_cycle_campaign(0.02, 30.0);
  const auto three = ds::simulate_campaign(c, INFINITY, 1, indicial::NoiseModel{});
  c.transient_cycles = 8;
  c.cycles_averaged = 2;
  const auto eight = ds::simulate_campaign(c, INFINITY, 1, indicial::NoiseModel{});
  CHECK(max_abs_difference(three[0].lift_true, eight[0].lift_true) < 1e-9);
}

TEST_CASE("dynamic stall: noise is sigma = RMS(C - C_static) / SNR on the raw samples, averaged down") {
  ds::Campaign c = one_cycle_campaign(0.06, 30.0);
  std::vector<double> sigma;
  const auto noisy = ds::simulate_campaign(c, 10.0, 3, c.default_noise, &sigma);
  REQUIRE(sigma.size() == 2);
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < noisy[0].lift.size(); ++i) {
    const double y = noisy[0].lift_true[i] - noisy[0].lift_static[i];
    sum_sq += y * y;
  }
  // RMS over one averaged cycle equals RMS over the raw samples (the truth is periodic): to
  // rounding, relative 1e-12 (scale 0; epsilon(1e-6) at the default scale was absolute).
  CHECK(sigma[0] == doctest::Approx(std::sqrt(sum_sq / static_cast<double>(noisy[0].lift.size())) / 10.0).epsilon(1e-12).scale(0));
  double e_sq = 0.0;
  for (std::size_t i = 0; i < noisy[0].lift.size(); ++i) e_sq += std::pow(noisy[0].lift[i] - noisy[0].lift_true[i], 2);
  const double e_rms = std::sqrt(e_sq / static_cast<double>(noisy[0].lift.size()));
  // The average of 20 independent cycles: sigma / sqrt(20), within a generous band for 128 samples
  // of AR(1) noise (phi 0.8: about 128 (1 - phi) / (1 + phi) = 14 effective samples).
  CHECK(e_rms > 0.4 * sigma[0] / std::sqrt(20.0));
  CHECK(e_rms < 1.8 * sigma[0] / std::sqrt(20.0));
}

TEST_CASE("dynamic stall: simulate --case dynamic-stall writes the agreed phase-averaged format") {
  namespace fs = std::filesystem;
  const indicial::testing::TempDir scratch("dynamic-stall");
  const fs::path& dir = scratch.path;
  const indicial::testing::CliRun r =
      indicial::testing::run_indicial("simulate --case dynamic-stall --snr 20 --out '" + (dir / "out").string() + "'", dir);
  REQUIRE(r.exit_code == 0);
  const std::string csv = indicial::testing::slurp(dir / "out" / "a8_k0.040_v25.csv");
  CHECK(csv.find("\nphase_rad,alpha_deg,q_degps,CL,Cm,") != std::string::npos);
  CHECK(csv.find("time_s") == std::string::npos);
  // Phases rounded to 0.01 rad: every phase value has at most 2 decimals.
  std::istringstream in(csv);
  std::string line;
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line[0] == 'p') continue;
    const std::string phase = line.substr(0, line.find(','));
    const std::size_t dot = phase.find('.');
    CHECK((dot == std::string::npos || phase.size() - dot - 1 <= 2));
    ++rows;
  }
  CHECK(rows == 128);
  const std::string toml = indicial::testing::slurp(dir / "out" / "experiment-CL.toml");
  CHECK(toml.find("{file = \"a8_k0.040_v25.csv\", reduced_frequency = 0.04, airspeed_mps = 25}") != std::string::npos);
  CHECK(toml.find("table = \"static.csv\"") != std::string::npos);
  CHECK(fs::exists(dir / "out" / "experiment-Cm.toml"));
  CHECK(fs::exists(dir / "out" / "cycles.csv"));
  // The static polar reads back as the fitter reads a static table (within the default runtime's 64 rows).
  indicial::StaticConfig s;
  indicial::read_static_table((dir / "out" / "static.csv").string(), indicial::Axis::pitch, "Cm", s);
  CHECK(s.table_x_rad.size() == 49);
  // End to end through the files: fit the CL experiment (the phase-averaged reader), predict a
  // hold-out cycle at another airspeed from its reduced frequency (periodic implied by the
  // phase column), and beat half the quasi-steady RMS error there.
  const fs::path out = dir / "out";
  const auto fit = indicial::testing::run_indicial(
      "fit '" + (out / "experiment-CL.toml").string() + "' --no-plots --out '" + (dir / "fit").string() + "'", dir);
  REQUIRE(fit.exit_code == 0);
  const auto pred = indicial::testing::run_indicial(
      "predict '" + (dir / "fit" / "model.coef").string() + "' '" + (out / "a6_k0.080_v35.csv").string() +
          "' --reduced-frequency 0.08 --airspeed-mps 35 --out '" + (dir / "p.csv").string() + "'", dir);
  REQUIRE(pred.exit_code == 0);
  CHECK(indicial::testing::slurp(dir / "p.csv").find("periodic steady state") != std::string::npos);
  const std::string metrics = indicial::testing::slurp(dir / "p.metrics.json");
  auto rms_after = [&](const std::string& key) {
    const std::size_t at = metrics.find("\"rms_error\"", metrics.find(key));
    return std::stod(metrics.substr(metrics.find(':', at) + 1));
  };
  CHECK(rms_after("\"model\"") < 0.5 * rms_after("\"quasi_steady\""));
}

TEST_CASE("dynamic stall: fitted on 3 cycles, the model beats half the quasi-steady error on >= 9 of 11") {
  // The acceptance study of docs/validation-realistic.md (seed 1, SNR 20, AR(1) phi 0.8).
  const indicial::RealisticValidation v = indicial::run_realistic_validation({});
  REQUIRE(v.coefficients.size() == 2);
  for (const indicial::CoefficientValidation& cv : v.coefficients) {
    CAPTURE(cv.coefficient);
    REQUIRE(cv.status == indicial::RealisticFit::fitted);
    CHECK(cv.cycles.size() == 11);
    CHECK(cv.cycles_at_most_half() >= 9);
  }
}
