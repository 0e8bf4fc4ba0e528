// Thin-airfoil check: a TWO-LAG model identified from data simulated with Wagner's indicial
// function in R. T. Jones's form,
//
//   phi(s) = 1 - 0.165 exp(-0.0455 s) - 0.335 exp(-0.3 s),   s = 2 V t / c,
//
// reproduces Jones's frequency response and Theodorsen's function C(k). The data carry white
// measurement noise (SNR 50, the report's definition) so the identification is not trivial.
//
// Set-up (apparent-mass terms ignored): C_L(t) = 2 pi [alpha(t) phi(0) + integral phi'(t - tau)
// ...], i.e. the response to a step in alpha is 2 pi alpha phi(s). That is exactly our model with
//   static curve 2 pi x, no rotary term, a(x) = 2 pi 0.165 (constant), two lags:
//   b_1 = 0.0455 (2V/c), b_2 = 0.3 (2V/c), c_2 = 0.335 / 0.165,
// since a step dx gives y_j(t) = -c_j a dx exp(-b_j t). With k = omega c / (2V) = omega l / V
// (l = c / 2, our reference length), the model's frequency response divided by 2 pi is
//   C_J(k) = 1 - 0.165 ik / (ik + 0.0455) - 0.335 ik / (ik + 0.3)   (Jones),
// to be compared with Theodorsen's C(k) = H1(k) / (H1(k) + i H0(k)), Hankel functions of the
// second kind (boost::math::cyl_hankel_2).
#include <doctest/doctest.h>

#include <boost/math/special_functions/hankel.hpp>
#include <cmath>
#include <complex>
#include <vector>

#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/freqresp.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "indicial/fitter/simulate.hpp"
#include "fit_test_data.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;
constexpr double kAirspeed = 10.0;   // m/s
constexpr double kChord = 0.5;       // m; l = c / 2
constexpr double kTimeScale = 2.0 * kAirspeed / kChord;  // ds/dt, 1/s

std::complex<double> jones(double k) {
  const std::complex<double> ik(0.0, k);
  return 1.0 - 0.165 * ik / (ik + 0.0455) - 0.335 * ik / (ik + 0.3);
}

std::complex<double> theodorsen(double k) {
  const std::complex<double> h1 = boost::math::cyl_hankel_2(1.0, k);
  const std::complex<double> h0 = boost::math::cyl_hankel_2(0.0, k);
  return h1 / (h1 + std::complex<double>(0.0, 1.0) * h0);
}

indicial::TruthModel wagner_jones_model() {
  return indicial::testing::polynomial_pitch_truth({"CL", kChord / 2.0, kAirspeed, -10.0 * kDeg, 10.0 * kDeg,
                                                    {0.0, 2.0 * kPi}, {2.0 * kPi * 0.165},
                                                    {{{0.0455 * kTimeScale}}, {{0.3 * kTimeScale}, 0.335 / 0.165}}});
}

// Reduced frequencies of the simulated runs (k = omega l / V).
const std::vector<double> kRunK = {0.05, 0.1, 0.2, 0.4, 0.7, 1.0};

indicial::Experiment simulated_experiment(const indicial::TruthModel& truth) {
  indicial::Experiment e;
  e.path = "wagner-jones (simulated)";
  e.axis = indicial::Axis::pitch;
  e.coefficient = "CL";
  e.reference_length_m = truth.reference_length_m;
  e.airspeed_mps = truth.airspeed_mps;
  e.static_curve.kind = indicial::StaticKind::polynomial;
  e.static_curve.polynomial = {0.0, 2.0 * kPi};
  e.rotary.polynomial = {0.0};
  e.rotary.estimate = false;
  e.model.a = indicial::SplineConfig{{0}, {}, 2};
  e.model.b1 = indicial::SplineConfig{{0}, {}, 1};
  e.model.bias = false;
  e.model.lags = 2;
  e.model.structure = indicial::StructureMode::fixed;
  std::vector<indicial::SimulatedRun> sims;
  for (double k : kRunK) {
    indicial::MotionSpec s;
    s.kind = indicial::MotionKind::sine;
    s.mean_rad = 0.0;
    s.amplitude_rad = 2.0 * kDeg;
    s.freq_hz = k * kAirspeed / truth.reference_length_m / (2.0 * kPi);
    s.cycles = k < 0.15 ? 3.0 : 6.0;
    s.dt_s = 0.002;
    sims.push_back(indicial::simulate_reference(truth, s));
  }
  // Measurement noise: SNR 50 (sigma = RMS of the unsteady part / 50), fixed seed.
  indicial::add_measurement_noise(sims, 50.0, 20240611);
  for (std::size_t i = 0; i < sims.size(); ++i) {
    const indicial::SimulatedRun& sim = sims[i];
    indicial::Run r;
    r.path = "k" + std::to_string(kRunK[i]);
    r.time_s = sim.time_s;
    r.motion_angle_rad = sim.motion_angle_rad;
    r.rate_radps = sim.rate_radps;
    r.rate_from_file = true;
    r.coefficient = sim.coefficient_measured[0];
    e.runs.push_back(r);
  }
  indicial::set_data_range(e);
  return e;
}

struct Errors {
  double magnitude_rel = 0.0;
  double phase_deg = 0.0;
};

// Largest relative magnitude error and phase error of f against g over k in [0.05, 1].
template <class F, class G>
Errors max_errors(F f, G g) {
  Errors e;
  for (int i = 0; i <= 200; ++i) {
    const double k = 0.05 * std::pow(20.0, i / 200.0);  // log-spaced 0.05 .. 1
    const std::complex<double> a = f(k), b = g(k);
    e.magnitude_rel = std::max(e.magnitude_rel, std::abs(std::abs(a) / std::abs(b) - 1.0));
    e.phase_deg = std::max(e.phase_deg, std::abs(std::arg(a / b)) / kDeg);
  }
  return e;
}

}  // namespace

TEST_CASE("theodorsen: the set-up -- the Wagner-Jones model's linearised response is Jones's form") {
  const auto truth = wagner_jones_model();
  const auto model_h = [&](double k) {
    return indicial::linearised_response(truth, 0.0, {k}, kAirspeed)[0].points[0].h / (2.0 * kPi);
  };
  const Errors e = max_errors(model_h, jones);
  CHECK(e.magnitude_rel < 1e-12);
  CHECK(e.phase_deg < 1e-9);
  // And our Theodorsen function: Jones's form is within about 2.1 % and 1.3 deg of it.
  const Errors j = max_errors(jones, theodorsen);
  MESSAGE("Jones vs Theodorsen over k in [0.05, 1]: magnitude " << 100 * j.magnitude_rel
                                                              << " %, phase " << j.phase_deg << " deg");
  CHECK(j.magnitude_rel > 0.015);
  CHECK(j.magnitude_rel < 0.025);
  CHECK(j.phase_deg > 0.8);
  CHECK(j.phase_deg < 1.5);
  // Theodorsen's limits: C(0) = 1, C(inf) = 1/2.
  CHECK(std::abs(theodorsen(1e-6) - 1.0) < 1e-3);
  CHECK(std::abs(theodorsen(200.0) - 0.5) < 2e-3);
}

TEST_CASE("theodorsen: a two-lag model identified from Wagner-Jones data matches Jones and Theodorsen") {
  const auto truth = wagner_jones_model();
  const indicial::Experiment e = simulated_experiment(truth);
  const indicial::FitResult r = indicial::fit_experiment(e, indicial::FitOptions{});
  for (const auto& p : r.parameters)
    MESSAGE(p.name << " = " << p.value << " (" << p.cr_bound << ")");
  MESSAGE("termination: " << std::string(indicial::termination_name(r.output_error.termination))
                          << ", s(v) = " << r.fit_error);
  REQUIRE(r.model.coefficients[0].n_lags == 2);
  // The written envelope (base_model_set's, on which the fit keeps b_j > 0) is the data's
  // model-angle range, the sines' +-2 deg, the same as Experiment::data_x_*.
  CHECK(r.model.x_min_rad == e.data_x_min_rad);
  CHECK(r.model.x_max_rad == e.data_x_max_rad);
  CHECK(e.data_x_min_rad == doctest::Approx(-2.0 * kDeg).epsilon(1e-3));
  CHECK(e.data_x_max_rad == doctest::Approx(2.0 * kDeg).epsilon(1e-3));
  const auto fitted_h = [&](double k) {
    return indicial::linearised_response(r.model, 0.0, {k}, kAirspeed)[0].points[0].h / (2.0 * kPi);
  };
  const Errors vs_jones = max_errors(fitted_h, jones);
  const Errors vs_theodorsen = max_errors(fitted_h, theodorsen);
  MESSAGE("fitted vs Jones: magnitude " << 100 * vs_jones.magnitude_rel << " %, phase "
                                        << vs_jones.phase_deg << " deg");
  MESSAGE("fitted vs Theodorsen: magnitude " << 100 * vs_theodorsen.magnitude_rel << " %, phase "
                                             << vs_theodorsen.phase_deg << " deg");
  CHECK(vs_jones.magnitude_rel < 0.005);
  CHECK(vs_jones.phase_deg < 0.3);
  CHECK(vs_theodorsen.magnitude_rel < 0.025);
  CHECK(vs_theodorsen.phase_deg < 1.5);
}
