// Columns sampled at their own phases (phase_resample.hpp): periodic interpolation, its
// measured error, and the experiment's `files = [...]` runs entry.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/phase_resample.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;

const fs::path& dir() {
  static const indicial::testing::TempDir d("test-phase-resample");
  return d.path;
}

std::string write(const std::string& name, const std::string& text) {
  const fs::path p = dir() / name;
  std::ofstream(p, std::ios::binary) << text;
  return p.string();
}

// A C_L-like periodic history: harmonics 1-3 (a hysteresis loop's shape), peak-to-peak ~2.
double history(double phase) {
  return 0.8 + 0.9 * std::sin(phase) + 0.25 * std::sin(2 * phase + 0.7) + 0.08 * std::cos(3 * phase - 0.3);
}

// n phases in [0, 2 pi): evenly spaced, each moved by up to 40 % of the spacing (a digitizer's
// clicks), seeded.
std::vector<double> digitized_phases(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  std::vector<double> p;
  for (int k = 0; k < n; ++k) p.push_back(2 * kPi * (k + 0.5 + u(rng)) / n);
  std::sort(p.begin(), p.end());
  return p;
}

// Periodic linear interpolation, the baseline the makima error is compared with.
double linear_at(const std::vector<double>& x, const std::vector<double>& y, double at) {
  const std::size_t n = x.size();
  for (std::size_t i = 0; i < n; ++i) {
    const double x0 = x[i], x1 = i + 1 < n ? x[i + 1] : x[0] + 2 * kPi;
    double a = at;
    if (a < x[0]) a += 2 * kPi;
    if (a >= x0 && a <= x1) return y[i] + (y[(i + 1) % n] - y[i]) * (a - x0) / (x1 - x0);
  }
  return y[0];
}

struct Errors {
  double makima = 0, linear = 0;
};
Errors interpolation_errors(int n) {
  Errors e;
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const std::vector<double> x = digitized_phases(n, seed);
    std::vector<double> y;
    for (double p : x) y.push_back(history(p));
    std::vector<double> at;
    for (int k = 0; k < 1000; ++k) at.push_back(2 * kPi * k / 1000);
    const std::vector<double> v = indicial::periodic_interpolate(x, y, at);
    for (std::size_t k = 0; k < at.size(); ++k) {
      e.makima = std::max(e.makima, std::abs(v[k] - history(at[k])));
      e.linear = std::max(e.linear, std::abs(linear_at(x, y, at[k]) - history(at[k])));
    }
  }
  return e;
}

}  // namespace

TEST_CASE("periodic_interpolate: exact at the points, periodic, and its measured error at 30 and 60 points") {
  const std::vector<double> x = digitized_phases(30, 7);
  std::vector<double> y;
  for (double p : x) y.push_back(history(p));
  const std::vector<double> at_points = indicial::periodic_interpolate(x, y, x);
  for (std::size_t i = 0; i < x.size(); ++i) CHECK(at_points[i] == doctest::Approx(y[i]).epsilon(1e-12));
  // Periodic: the value and slope match across 0 = 2 pi.
  const std::vector<double> ends = indicial::periodic_interpolate(x, y, {1e-9, 2 * kPi - 1e-9, 2 * kPi + 0.1, 0.1});
  CHECK(ends[0] == doctest::Approx(ends[1]).epsilon(1e-7));
  CHECK(ends[2] == doctest::Approx(ends[3]).epsilon(1e-12));
  // The error, relative to the peak-to-peak amplitude (about 2.2), over 20 digitizations.
  const Errors e30 = interpolation_errors(30), e60 = interpolation_errors(60);
  MESSAGE("max error / p-p: 30 points makima " << e30.makima / 2.2 << " linear " << e30.linear / 2.2
                                               << "; 60 points makima " << e60.makima / 2.2 << " linear "
                                               << e60.linear / 2.2);
  CHECK(e30.makima < 0.5 * e30.linear);
  CHECK(e60.makima < 0.5 * e60.linear);
  CHECK(e30.makima / 2.2 < 0.015);
  CHECK(e60.makima / 2.2 < 0.003);
}

TEST_CASE("runs entry files = [...]: alpha, CL and Cm at their own phases make one periodic run") {
  // alpha at 41 phases (deg), CL at 37 (rad), Cm at 52 (deg): every quantity a smooth function of
  // phase, so the resampled run is compared with the functions on its grid.
  auto alpha_deg = [](double ph) { return 10 + 8 * std::sin(ph); };
  auto cm = [](double ph) { return -0.02 + 0.01 * std::cos(ph - 0.4); };
  std::string a = "phase_deg,alpha_deg\n", l = "% digitized CL\nphase_rad  CL\n", m = "phase_deg;Cm\n";
  for (double ph : digitized_phases(41, 1)) a += indicial::format_double(ph * 180 / kPi) + "," + indicial::format_double(alpha_deg(ph)) + "\n";
  for (double ph : digitized_phases(37, 2)) l += indicial::format_double(ph) + "  " + indicial::format_double(history(ph)) + "\n";
  for (double ph : digitized_phases(52, 3)) m += indicial::format_double(ph * 180 / kPi) + ";" + indicial::format_double(cm(ph)) + "\n";
  write("alpha.csv", a);
  write("cl.txt", l);
  write("cm.csv", m);
  const std::string toml =
      "axis = \"pitch\"\ncoefficients = [\"CL\", \"Cm\"]\nreference_length_m = 0.275\nairspeed_mps = 40\n"
      "runs = [{files = [\"alpha.csv\", \"cl.txt\", \"cm.csv\"], frequency_hz = 2.0, samples = 128}]\n"
      "[static.CL]\npolynomial = [0.1, 5.0]\n[static.Cm]\npolynomial = [0.0]\n";
  const std::vector<indicial::Experiment> es = indicial::load_experiments(write("files.toml", toml));
  REQUIRE(es.size() == 2);
  for (const indicial::Experiment& e : es) {
    const indicial::Run& r = e.runs[0];
    CHECK(r.periodic);
    CHECK(r.time_grid == indicial::TimeGrid::uniform);
    REQUIRE(r.size() == 128);
    CHECK(r.dt_s() == doctest::Approx(1.0 / 256).epsilon(1e-12));
    CHECK(r.path == "alpha.csv + cl.txt + cm.csv");
    double worst_alpha = 0, worst_c = 0;
    for (std::size_t k = 0; k < r.size(); ++k) {
      const double ph = 2 * kPi * static_cast<double>(k) / 128;
      worst_alpha = std::max(worst_alpha, std::abs(r.motion_angle_rad[k] * 180 / kPi - alpha_deg(ph)));
      worst_c = std::max(worst_c, std::abs(r.coefficient[k] - (e.coefficient == "CL" ? history(ph) : cm(ph))));
    }
    CHECK(worst_alpha < 0.02 * 16);  // 2 % of alpha's peak-to-peak
    CHECK(worst_c < (e.coefficient == "CL" ? 0.03 : 0.0005));
  }
  bool noted = false;
  for (const auto& n : es[0].notes) noted = noted || n.find("alpha_deg at 41, CL at 37 phases, interpolated") != std::string::npos;
  CHECK(noted);
  // Written back as files = [...] and read again to the same run.
  const std::string back = indicial::write_experiment_toml(es[0], {});
  CHECK(back.find("{files = [\"alpha.csv\", \"cl.txt\", \"cm.csv\"], frequency_hz = 2, samples = 128}") != std::string::npos);
  const indicial::Experiment again = indicial::load_experiment(write("files_back.toml", back));
  CHECK(again.runs[0].coefficient == es[0].runs[0].coefficient);
  // Wrong entries name the problem.
  auto error_of = [&](const std::string& name, const std::string& text) {
    try {
      indicial::load_experiments(write(name, text));
    } catch (const indicial::InputError& err) {
      return std::string(err.what());
    }
    return std::string("(no error)");
  };
  auto with_runs = [&](const std::string& runs) {
    std::string t = toml;
    const std::size_t b = t.find("runs = "), e = t.find('\n', b);
    return t.replace(b, e - b, "runs = " + runs);
  };
  CHECK(error_of("nofreq.toml", with_runs("[{files = [\"alpha.csv\", \"cl.txt\", \"cm.csv\"]}]"))
            .find("needs the cycle's frequency") != std::string::npos);
  CHECK(error_of("noalpha.toml", with_runs("[{files = [\"cl.txt\", \"cm.csv\"], frequency_hz = 2.0}]"))
            .find("no file of the run has the motion angle column") != std::string::npos);
  CHECK(error_of("twice.toml", with_runs("[{files = [\"alpha.csv\", \"cl.txt\", \"cl.txt\", \"cm.csv\"], frequency_hz = 2.0}]"))
            .find("'CL' is in both") != std::string::npos);
  CHECK(error_of("both.toml", with_runs("[{file = \"alpha.csv\", files = [\"cl.txt\"], frequency_hz = 2.0}]"))
            .find("give 'runs.file' or 'runs.files', not both") != std::string::npos);
  CHECK(error_of("samples.toml", with_runs("[{file = \"alpha.csv\", samples = 64, frequency_hz = 2.0}]"))
            .find("'runs.samples' is used only with 'runs.files'") != std::string::npos);
}
