// A static table from quasi-static cycles (quasi_static_polar.hpp, `indicial polar`): the
// outward samples recover the static curve where the return stroke's hysteresis would bias it; the
// command's table is accepted as a [static] table by the experiment reader.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/quasi_static_polar.hpp"
#include "cli_test_support.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;

// The static curve (a lift-like cubic) and a quasi-static cycle's measurement: on the
// downstroke above 10 deg the flow is still separated, 0.3 below the curve (the hysteresis the
// rising recipe leaves out).
double static_curve(double x_rad) { return 5.5 * x_rad - 8.0 * x_rad * x_rad * x_rad; }

// One periodic cycle of n samples, alpha = mean + amp sin(phase + offset).
indicial::Run quasi_static_cycle(double mean_deg, double amp_deg, double offset, int n) {
  indicial::Run r;
  r.periodic = true;
  for (int k = 0; k < n; ++k) {
    const double ph = 2 * kPi * k / n + offset;
    const double x = (mean_deg + amp_deg * std::sin(ph)) * kDeg;
    const bool falling = std::cos(ph) < 0.0;
    r.time_s.push_back(k * 0.01);
    r.motion_angle_rad.push_back(x);
    r.coefficient.push_back(static_curve(x) - (falling && x > 10 * kDeg ? 0.3 : 0.0));
  }
  return r;
}

indicial::Experiment experiment_of(const std::string& coefficient) {
  indicial::Experiment e;
  e.path = "cycles.toml";
  e.coefficient = coefficient;
  for (int c = 0; c < 3; ++c) e.runs.push_back(quasi_static_cycle(8.0, 10.0, 0.37 * c, 200));
  return e;
}

}  // namespace

TEST_CASE("quasi-static polar: the outward samples recover the static curve, both strokes carry the hysteresis") {
  const std::vector<indicial::Experiment> es = {experiment_of("CL")};
  const indicial::QuasiStaticPolar rising = indicial::quasi_static_polar(es, {});
  REQUIRE(rising.x_rad.size() >= 19);
  CHECK(rising.runs == 3);
  double worst = 0.0;
  for (std::size_t i = 0; i < rising.x_rad.size(); ++i) {
    if (i > 0) CHECK(rising.x_rad[i] > rising.x_rad[i - 1]);
    CHECK(rising.samples[i] >= 4);
    // At its samples' mean angle the bin mean is the curve up to its curvature over the bin:
    // |s''| w^2 / 24 = 48 x 0.3 x (1 deg)^2 / 24, about 2e-4.
    worst = std::max(worst, std::abs(rising.values[0][i] - static_curve(rising.x_rad[i])));
  }
  MESSAGE("largest error of the outward polar: " << worst);
  CHECK(worst < 1e-3);
  indicial::QuasiStaticPolarOptions both;
  both.stroke = indicial::PolarStroke::both;
  const indicial::QuasiStaticPolar pooled = indicial::quasi_static_polar(es, both);
  double bias_above_10 = 0.0;
  for (std::size_t i = 0; i < pooled.x_rad.size(); ++i)
    if (pooled.x_rad[i] > 11 * kDeg && pooled.x_rad[i] < 17 * kDeg)
      bias_above_10 = std::max(bias_above_10, static_curve(pooled.x_rad[i]) - pooled.values[0][i]);
  CHECK(bias_above_10 > 0.1);  // half the samples 0.3 low
}

// A cycle through zero (-20 ... 20 deg) that stalls on both sides: the return stroke is 0.3
// inside the static curve beyond 10 deg either way. The outward samples (the angle moving away
// from zero) recover the curve on both sides; the rising ones take the negative side's return.
TEST_CASE("quasi-static polar: the outward stroke recovers both sides of a cycle through zero, rising does not") {
  indicial::Experiment e;
  e.path = "symmetric.toml";
  e.coefficient = "CL";
  for (int c = 0; c < 3; ++c) {
    indicial::Run r;
    r.periodic = true;
    for (int k = 0; k < 300; ++k) {
      const double ph = 2 * kPi * k / 300 + 0.29 * c;
      const double x = 20.0 * kDeg * std::sin(ph);
      const bool outward = (x >= 0.0) == (std::cos(ph) > 0.0);
      r.time_s.push_back(k * 0.01);
      r.motion_angle_rad.push_back(x);
      r.coefficient.push_back(static_curve(x) - (!outward && std::abs(x) > 10 * kDeg ? (x > 0 ? 0.3 : -0.3) : 0.0));
    }
    e.runs.push_back(r);
  }
  auto worst_below = [&](indicial::PolarStroke stroke) {
    indicial::QuasiStaticPolarOptions o;
    o.stroke = stroke;
    const indicial::QuasiStaticPolar p = indicial::quasi_static_polar({e}, o);
    double worst = 0.0;
    for (std::size_t i = 0; i < p.x_rad.size(); ++i)
      if (p.x_rad[i] < -11 * kDeg) worst = std::max(worst, std::abs(p.values[0][i] - static_curve(p.x_rad[i])));
    return worst;
  };
  CHECK(worst_below(indicial::PolarStroke::outward) < 1e-3);
  CHECK(worst_below(indicial::PolarStroke::rising) > 0.2);
}

TEST_CASE("quasi-static polar: sparse bins dropped, held end rows, invalid options and unequal runs refused") {
  const std::vector<indicial::Experiment> es = {experiment_of("CL"), experiment_of("Cm")};
  indicial::QuasiStaticPolarOptions o;
  const indicial::QuasiStaticPolar plain = indicial::quasi_static_polar(es, o);
  REQUIRE(plain.coefficients == std::vector<std::string>{"CL", "Cm"});
  o.min_samples = 20;  // about 15 rising samples per 1 deg bin mid-stroke, more at the turning points
  const indicial::QuasiStaticPolar sparse = indicial::quasi_static_polar(es, o);
  CHECK(sparse.bins_dropped > 0);
  CHECK(sparse.x_rad.size() + static_cast<std::size_t>(sparse.bins_dropped) ==
        plain.x_rad.size() + static_cast<std::size_t>(plain.bins_dropped));
  o = {};
  o.hold_deg = 4.0;
  const indicial::QuasiStaticPolar held = indicial::quasi_static_polar(es, o);
  REQUIRE(held.x_rad.size() == plain.x_rad.size() + 2);
  CHECK(held.held_rows == 2);
  CHECK(held.x_rad.front() == doctest::Approx(plain.x_rad.front() - 4 * kDeg));
  CHECK(held.values[1].back() == plain.values[1].back());
  o = {};
  o.bin_deg = 0.0;
  CHECK_THROWS_WITH_AS(indicial::quasi_static_polar(es, o), doctest::Contains("bin width must be > 0"),
                       indicial::InputError);
  o = {};
  o.min_samples = 100000;
  CHECK_THROWS_WITH_AS(indicial::quasi_static_polar(es, o), doctest::Contains("held fewer than 100000 samples"),
                       indicial::InputError);
  o = {};
  o.bin_deg = 0.2;
  o.min_samples = 1;  // about 100 rows: more than a static table holds
  CHECK_THROWS_WITH_AS(indicial::quasi_static_polar(es, o), doctest::Contains("a static table holds at most 64"),
                       indicial::InputError);
  // Runs at a constant angle (a static test): nothing rises, and the message says --stroke both.
  std::vector<indicial::Experiment> still = {experiment_of("CL")};
  for (indicial::Run& r : still[0].runs) std::fill(r.motion_angle_rad.begin(), r.motion_angle_rad.end(), 0.1);
  CHECK_THROWS_WITH_AS(indicial::quasi_static_polar(still, {}), doctest::Contains("0 of 600 samples are on the "
                                                                                   "outward stroke: with runs that "
                                                                                   "do not move, --stroke both"),
                       indicial::InputError);
  std::vector<indicial::Experiment> unequal = es;
  unequal[1].runs.pop_back();
  CHECK_THROWS_WITH_AS(indicial::quasi_static_polar(unequal, {}), doctest::Contains("the runs of Cm differ"),
                       indicial::InputError);
}

TEST_SUITE_BEGIN("cli");

// The command on run files: an experiment with no [static] yet; its table read back as the
// [static] table of an experiment (what polar writes, fit accepts); nothing overwritten, and a
// table beyond the runtime's rows refused with nothing written.
TEST_CASE("indicial polar: writes a static table the experiment reader accepts, refuses overwrite and too many rows") {
  const indicial::testing::TempDir tmp("test-polar");
  const std::string exe = INDICIAL_EXE;
  std::string runs;
  for (int c = 0; c < 3; ++c) {
    const indicial::Run r = quasi_static_cycle(8.0, 10.0, 0.37 * c, 200);
    const std::string name = "qs" + std::to_string(c) + ".csv";
    std::ofstream f(tmp.path / name);
    f << "phase_rad,alpha_deg,CL\n";
    for (std::size_t k = 0; k < r.size(); ++k)
      f << indicial::format_double(2 * kPi * static_cast<double>(k) / 200.0) << "," << indicial::format_double(r.motion_angle_rad[k] / kDeg)
        << "," << indicial::format_double(r.coefficient[k]) << "\n";
    runs += std::string(c ? ", " : "") + "{file = \"" + name + "\", frequency_hz = 0.1}";
  }
  const std::string head = "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.275\nairspeed_mps = 40\n";
  std::ofstream(tmp.path / "qs.toml") << head << "runs = [" << runs << "]\n";
  const std::string table = (tmp.path / "static.csv").string();
  auto run = [](const std::string& cmd) { return std::system((cmd + " > /dev/null 2>&1").c_str()); };
  // The rows are at their bins' mean angles, inside the cycles' range, which a static table
  // must cover: the end values held 1 deg further.
  REQUIRE(run(exe + " polar " + (tmp.path / "qs.toml").string() + " --out " + table + " --hold-deg 1") == 0);
  std::ofstream(tmp.path / "fit.toml") << head << "runs = [" << runs << "]\n[static]\ntable = \"static.csv\"\n";
  const indicial::Experiment e = indicial::load_experiment((tmp.path / "fit.toml").string());
  REQUIRE(e.static_curve.table_x_rad.size() >= 19);
  for (std::size_t i = 1; i + 1 < e.static_curve.table_x_rad.size(); ++i)  // the binned rows
    CHECK(std::abs(e.static_curve.table_value[i] - static_curve(e.static_curve.table_x_rad[i])) < 1e-3);
  // An existing output is kept, and an input is never replaced, --force or not; 0.2 deg bins of
  // any count make more rows than the runtime holds.
  const std::string before = indicial::testing::slurp(table);
  CHECK(run(exe + " polar " + (tmp.path / "qs.toml").string() + " --out " + table) != 0);
  CHECK(indicial::testing::slurp(table) == before);
  const std::string run_file = (tmp.path / "qs1.csv").string(), run_text = indicial::testing::slurp(run_file);
  CHECK(run(exe + " polar " + (tmp.path / "qs.toml").string() + " --out " + run_file + " --force") != 0);
  CHECK(indicial::testing::slurp(run_file) == run_text);
  const std::string fine = (tmp.path / "fine.csv").string();
  CHECK(run(exe + " polar " + (tmp.path / "qs.toml").string() + " --out " + fine + " --bin-deg 0.2 --min-samples 1") != 0);
  CHECK_FALSE(fs::exists(fine));
}

TEST_SUITE_END();
