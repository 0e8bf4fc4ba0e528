// The linearised frequency response (fitter/.../freqresp.hpp) against a numerical
// small-amplitude simulation of the runtime: the first harmonic of the runtime's output,
// fitted by least squares over whole cycles after the transient has decayed, must equal H.
#include <doctest/doctest.h>
#include <unistd.h>

#include <Eigen/Dense>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "indicial/fitter/freqresp.hpp"
#include "indicial/fitter/predict.hpp"
#include "indicial/fitter/simulate.hpp"
#include "indicial/runtime.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;

// First harmonic of the runtime's response to m = m0 + d sin(w t): C - C0 = d (Re H sin + Im H cos).
std::complex<double> simulated_h(const indicial::TruthModel& model, double m0, double k,
                                 double d) {
  auto p = std::make_unique<indicial::Predictor<double, indicial::FitCapacity>>();
  REQUIRE(p->load(model) == indicial::LoadStatus::ok);
  const double V = model.airspeed_mps;
  const double w = k * V / model.reference_length_m;
  const double period = 2.0 * kPi / w;
  // Slowest lag decay over the oscillation (b_j at m0): settle for 25 time constants.
  double b_min = 1e300;
  const double x0 = indicial::model_angle<double>(model.axis, model.alpha0_rad, m0);
  for (int j = 0; j < model.coefficients[0].n_lags; ++j)
    b_min = std::min(b_min, indicial::spline_value(model.coefficients[0].lags[j].b, x0));
  const double settle_s = 25.0 / b_min;
  const int cycles_fit = 2;
  const int steps_per_cycle = 2000;
  const double dt = period / steps_per_cycle;
  const int settle_cycles = static_cast<int>(std::ceil(settle_s / period));
  const int n_total = (settle_cycles + cycles_fit) * steps_per_cycle;
  REQUIRE(p->reset(m0, V) == indicial::StepStatus::ok);
  const int n_fit = cycles_fit * steps_per_cycle;
  Eigen::MatrixXd A(n_fit, 3);
  Eigen::VectorXd c(n_fit);
  indicial::Predictor<double, indicial::FitCapacity>::Outputs out;
  int refused = 0;
  for (int i = 1; i <= n_total; ++i) {
    const double t = i * dt;
    const double m = m0 + d * std::sin(w * t);
    const double rate = d * w * std::cos(w * t);
    const auto st = p->step(indicial::MotionInput{m, rate, V}, dt, &out);
    if (st != indicial::StepStatus::ok) ++refused;
    const int row = i - (n_total - n_fit) - 1;
    if (row >= 0) {
      A(row, 0) = 1.0;
      A(row, 1) = std::sin(w * t);
      A(row, 2) = std::cos(w * t);
      c(row) = out.value[0];
    }
  }
  REQUIRE(refused == 0);
  const Eigen::Vector3d coef = A.colPivHouseholderQr().solve(c);
  return {coef(1) / d, coef(2) / d};
}

double check_model(const indicial::TruthModel& model, double m0) {
  double worst = 0.0;
  const std::vector<double> ks = {0.02, 0.05, 0.1, 0.2, 0.4};
  const auto r = indicial::linearised_response(model, m0, ks, model.airspeed_mps);
  REQUIRE(r.size() == 1);
  for (std::size_t i = 0; i < ks.size(); ++i) {
    const std::complex<double> h_lin = r[0].points[i].h;
    const std::complex<double> h_sim = simulated_h(model, m0, ks[i], 1e-4);
    const double rel = std::abs(h_sim - h_lin) / std::abs(h_lin);
    INFO("m0 = " << m0 / kDeg << " deg, k = " << ks[i] << ": linear " << h_lin << ", simulated "
                 << h_sim << ", relative difference " << rel);
    // Tolerance: the runtime's update is second order in dt (2000 steps per cycle) and the
    // amplitude 1e-4 rad leaves cubic terms ~1e-8; measured at most 3.9e-6 over these models
    // (mean angles off the knots). 2e-5 leaves margin while catching any missing term.
    CHECK(rel < 2e-5);
    worst = std::max(worst, rel);
  }
  MESSAGE(model.coefficients[0].name << " about " << m0 / kDeg << " deg: largest relative |H_sim - H_lin| / |H_lin| = " << worst);
  return worst;
}

}  // namespace

TEST_CASE("freqresp: linearisation matches the runtime's small-amplitude response (tailless Model II)") {
  check_model(indicial::find_simulation_case("tailless-model-2").truth, 40.0 * kDeg);  // between knots
}

TEST_CASE("freqresp: the steady-state term (con != 0 and b1'(x0) != 0) is needed and right (f16xl-like-CL)") {
  const auto& model = indicial::find_simulation_case("f16xl-like-CL").truth;
  check_model(model, 30.0 * kDeg);
  check_model(model, 50.0 * kDeg);
  // H(0) is the slope of the steady-state curve C_a(x) + con / b1(x): check by a difference.
  const auto& cm = model.coefficients[0];
  auto steady = [&](double x) {
    return indicial::spline_value(cm.static_curve.polynomial, x) +
           cm.con / indicial::spline_value(cm.lags[0].b, x);
  };
  const double x0 = 50.0 * kDeg, h = 1e-6;
  const auto r = indicial::linearised_response(model, x0, {0.0}, model.airspeed_mps);
  CHECK(r[0].points[0].h.real() ==
        doctest::Approx((steady(x0 + h) - steady(x0 - h)) / (2 * h)).epsilon(1e-6));
  CHECK(std::abs(r[0].steady_state_slope - r[0].static_slope) > 1e-2);  // the term matters here
}

TEST_CASE("freqresp: a pure delay of the forcing multiplies the forcing term by exp(-i w tau)") {
  indicial::TruthModel model = indicial::find_simulation_case("f16xl-like-Cm").truth;
  model.coefficients[0].delay_s = 0.02;  // within the FitCapacity history at 2000 steps per cycle
  check_model(model, 20.0 * kDeg);
}

TEST_CASE("freqresp: roll and yaw linearise in the motion angle (eqs. 17 and 20)") {
  check_model(indicial::find_simulation_case("lateral-roll-Cl").truth, 10.0 * kDeg);
  check_model(indicial::find_simulation_case("lateral-yaw-Cn").truth, -8.0 * kDeg);
}

TEST_CASE("freqresp: CLI writes the table and the plot and refuses bad input") {
  namespace fs = std::filesystem;
  const indicial::testing::TempDir tmp("test-freqresp");
  const fs::path& dir = tmp.path;
  const std::string exe = INDICIAL_EXE;
  const std::string coef = (dir / "m.coef").string();
  {
    std::ofstream f(coef);
    f << indicial::truth_coef_text(indicial::find_simulation_case("f16xl-like-Cm").truth);
  }
  const std::string csv = (dir / "fr.csv").string(), png = (dir / "fr.png").string();
  const std::string cmd = exe + " freqresp " + coef + " --alpha0-deg 20 --k-list 0.05,0.1,0.2 --out " +
                          csv + " --plot " + png + " > " + (dir / "log.txt").string() + " 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  std::ifstream in(csv);
  std::string line;
  int rows = 0;
  bool header = false;
  while (std::getline(in, line)) {
    if (line.rfind("coefficient,k,", 0) == 0) header = true;
    else if (line.rfind("Cm,", 0) == 0) ++rows;
  }
  CHECK(header);
  CHECK(rows == 3);
  CHECK(fs::file_size(png) > 1000);
  // Refuses to overwrite; refuses a mean angle outside the envelope and a malformed k list.
  CHECK(std::system(cmd.c_str()) != 0);
  const std::string bad1 = exe + " freqresp " + coef + " --alpha0-deg 120 --k-list 0.1 > /dev/null 2>&1";
  CHECK(std::system(bad1.c_str()) != 0);
  const std::string bad2 = exe + " freqresp " + coef + " --alpha0-deg 20 --k-list 0.1,x > /dev/null 2>&1";
  CHECK(std::system(bad2.c_str()) != 0);
  // gnuplot cannot be run: exit 1 and neither the plot nor the table is written.
  const std::string csv2 = (dir / "fr2.csv").string(), png2 = (dir / "fr2.png").string();
  const std::string nogp = exe + " freqresp " + coef + " --alpha0-deg 20 --k-list 0.1 --out " + csv2 + " --plot " + png2 +
                           " --gnuplot /nonexistent/gnuplot > /dev/null 2>&1";
  CHECK(std::system(nogp.c_str()) != 0);
  CHECK_FALSE(fs::exists(csv2));
  CHECK_FALSE(fs::exists(png2));
}
