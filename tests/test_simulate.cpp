// The reference simulator (fitter/simulate.hpp) and `indicial simulate`.
#include <doctest/doctest.h>
#include <unistd.h>

#include <sys/wait.h>

#include <algorithm>
#include <boost/math/quadrature/gauss_kronrod.hpp>
#include <functional>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/csv_reader.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/fitter/simulate.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;

const fs::path& dir() {
  static const indicial::testing::TempDir d("test-simulate");
  return d.path;
}

int run_cli(const std::string& args, std::string* err = nullptr) {
  const fs::path err_file = dir() / "stderr.txt";
  const std::string cmd = std::string(INDICIAL_EXE) + " " + args + " > /dev/null 2> " + err_file.string();
  const int rc = std::system(cmd.c_str());
  if (err) {
    std::ifstream in(err_file);
    std::stringstream ss;
    ss << in.rdbuf();
    *err = ss.str();
  }
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

// All numeric columns of a CSV by header name.
std::map<std::string, std::vector<double>> read_columns(const fs::path& p) {
  std::ifstream in(p);
  std::string line;
  std::vector<std::string> names;
  std::map<std::string, std::vector<double>> cols;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::string cell;
    std::vector<std::string> cells;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (names.empty()) {
      names = cells;
      continue;
    }
    for (std::size_t i = 0; i < cells.size(); ++i) cols[names[i]].push_back(std::stod(cells[i]));
  }
  return cols;
}

// Model I's y(t) by direct quadrature of the convolution integral (report eq. 13):
//   y(t) = -integral_0^t exp(-b1 (t - tau)) a(alpha(tau)) alpha'(tau) dtau
// with adaptive Gauss-Kronrod, split at the times alpha crosses a knot of a(x) (where the
// integrand's 2nd derivative jumps) so each piece is smooth.
double quadrature_y(const indicial::CoefficientModel<double, indicial::FitCapacity>& m, double b1,
                    const std::function<double(double)>& alpha, const std::function<double(double)>& alpha_dot,
                    const std::vector<double>& splits, double t) {
  auto f = [&](double tau) {
    return std::exp(-b1 * (t - tau)) * indicial::spline_value(m.a, alpha(tau)) * alpha_dot(tau);
  };
  double sum = 0.0, a = 0.0;
  std::vector<double> pts = splits;
  pts.push_back(t);
  for (double s : pts) {
    if (s <= a) continue;
    const double b = std::min(s, t);
    sum += boost::math::quadrature::gauss_kronrod<double, 61>::integrate(f, a, b, 8, 1e-13);
    a = b;
    if (a >= t) break;
  }
  return -sum;
}

}  // namespace

TEST_CASE("simulate --case writes the runs, experiment.toml and truth.coef, refuses without --force") {
  const fs::path out = dir() / "m2";
  std::string err;
  REQUIRE(run_cli("simulate --case tailless-model-2 --out " + out.string() + " --snr 40 --seed 11", &err) == 0);
  for (const char* f : {"run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv", "experiment.toml", "truth.coef"}) {
    CHECK(fs::exists(out / f));
  }
  const auto cols = read_columns(out / "run_f0.25.csv");
  CHECK(cols.at("time_s").size() == 1201);  // 3 cycles at 0.25 Hz, dt = 0.01 s, both ends
  CHECK(cols.at("alpha_deg").front() == 0.0);
  CHECK(*std::max_element(cols.at("alpha_deg").begin(), cols.at("alpha_deg").end()) ==
        doctest::Approx(70.0));
  // The written experiment loads (Model II: b1 knots at the true knots, inside 0..70 deg).
  const indicial::Experiment e = indicial::load_experiment((out / "experiment.toml").string());
  CHECK(e.model.b1.knots_rad.size() == 4);
  CHECK(e.runs.size() == 3);
  CHECK(e.runs[1].rate_from_file);
  // Refused without --force, one line naming the directory, exit 1; replaced with --force.
  CHECK(run_cli("simulate --case tailless-model-2 --out " + out.string(), &err) == 1);
  CHECK(err.find("output directory is not empty") != std::string::npos);
  CHECK(std::count(err.begin(), err.end(), '\n') == 1);
  CHECK(run_cli("simulate --case tailless-model-2 --out " + out.string() + " --force") == 0);
  CHECK(run_cli("simulate --case no-such-case --out " + (dir() / "x").string(), &err) == 1);
  CHECK(err.find("unknown case 'no-such-case' (known: tailless-model-1, tailless-model-2") != std::string::npos);
  CHECK(run_cli("simulate --help") == 0);
}

TEST_CASE("noise: N(0, sigma) with sigma = RMS(y over all runs) / SNR") {
  const fs::path out = dir() / "m1";
  REQUIRE(run_cli("simulate --case tailless-model-1 --out " + out.string() + " --snr 40 --seed 20240601") == 0);
  double sum_y2 = 0, sum_r = 0, sum_r2 = 0;
  std::size_t n = 0;
  for (const char* f : {"run_f0.25.csv", "run_f0.50.csv", "run_f1.00.csv"}) {
    const auto c = read_columns(out / f);
    for (std::size_t k = 0; k < c.at("Cm").size(); ++k) {
      const double r = c.at("Cm")[k] - c.at("Cm_true")[k];
      sum_r += r;
      sum_r2 += r * r;
      sum_y2 += c.at("y_true")[k] * c.at("y_true")[k];
      ++n;
    }
  }
  const double sigma = std::sqrt(sum_y2 / static_cast<double>(n)) / 40.0;
  const double mean = sum_r / static_cast<double>(n);
  const double sd = std::sqrt(sum_r2 / static_cast<double>(n) - mean * mean);
  std::printf("Model I, SNR 40: sigma = RMS(y)/SNR = %.5f; noise sample sd %.5f, mean %.2e over %zu samples\n",
              sigma, sd, mean, n);
  // The reference's note: "for Model I at SNR = 40 that gives a noise standard deviation near 0.0035".
  CHECK(sigma > 0.0033);
  CHECK(sigma < 0.0038);
  // Sample sd of n = 2103 normals has relative standard error 1/sqrt(2n) = 1.5 %: allow 4.5 %.
  CHECK(std::abs(sd / sigma - 1.0) < 0.045);
  CHECK(std::abs(mean) < 4.0 * sigma / std::sqrt(static_cast<double>(n)));
  // Same seed, same data; no --snr, no noise.
  const fs::path again = dir() / "m1-again";
  REQUIRE(run_cli("simulate --case tailless-model-1 --out " + again.string() + " --snr 40 --seed 20240601") == 0);
  CHECK(read_columns(again / "run_f1.00.csv").at("Cm") == read_columns(out / "run_f1.00.csv").at("Cm"));
  const fs::path clean = dir() / "m1-clean";
  REQUIRE(run_cli("simulate --case tailless-model-1 --out " + clean.string()) == 0);
  const auto c = read_columns(clean / "run_f0.50.csv");
  CHECK(c.at("Cm") == c.at("Cm_true"));
}

TEST_CASE("reference integration agrees with direct quadrature of the convolution (Model I)") {
  const auto& cs = indicial::find_simulation_case("tailless-model-1");
  const auto& m = cs.truth.coefficients[0];
  const double b1 = 2.5;
  // Sine, 1 Hz: alpha = 35 - 35 cos(2 pi t) deg.
  {
    const indicial::SimulatedRun r = indicial::simulate_reference(cs.truth, cs.motions[2]);
    const double w = 2 * kPi;
    auto alpha = [&](double t) { return 35 * kDeg - 35 * kDeg * std::cos(w * t); };
    auto alpha_dot = [&](double t) { return 35 * kDeg * w * std::sin(w * t); };
    // Knot crossing times of a(x): alpha(t) = 0.4363 or 0.9599 -> t = acos(1 - k / A) / w (+ cycles).
    std::vector<double> splits;
    for (int cycle = 0; cycle < 3; ++cycle) {
      for (double k : {0.4363, 0.9599}) {
        const double phase = std::acos(1.0 - k / (35 * kDeg));
        splits.push_back((phase + 2 * kPi * cycle) / w);
        splits.push_back((2 * kPi * (cycle + 1) - phase) / w);
      }
    }
    std::sort(splits.begin(), splits.end());
    double worst = 0;
    for (std::size_t k : {17u, 50u, 123u, 200u, 299u}) {
      const double q = quadrature_y(m, b1, alpha, alpha_dot, splits, r.time_s[k]);
      worst = std::max(worst, std::abs(q - r.y_true[0][k]));
      CHECK(std::abs(q - r.y_true[0][k]) < 1e-8);
    }
    std::printf("sine 1 Hz: max |y_ode - y_quadrature| = %.2e\n", worst);
  }
  // Ramp 0 -> 70 deg at 30 deg/s after a 0.5 s hold: kinks at 0.5 s and 2.8333 s.
  {
    const indicial::MotionSpec ramp =
        indicial::parse_motion_spec("ramp:from_deg=0,to_deg=70,rate_dps=30,dt_s=0.01", indicial::Axis::pitch);
    const indicial::SimulatedRun r = indicial::simulate_reference(cs.truth, ramp);
    // 0.5 s hold + 70/30 s ramp + 2 s hold = 4.8333 s: floor(483.33) + 1 = 484 samples.
    CHECK(r.time_s.size() == 484);
    const double rate = 30 * kDeg;
    const double t1 = 0.5, t2 = 0.5 + 70.0 / 30.0;
    auto alpha = [&](double t) { return t <= t1 ? 0.0 : t >= t2 ? 70 * kDeg : rate * (t - t1); };
    auto alpha_dot = [&](double t) { return (t > t1 && t < t2) ? rate : 0.0; };
    const std::vector<double> splits = {t1, t1 + 0.4363 / rate, t1 + 0.9599 / rate, t2};
    double worst = 0;
    for (std::size_t k : {60u, 130u, 283u, 300u, 450u}) {
      const double q = quadrature_y(m, b1, alpha, alpha_dot, splits, r.time_s[k]);
      worst = std::max(worst, std::abs(q - r.y_true[0][k]));
      CHECK(std::abs(q - r.y_true[0][k]) < 1e-8);
    }
    std::printf("ramp 0..70 deg: max |y_ode - y_quadrature| = %.2e\n", worst);
  }
}

TEST_CASE("--model FILE.coef reproduces the case, and csv: motions follow the spline") {
  const fs::path out = dir() / "m1-model";
  REQUIRE(run_cli("simulate --case tailless-model-1 --out " + out.string()) == 0);
  const fs::path csv = dir() / "model-sine.csv";
  REQUIRE(run_cli("simulate --model " + (out / "truth.coef").string() +
                  " --motion sine:alpha0_deg=35,amp_deg=35,freq_hz=1,cycles=3,dt_s=0.01 --out " + csv.string()) == 0);
  const auto a = read_columns(csv);
  const auto b = read_columns(out / "run_f1.00.csv");
  // The coefficient file round-trips every double, so the simulation is the same bit for bit.
  CHECK(a.at("Cm_true") == b.at("Cm_true"));
  // csv: motion from the written run: a C2 spline through the 1 Hz samples.
  const fs::path csv2 = dir() / "model-csv.csv";
  REQUIRE(run_cli("simulate --model " + (out / "truth.coef").string() + " --motion csv:" +
                  (out / "run_f1.00.csv").string() + " --out " + csv2.string()) == 0);
  const auto c = read_columns(csv2);
  REQUIRE(c.at("y_true").size() == b.at("y_true").size());
  double worst = 0;
  for (std::size_t k = 0; k < c.at("y_true").size(); ++k) {
    worst = std::max(worst, std::abs(c.at("y_true")[k] - b.at("y_true")[k]));
  }
  std::printf("csv: motion (spline through 100 samples per cycle) vs analytic sine: max |dy| = %.2e\n", worst);
  CHECK(worst < 1e-7);  // measured 4.7e-9: the C2 spline's h^4 angle error
  // A written file is not overwritten without --force.
  std::string err;
  CHECK(run_cli("simulate --model " + (out / "truth.coef").string() +
                " --motion sine:alpha0_deg=35,amp_deg=35,freq_hz=1 --out " + csv.string(), &err) == 1);
  CHECK(err.find("output file exists") != std::string::npos);
}

TEST_CASE("one initial state: simulate --model and predict both start at rest (y = con / b1(x0))") {
  // examples/synthetic-lift-moment.coef: CL has con = 0.125, so y = 0 would be a transient.
  const std::string coef = std::string(INDICIAL_SOURCE_DIR) + "/examples/synthetic-lift-moment.coef";
  const auto model = indicial::read_model_file(coef);
  const indicial::MotionSpec motion =
      indicial::parse_motion_spec("sine:alpha0_deg=30,amp_deg=20,freq_hz=0.5,cycles=1.5,dt_s=0.002", indicial::Axis::pitch);
  const indicial::SimulatedRun sim = indicial::simulate_reference(indicial::to_truth_model(model), motion);
  const indicial::Prediction p =
      indicial::predict_motion(model, sim.time_s, sim.motion_angle_rad, sim.rate_radps, model.airspeed_mps);
  // The steady state at the first angle, from the model's own b1.
  const auto& cl = model.coefficients[0];
  const double y0 = cl.con / indicial::spline_value(cl.lags[0].b, sim.x_rad[0]);
  CHECK(sim.lag_states[0][0][0] == doctest::Approx(y0).epsilon(1e-15));
  double first = 0, sum_sq = 0;
  for (std::size_t c = 0; c < p.coefficients.size(); ++c) {
    first = std::max(first, std::abs(p.coefficients[c].predicted[0] - sim.coefficient_true[c][0]));
    for (std::size_t k = 0; k < sim.time_s.size(); ++k) {
      const double d = p.coefficients[c].predicted[k] - sim.coefficient_true[c][k];
      sum_sq += d * d;
    }
  }
  const double rms = std::sqrt(sum_sq / static_cast<double>(2 * sim.time_s.size()));
  std::printf("simulate --model vs predict on synthetic-lift-moment.coef: first sample %.2e, RMS %.2e\n", first, rms);
  CHECK(first < 1e-12);  // the same state, the same output function (was 0.031 with y = 0)
  CHECK(rms < 1e-4);     // the runtime's discretization at dt = 2 ms (was 0.0066 RMS over 3 s)
}

TEST_CASE("motion specs: defaults and errors") {
  using indicial::Axis;
  const indicial::MotionSpec s = indicial::parse_motion_spec("sine:alpha0_deg=35,amp_deg=35,freq_hz=0.5,cycles=3,dt_s=0.01", Axis::pitch);
  CHECK(indicial::motion_sample_times(s).size() == 601);
  auto err = [](const std::string& spec, Axis axis) {
    try {
      indicial::parse_motion_spec(spec, axis);
    } catch (const indicial::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  CHECK(err("sine:alpha0_deg=35,amp_deg=35", Axis::pitch).find("--motion: sine motion needs 'freq_hz'") == 0);
  CHECK(err("sine:alpha0_deg=35,amp_deg=35,freq_hz=1,colour=2", Axis::pitch).find("unknown key 'colour'") != std::string::npos);
  CHECK(err("sine:alpha0_deg=35,amp_deg=35,freq_hz=x", Axis::pitch).find("'freq_hz' needs a finite number") != std::string::npos);
  CHECK(err("sine:alpha0_deg=35,amp_deg=35,freq_hz=1", Axis::roll).find("mean_deg") != std::string::npos);
  CHECK(err("square:a=1", Axis::pitch).find("unknown motion kind 'square'") != std::string::npos);
  CHECK(err("ramp:from_deg=0,to_deg=10,rate_dps=0", Axis::pitch).find("'rate_dps' must be > 0") != std::string::npos);
  CHECK(err("csv:/nonexistent/x.csv", Axis::pitch).find("/nonexistent/x.csv: cannot open") == 0);
}

TEST_CASE("roll: beta and its rate follow eq. 17 and the chain rule") {
  indicial::TruthModel m = indicial::find_simulation_case("tailless-model-1").truth;
  m.axis = indicial::Axis::roll;
  m.alpha0_rad = 30 * kDeg;
  m.coefficients[0].name[0] = 'C';
  m.coefficients[0].name[1] = 'l';
  const indicial::MotionSpec s =
      indicial::parse_motion_spec("sine:mean_deg=0,amp_deg=40,freq_hz=1,cycles=1,dt_s=0.001", indicial::Axis::roll);
  const indicial::SimulatedRun r = indicial::simulate_reference(m, s);
  double worst = 0;
  for (std::size_t k = 1; k + 1 < r.time_s.size(); ++k) {
    CHECK(r.x_rad[k] == doctest::Approx(std::asin(std::sin(r.motion_angle_rad[k]) * 0.5)).epsilon(1e-14));
    const double fd = (r.x_rad[k + 1] - r.x_rad[k - 1]) / 0.002;
    worst = std::max(worst, std::abs(fd - r.xdot_radps[k]));
  }
  // Central difference error ~ dt^2 / 6 x''' ~ 1e-6 * 40 = 4e-5 rad/s.
  CHECK(worst < 1e-4);
  const std::string csv = indicial::simulated_run_csv(m, r, {});
  CHECK(csv.rfind("time_s,phi_deg,p_degps,Cl,Cl_true,y_true\n", 0) == 0);
}

TEST_CASE("simulate --model integrates a model with dynamic-stall families, freqresp refuses it and says why") {
  const std::string coef = std::string(INDICIAL_SOURCE_DIR) + "/examples/dynamic-stall-lift-moment.coef";
  const fs::path csv = dir() / "stall-simulated.csv";
  std::string err;
  CHECK(run_cli("simulate --model " + coef + " --motion sine:alpha0_deg=15,amp_deg=10,freq_hz=2,cycles=2,dt_s=0.002 --out " +
                    csv.string() + " --force", &err) == 0);
  REQUIRE(fs::exists(csv));
  // The written truth is the reference integration of the file's model, families included.
  const std::string text = indicial::read_text(coef);
  auto model = std::make_unique<indicial::ModelSet<double, indicial::FitCapacity>>();
  indicial::ParseDiagnostic diag;
  REQUIRE(indicial::parse_coef_file(text.data(), text.size(), model.get(), &diag) == indicial::LoadStatus::ok);
  REQUIRE(model->coefficients[0].stall.families != indicial::StallFamilies::none);
  const indicial::SimulatedRun r = indicial::simulate_reference(
      *model, indicial::parse_motion_spec("sine:alpha0_deg=15,amp_deg=10,freq_hz=2,cycles=2,dt_s=0.002", model->axis));
  const indicial::Run back = indicial::read_run_csv(csv.string(), indicial::Axis::pitch, "CL",
                                                    indicial::CoefficientPresence::required);
  REQUIRE(back.size() == r.time_s.size());
  for (std::size_t k = 0; k < back.size(); k += 97) CHECK(back.coefficient[k] == doctest::Approx(r.coefficient_true[0][k]).epsilon(1e-9));
  err.clear();
  const fs::path table = dir() / "stall-freqresp.csv";
  CHECK(run_cli("freqresp " + coef + " --alpha0-deg 15 --k-list 0.1 --out " + table.string(), &err) == 1);
  CHECK(err.find("has dynamic-stall families: its response depends on the amplitude") != std::string::npos);
  CHECK(err.find("indicial simulate --model") != std::string::npos);
  CHECK(!fs::exists(table));
}
