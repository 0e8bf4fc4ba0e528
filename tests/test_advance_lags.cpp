// The discrete update advance_lags() (shared/include/indicial/model.hpp) against the
// reference integration of the continuous model (fitter simulate.hpp, Dormand-Prince 1e-12):
// accuracy at 1 ms, measured order over three halvings, the b dt -> 0 limit, the phi1 branch
// seam, the autodiff Jacobian of one step, and the roll / yaw angle transforms; the delayed
// forcing (delayed_angle): its interpolation rules, its autodiff derivative with respect to
// the delay, and the delayed update (direct and through the runtime) against the reference.
#include <doctest/doctest.h>

#include <Eigen/Core>
#include <unsupported/Eigen/AutoDiff>
#include <cmath>
#include <cstdio>
#include <type_traits>
#include <vector>

#include "indicial/fitter/simulate.hpp"
#include "indicial/model.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::testing::kPi;
constexpr double kDeg = kPi / 180.0;

using indicial::FitCapacity;
using indicial::TruthModel;

indicial::MotionSpec sine_1hz(double dt_s) {
  indicial::MotionSpec m;
  m.kind = indicial::MotionKind::sine;
  m.mean_rad = 35.0 * kDeg;
  m.amplitude_rad = 35.0 * kDeg;
  m.freq_hz = 1.0;
  m.cycles = 3.0;
  m.dt_s = dt_s;
  return m;
}

// Runs the discrete update over the reference's samples and returns max |y_d - y_ref|.
double max_discrete_error(const TruthModel& model, double dt_s) {
  const indicial::SimulatedRun ref = indicial::simulate_reference(model, sine_1hz(dt_s));
  const auto& cm = model.coefficients[0];
  double y[FitCapacity::max_lags] = {};
  double err = 0.0;
  for (std::size_t k = 0; k + 1 < ref.time_s.size(); ++k) {
    const indicial::StepGeometry<double> g{ref.x_rad[k], ref.x_rad[k + 1], ref.x_rad[k],
                                           ref.x_rad[k + 1], dt_s, 1.0};
    indicial::advance_lags(cm, g, y);
    err = std::max(err, std::abs(y[0] - ref.lag_states[0][0][k + 1]));
  }
  return err;
}

}  // namespace

// Prints the error table and checks max error at 1 ms and the order over three halvings.
// "Order >= 2" is checked as >= 1.95: a second-order method measures 1.99..2.01 on smooth
// problems, and a strict 2.0 would fail on rounding.
void check_convergence(const char* case_name) {
  const TruthModel& model = indicial::find_simulation_case(case_name).truth;
  const double dts[] = {0.008, 0.004, 0.002, 0.001};
  double errors[4];
  for (int i = 0; i < 4; ++i) errors[i] = max_discrete_error(model, dts[i]);
  std::printf("advance_lags vs reference, %s, alpha = 35 - 35 cos(2 pi t) deg, 3 cycles\n", case_name);
  std::printf("  dt_s      max|y error|   order\n");
  for (int i = 0; i < 4; ++i) {
    if (i == 0) {
      std::printf("  %-8.4g  %.4e\n", dts[i], errors[i]);
    } else {
      std::printf("  %-8.4g  %.4e     %.3f\n", dts[i], errors[i], std::log2(errors[i - 1] / errors[i]));
    }
  }
  CHECK(errors[3] < 1e-6);
  for (int i = 1; i < 4; ++i) CHECK(std::log2(errors[i - 1] / errors[i]) >= 1.95);
}

TEST_CASE("advance_lags converges to the reference at order 2 (Model II, 35 deg, 1 Hz)") {
  check_convergence("tailless-model-2");
}

TEST_CASE("advance_lags converges to the reference at order 2 (Model I, 35 deg, 1 Hz)") {
  check_convergence("tailless-model-1");
}

TEST_CASE("advance_lags at the report's 10 ms step is accurate to the noise floor (Model I)") {
  // Not a requirement of the issue, but the fitter runs at the data's 10 ms: print it.
  const TruthModel& model1 = indicial::find_simulation_case("tailless-model-1").truth;
  const double e = max_discrete_error(model1, 0.01);
  std::printf("Model I, dt = 10 ms: max|y error| = %.3e (noise sigma at SNR 40 is ~3.6e-3)\n", e);
  CHECK(e < 1e-4);
}

TEST_CASE("b dt -> 0: b = 0 gives y = -[A(x_N) - A(x_0)] exactly, tiny b is continuous") {
  TruthModel m = indicial::find_simulation_case("tailless-model-1").truth;
  auto& cm = m.coefficients[0];
  cm.lags[0].b.n_powers = 1;
  cm.lags[0].b.power_coef[0] = 0.0;
  const indicial::SimulatedRun ref = indicial::simulate_reference(m, sine_1hz(0.01));
  double y[FitCapacity::max_lags] = {};
  for (std::size_t k = 0; k + 1 < ref.time_s.size(); ++k) {
    const indicial::StepGeometry<double> g{ref.x_rad[k], ref.x_rad[k + 1], ref.x_rad[k],
                                           ref.x_rad[k + 1], 0.01, 1.0};
    indicial::advance_lags(cm, g, y);
    // Telescoping sum of the exact antiderivative differences.
    const double expected = -(indicial::spline_antiderivative(cm.a, ref.x_rad[k + 1]) -
                              indicial::spline_antiderivative(cm.a, ref.x_rad[0]));
    REQUIRE(std::abs(y[0] - expected) < 1e-13);
    // With b = 0 the continuous solution is the same integral: the reference agrees too.
    REQUIRE(std::abs(ref.lag_states[0][0][k + 1] - expected) < 1e-9);
  }
  // b = 1e-9 1/s: the exponential branch of phi1 is not taken (z = 1e-11), and the result
  // differs from b = 0 by O(b t) relative, no 0/0.
  double y0[1] = {0.0}, y1[1] = {0.0}, y0_max = 0.0;
  TruthModel m_small = m;
  m_small.coefficients[0].lags[0].b.power_coef[0] = 1e-9;
  for (std::size_t k = 0; k + 1 < ref.time_s.size(); ++k) {
    const indicial::StepGeometry<double> g{ref.x_rad[k], ref.x_rad[k + 1], ref.x_rad[k],
                                           ref.x_rad[k + 1], 0.01, 1.0};
    indicial::advance_lags(m.coefficients[0], g, y0);
    indicial::advance_lags(m_small.coefficients[0], g, y1);
    REQUIRE(std::isfinite(y1[0]));
    y0_max = std::max(y0_max, std::abs(y0[0]));
  }
  // |y(b) - y(0)| <= b T max|y| = 1e-9 * 3 s * max|y|; allow a factor 3.
  CHECK(std::abs(y1[0] - y0[0]) <= 1e-8 * y0_max);
  CHECK(std::abs(y1[0] - y0[0]) > 0.0);  // and b did act
}

TEST_CASE("phi1 is smooth across its series / exponential seam (value and autodiff derivative)") {
  using AD = Eigen::AutoDiffScalar<Eigen::VectorXd>;
  for (double seam : {1e-3, -1e-3}) {
    for (double rel : {-1e-9, 1e-9}) {
      const double z = seam * (1.0 + rel);
      // Reference from the series to 6 terms (truncation < z^6/5040 ~ 2e-22).
      const double v_ref = 1 - z / 2 + z * z / 6 - z * z * z / 24 + z * z * z * z / 120 -
                           z * z * z * z * z / 720;
      const double d_ref = -0.5 + z / 3 - z * z / 8 + z * z * z / 30 - z * z * z * z / 144;
      AD za(z, Eigen::VectorXd::Unit(1, 0));
      const AD p = indicial::phi1(za);
      CHECK(std::abs(p.value() - v_ref) < 1e-13);
      CHECK(std::abs(indicial::phi1(z) - v_ref) < 1e-13);
      // The exponential branch's derivative loses ~eps / z^2 = 2e-10 to cancellation.
      CHECK(std::abs(p.derivatives()(0) - d_ref) < 1e-9);
    }
  }
  // Exact at zero, no NaN in value or derivative.
  AD z0(0.0, Eigen::VectorXd::Unit(1, 0));
  const AD p0 = indicial::phi1(z0);
  CHECK(p0.value() == 1.0);
  CHECK(p0.derivatives()(0) == -0.5);
}

TEST_CASE("autodiff Jacobian of one step matches central finite differences") {
  using AD = Eigen::AutoDiffScalar<Eigen::VectorXd>;
  const TruthModel& truth = indicial::find_simulation_case("tailless-model-2").truth;
  const auto& cm = truth.coefficients[0];
  // Parameters: a0 a1 a2 A1 A2 | b10 B1 B2 B3 B4 | y_in.
  const int n_a = cm.a.n_powers + cm.a.n_knots;
  const int n_b = cm.lags[0].b.n_powers + cm.lags[0].b.n_knots;
  const int n = n_a + n_b + 1;
  std::vector<double> p0;
  for (int i = 0; i < cm.a.n_powers; ++i) p0.push_back(cm.a.power_coef[i]);
  for (int j = 0; j < cm.a.n_knots; ++j) p0.push_back(cm.a.knot_coef[j]);
  for (int i = 0; i < cm.lags[0].b.n_powers; ++i) p0.push_back(cm.lags[0].b.power_coef[i]);
  for (int j = 0; j < cm.lags[0].b.n_knots; ++j) p0.push_back(cm.lags[0].b.knot_coef[j]);
  p0.push_back(-0.05);  // incoming y

  // Build a model of scalar type S from parameter values (with seeds for AD).
  // Eigen's AutoDiffScalar<VectorXd> cannot add an expression with an empty derivative vector
  // to a sized one (an assertion in Debug, a crash in Release), so every AD input that is not
  // a parameter carries a zero derivative vector of the full size (`constant` below); the
  // model's own Scalar(k) constants are then resized by Eigen's make_coherent.
  auto step = [&](auto tag, const std::vector<decltype(tag)>& p, double x0, double x1) {
    using S = decltype(tag);
    auto constant = [&](double v) {
      if constexpr (std::is_same_v<S, double>) return v;
      else return S(v, Eigen::VectorXd::Zero(n));
    };
    indicial::CoefficientModel<S, FitCapacity> m;
    m.con = constant(0.0);
    m.a.n_powers = cm.a.n_powers;
    m.a.n_knots = cm.a.n_knots;
    int k = 0;
    for (int i = 0; i < cm.a.n_powers; ++i) m.a.power_coef[i] = p[static_cast<std::size_t>(k++)];
    for (int j = 0; j < cm.a.n_knots; ++j) {
      m.a.knot_rad[j] = cm.a.knot_rad[j];
      m.a.knot_power[j] = cm.a.knot_power[j];
      m.a.knot_coef[j] = p[static_cast<std::size_t>(k++)];
    }
    auto& b = m.lags[0].b;
    b.n_powers = cm.lags[0].b.n_powers;
    b.n_knots = cm.lags[0].b.n_knots;
    for (int i = 0; i < b.n_powers; ++i) b.power_coef[i] = p[static_cast<std::size_t>(k++)];
    for (int j = 0; j < b.n_knots; ++j) {
      b.knot_rad[j] = cm.lags[0].b.knot_rad[j];
      b.knot_power[j] = cm.lags[0].b.knot_power[j];
      b.knot_coef[j] = p[static_cast<std::size_t>(k++)];
    }
    m.n_lags = 1;
    S y[FitCapacity::max_lags] = {p[static_cast<std::size_t>(k)]};
    const indicial::StepGeometry<S> g{constant(x0), constant(x1), constant(x0), constant(x1),
                                      constant(0.01), constant(1.0)};
    indicial::advance_lags(m, g, y);
    return y[0];
  };

  // Steps placed so that every knot term is active at one end at least.
  const double steps[][2] = {{0.30, 0.36}, {1.00, 1.06}, {1.20, 1.17}};
  for (const auto& st : steps) {
    std::vector<AD> pa;
    for (int i = 0; i < n; ++i) {
      pa.emplace_back(p0[static_cast<std::size_t>(i)], Eigen::VectorXd::Unit(n, i));
    }
    const AD ya = step(AD(), pa, st[0], st[1]);
    for (int i = 0; i < n; ++i) {
      const double h = 1e-6 * std::max(1.0, std::abs(p0[static_cast<std::size_t>(i)]));
      std::vector<double> pp = p0, pm = p0;
      pp[static_cast<std::size_t>(i)] += h;
      pm[static_cast<std::size_t>(i)] -= h;
      const double fd = (step(0.0, pp, st[0], st[1]) - step(0.0, pm, st[0], st[1])) / (2 * h);
      const double ad = ya.derivatives()(i);
      INFO("step " << st[0] << " -> " << st[1] << ", parameter " << i << ": ad " << ad
                   << ", fd " << fd);
      // Relative 1e-6, with a floor for derivatives that are zero (inactive knot terms).
      CHECK(std::abs(ad - fd) <= 1e-6 * std::max(std::abs(fd), 1e-4));
    }
    // And the AD value is the double value.
    CHECK(ya.value() == doctest::Approx(step(0.0, p0, st[0], st[1])).epsilon(1e-15));
  }
}

TEST_CASE("roll and yaw model angles (report eqs. 17, 20) against hand numbers") {
  using indicial::Axis;
  // Roll, phi = 30 deg, alpha0 = 30 deg: beta = asin(sin 30 sin 30) = asin(0.25)
  //   = 0.252680255142078653 rad (14.4775 deg).
  CHECK(indicial::model_angle(Axis::roll, 30 * kDeg, 30 * kDeg) ==
        doctest::Approx(0.252680255142078653).epsilon(1e-14));
  // Roll, phi = 90 deg, alpha0 = 45 deg: beta = asin(sin 45) = 45 deg = pi / 4.
  CHECK(indicial::model_angle(Axis::roll, 45 * kDeg, 90 * kDeg) ==
        doctest::Approx(kPi / 4).epsilon(1e-14));
  // Roll, phi = -20 deg, alpha0 = 0: beta = asin(0) = 0 (no sideslip at zero incidence).
  CHECK(std::abs(indicial::model_angle(Axis::roll, 0.0, -20 * kDeg)) < 1e-16);
  // Yaw, psi = 30 deg, alpha0 = 60 deg: beta = asin(-sin 30 cos 60) = asin(-0.25)
  //   = -0.252680255142078653 rad.
  CHECK(indicial::model_angle(Axis::yaw, 60 * kDeg, 30 * kDeg) ==
        doctest::Approx(-0.252680255142078653).epsilon(1e-14));
  // Yaw, psi = 90 deg, alpha0 = 0: beta = asin(-1) = -pi / 2.
  CHECK(indicial::model_angle(Axis::yaw, 0.0, 90 * kDeg) == doctest::Approx(-kPi / 2).epsilon(1e-14));
  // Yaw, psi = -10 deg, alpha0 = 20 deg: beta = asin(sin 10 cos 20)
  //   = asin(0.173648177666930 * 0.939692620785908) = asin(0.163175911166535)
  //   = 0.163908... rad; computed here from the hand-evaluated sine product.
  CHECK(indicial::model_angle(Axis::yaw, 20 * kDeg, -10 * kDeg) ==
        doctest::Approx(std::asin(0.163175911166535)).epsilon(1e-13));
  // Pitch is the identity.
  CHECK(indicial::model_angle(Axis::pitch, 0.3, 0.7) == 0.7);
}

// ==========================================================================================
// Delayed forcing: x_f(t) = x(t - delay) by indicial::delayed_angle
// ==========================================================================================
namespace {

// 0, 0.1, ..., 0.5 s with x = t^2 (so linear interpolation differs from the curve).
struct SquareHistory {
  double t[6] = {0.0, 0.1, 0.2, 0.3, 0.4, 0.5};
  double x[6] = {0.0, 0.01, 0.04, 0.09, 0.16, 0.25};
  indicial::ArrayHistory<double> all() const { return {t, x, 6}; }
};

// A sine motion that stays strictly inside Model II's 0..70 deg envelope (no clamping).
indicial::MotionSpec sine_30(double dt_s) {
  indicial::MotionSpec m = sine_1hz(dt_s);
  m.mean_rad = 30.0 * kDeg;
  m.amplitude_rad = 29.0 * kDeg;
  return m;
}

}  // namespace

TEST_CASE("delayed_angle: exact at samples, linear between, at rest before, no future") {
  const SquareHistory sq;
  const auto h = sq.all();
  // At the newest time with no delay: the newest sample, exactly.
  CHECK(indicial::delayed_angle(h, 0.5, 0.0) == 0.25);
  // On samples (t - delay = 0.3 s): exactly the stored angle.
  CHECK(indicial::delayed_angle(h, 0.5, 0.5 - 0.3) == 0.09);
  CHECK(indicial::delayed_angle(h, 0.4, 0.4 - 0.3) == 0.09);
  // Between samples: the straight line, not the curve t^2 (0.25^2 = 0.0625).
  CHECK(indicial::delayed_angle(h, 0.5, 0.25) == doctest::Approx(0.065).epsilon(1e-14));
  CHECK(indicial::delayed_angle(h, 0.45, 0.1) == doctest::Approx(0.09 + 0.5 * 0.07).epsilon(1e-14));
  // Before the oldest sample: the oldest angle (at rest); even far before.
  CHECK(indicial::delayed_angle(h, 0.5, 0.7) == 0.0);
  CHECK(indicial::delayed_angle(h, 0.5, 1e6) == 0.0);
  // A negative delay (t - delay after the newest): the newest angle, no extrapolation.
  CHECK(indicial::delayed_angle(h, 0.5, -0.2) == 0.25);
  // Samples newer than t_now are allowed (a fitter passes the whole run): only t - delay
  // counts. A negative delay between samples interpolates among the newer samples.
  CHECK(indicial::delayed_angle(h, 0.2, 0.05) == doctest::Approx(0.025).epsilon(1e-14));
  CHECK(indicial::delayed_angle(h, 0.2, -0.1) == doctest::Approx(0.09).epsilon(1e-14));
  // Same as a truncated history ending at t_now.
  const indicial::ArrayHistory<double> upto{sq.t, sq.x, 3};
  for (double d : {0.0, 0.03, 0.1, 0.17, 0.2, 0.35}) {
    CHECK(indicial::delayed_angle(h, 0.2, d) == indicial::delayed_angle(upto, 0.2, d));
  }
  // One sample: its angle for any delay.
  const indicial::ArrayHistory<double> one{sq.t, sq.x + 3, 1};
  CHECK(indicial::delayed_angle(one, 0.0, 0.3) == 0.09);
  // Monotone in the delay between samples (x increases with t, so decreases with delay).
  double prev = 1.0;
  for (int i = 0; i <= 600; ++i) {
    const double v = indicial::delayed_angle(h, 0.5, 0.001 * i);
    CHECK(v <= prev);
    prev = v;
  }
  // Airspeed scaling of the delay: V_ref / V.
  CHECK(indicial::delay_at_airspeed(0.03, 20.0, 40.0) == 0.015);
}

TEST_CASE("delayed_angle: autodiff derivative with respect to the delay is -slope (vs FD)") {
  // Eigen::AutoDiffScalar<VectorXd> with a second, unrelated parameter, as a fitter would
  // have: the constants inside delayed_angle carry empty derivative vectors.
  using AD = Eigen::AutoDiffScalar<Eigen::VectorXd>;
  const SquareHistory sq;
  const auto h = sq.all();
  for (double d : {0.0, 0.013, 0.1234, 0.25, 0.3999, 0.47}) {
    const AD delay(d, Eigen::VectorXd::Unit(2, 0));
    const AD xf = indicial::delayed_angle(h, 0.5, delay);
    const double fd_h = 1e-7;
    // One-sided to the older side at a sample (the newer segment's slope is what the
    // function promises there; at d = 0 that is the last segment's).
    const double fd = (indicial::delayed_angle(h, 0.5, d + fd_h) - indicial::delayed_angle(h, 0.5, d)) / fd_h;
    INFO("delay " << d << ": ad " << xf.derivatives()(0) << ", fd " << fd);
    CHECK(xf.value() == indicial::delayed_angle(h, 0.5, d));
    CHECK(xf.derivatives().size() == 2);
    CHECK(xf.derivatives()(1) == 0.0);
    CHECK(std::abs(xf.derivatives()(0) - fd) <= 1e-6);
  }
  // At delay 0 the derivative is -(x_0 - x_1) / (t_0 - t_1) = -(0.25 - 0.16) / 0.1 = -0.9, not 0:
  // an estimate started at zero delay can move.
  const AD xf0 = indicial::delayed_angle(h, 0.5, AD(0.0, Eigen::VectorXd::Unit(2, 0)));
  CHECK(xf0.derivatives()(0) == doctest::Approx(-0.9).epsilon(1e-12));
  // Before the history (at rest): no sensitivity.
  const AD xf_rest = indicial::delayed_angle(h, 0.5, AD(0.8, Eigen::VectorXd::Unit(2, 0)));
  CHECK(xf_rest.value() == 0.0);
  CHECK(xf_rest.derivatives().norm() == 0.0);
}

namespace {

// Table I Model I (constant b1, so no b(x) kinks blur the measured order) with its forcing
// delayed: the runtime's model and the simulator's truth.
indicial::ModelSet<double, indicial::DefaultCapacity> delayed_model_one(double delay_s) {
  auto m = indicial::test_models::table_one_model_one();
  m.coefficients[0].delay_s = delay_s;
  return m;
}

struct DelayedErrors {
  double direct = 0.0;   // advance_lags + delayed_angle over the reference's arrays: max |dy|
  double runtime = 0.0;  // Predictor outputs vs the reference's coefficient: max |dC|
};

DelayedErrors max_delayed_errors(double delay_s, double dt_s) {
  const auto rt_model = delayed_model_one(delay_s);
  const TruthModel truth = indicial::to_truth_model(rt_model);
  const indicial::SimulatedRun ref = indicial::simulate_reference(truth, sine_30(dt_s));
  const auto& cm = truth.coefficients[0];
  const int n = static_cast<int>(ref.time_s.size());
  const indicial::ArrayHistory<double> h{ref.time_s.data(), ref.x_rad.data(), n};
  DelayedErrors e;
  double y[FitCapacity::max_lags] = {};
  for (int k = 0; k + 1 < n; ++k) {
    const auto kk = static_cast<std::size_t>(k);
    const indicial::StepGeometry<double> g{
        ref.x_rad[kk], ref.x_rad[kk + 1], indicial::delayed_angle(h, ref.time_s[kk], cm.delay_s),
        indicial::delayed_angle(h, ref.time_s[kk + 1], cm.delay_s), dt_s, 1.0};
    indicial::advance_lags(cm, g, y);
    e.direct = std::max(e.direct, std::abs(y[0] - ref.lag_states[0][0][kk + 1]));
  }
  indicial::Predictor<double> p;
  REQUIRE(p.load(rt_model) == indicial::LoadStatus::ok);
  REQUIRE(p.reset(ref.motion_angle_rad[0], rt_model.airspeed_mps) == indicial::StepStatus::ok);
  for (std::size_t k = 1; k < ref.time_s.size(); ++k) {
    indicial::Predictor<double>::Outputs out;
    REQUIRE(p.step({ref.motion_angle_rad[k], ref.rate_radps[k], rt_model.airspeed_mps}, dt_s, &out) ==
            indicial::StepStatus::ok);
    e.runtime = std::max(e.runtime, std::abs(out.value[0] - ref.coefficient_true[0][k]));
  }
  return e;
}

}  // namespace

TEST_CASE("delayed update (direct and runtime) converges to the reference at order 2") {
  // The forcing angle's interpolation error is x'' theta (1 - theta) dt^2 / 2 with theta the
  // fraction of a step by which t - delay falls between samples. A delay of 7/3 steps of
  // 8 ms has theta = 1/3 or 2/3 at 8, 4, 2 and 1 ms alike, so the error constant is the same
  // at every dt and the measured order is the method's (with another delay theta varies with
  // dt and blurs it). Never a multiple of a step: every forcing angle is interpolated.
  // Before t = delay the reference's forcing is at rest at x(0), like the runtime's reset.
  const double delay_s = 0.008 * 7.0 / 3.0;
  const double dts[] = {0.008, 0.004, 0.002, 0.001};
  DelayedErrors e[4];
  for (int i = 0; i < 4; ++i) e[i] = max_delayed_errors(delay_s, dts[i]);
  std::printf("delayed (%.6f s) update vs reference, Model I, alpha = 30 - 29 cos(2 pi t) deg\n", delay_s);
  std::printf("  dt_s      direct max|y err|  order   runtime max|C err|  order\n");
  for (int i = 0; i < 4; ++i) {
    if (i == 0) {
      std::printf("  %-8.4g  %.4e                 %.4e\n", dts[i], e[i].direct, e[i].runtime);
    } else {
      std::printf("  %-8.4g  %.4e        %.3f    %.4e         %.3f\n", dts[i], e[i].direct,
                  std::log2(e[i - 1].direct / e[i].direct), e[i].runtime,
                  std::log2(e[i - 1].runtime / e[i].runtime));
    }
  }
  // At 1 ms: the forcing angle's interpolation error is at most x'' (2/9) dt^2 / 2 =
  // 20 rad/s^2 * 1.1e-7 s^2 = 2.2e-6 rad here (x'' = 29 deg * (2 pi)^2), times |a(x)| < 1.
  CHECK(e[3].direct < 2e-6);
  CHECK(e[3].runtime < 2e-6);
  for (int i = 1; i < 4; ++i) {
    CHECK(std::log2(e[i - 1].direct / e[i].direct) >= 1.9);
    CHECK(std::log2(e[i - 1].runtime / e[i].runtime) >= 1.9);
  }
  // The delay is really exercised: the same update without it is far off the delayed truth.
  const TruthModel truth = indicial::to_truth_model(delayed_model_one(delay_s));
  const indicial::SimulatedRun ref = indicial::simulate_reference(truth, sine_30(0.001));
  double y[FitCapacity::max_lags] = {};
  double undelayed_err = 0.0;
  for (std::size_t k = 0; k + 1 < ref.time_s.size(); ++k) {
    const indicial::StepGeometry<double> g{ref.x_rad[k], ref.x_rad[k + 1], ref.x_rad[k],
                                           ref.x_rad[k + 1], 0.001, 1.0};
    indicial::advance_lags(truth.coefficients[0], g, y);
    undelayed_err = std::max(undelayed_err, std::abs(y[0] - ref.lag_states[0][0][k + 1]));
  }
  std::printf("  ignoring the delay at 1 ms: max|y err| = %.4e\n", undelayed_err);
  CHECK(undelayed_err > 1000 * e[3].direct);
}

TEST_CASE("autodiff d y / d delay through a delayed run matches central finite differences") {
  // What the fitter needs to estimate the delay: the sensitivity of the simulated lag state
  // with respect to delay_s, through delayed_angle and advance_lags over 500 steps.
  using AD = Eigen::AutoDiffScalar<Eigen::Matrix<double, 1, 1>>;
  const TruthModel truth = indicial::to_truth_model(delayed_model_one(0.0));
  const indicial::SimulatedRun ref = indicial::simulate_reference(truth, sine_30(0.002));
  const int n = 500;
  const indicial::ArrayHistory<double> h{ref.time_s.data(), ref.x_rad.data(), n + 1};
  auto run = [&](auto delay) {
    using S = decltype(delay);
    const auto& src = truth.coefficients[0];
    indicial::CoefficientModel<S, FitCapacity> m;
    auto copy = [](const auto& from, auto& to) {
      to.n_powers = from.n_powers;
      to.n_knots = from.n_knots;
      for (int i = 0; i < from.n_powers; ++i) to.power_coef[i] = S(from.power_coef[i]);
      for (int j = 0; j < from.n_knots; ++j) {
        to.knot_rad[j] = from.knot_rad[j];
        to.knot_power[j] = from.knot_power[j];
        to.knot_coef[j] = S(from.knot_coef[j]);
      }
    };
    copy(src.a, m.a);
    copy(src.lags[0].b, m.lags[0].b);
    m.n_lags = 1;
    m.con = S(0.0);
    m.delay_s = delay;
    S y[FitCapacity::max_lags] = {S(0.0)};
    for (int k = 0; k < n; ++k) {
      const auto kk = static_cast<std::size_t>(k);
      const indicial::StepGeometry<S> g{S(ref.x_rad[kk]), S(ref.x_rad[kk + 1]),
                                        indicial::delayed_angle(h, ref.time_s[kk], m.delay_s),
                                        indicial::delayed_angle(h, ref.time_s[kk + 1], m.delay_s),
                                        S(0.002), S(1.0)};
      indicial::advance_lags(m, g, y);
    }
    return y[0];
  };
  // None a multiple of the 2 ms step: at a multiple the run is kinked in the delay (AD
  // gives the one-sided derivative there, central differences the average).
  for (double d : {0.0237, 0.0517, 0.1111}) {
    const AD ya = run(AD(d, Eigen::Matrix<double, 1, 1>::Constant(1.0)));
    const double hh = 1e-7;
    const double fd = (run(d + hh) - run(d - hh)) / (2 * hh);
    INFO("delay " << d << ": ad " << ya.derivatives()(0) << ", fd " << fd);
    CHECK(ya.value() == doctest::Approx(run(d)).epsilon(1e-14));
    CHECK(std::abs(ya.derivatives()(0)) > 1e-3);  // a real sensitivity
    CHECK(std::abs(ya.derivatives()(0) - fd) <= 1e-6 * std::abs(fd));
  }
}
