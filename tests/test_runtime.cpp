// The embedded runtime (Predictor): it adds nothing to the model equations, keeps its state
// on bad input, clamps and flags, replays bit for bit and scales with airspeed.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using Set = indicial::ModelSet<double, indicial::DefaultCapacity>;
using P = indicial::Predictor<double>;
using indicial::LoadStatus;
using indicial::StepStatus;

using indicial::testing::kPi;

// The report's Example 1 motion: alpha = 35 deg + 35 deg sin(2 pi f t).
double alpha_at(double t_s, double f_hz) {
  return (35.0 + 35.0 * std::sin(2.0 * kPi * f_hz * t_s)) * kPi / 180.0;
}
double q_at(double t_s, double f_hz) {
  return 35.0 * kPi / 180.0 * 2.0 * kPi * f_hz * std::cos(2.0 * kPi * f_hz * t_s);
}

bool same_bytes(const P::Snapshot& a, const P::Snapshot& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

std::string text_of(const Set& m) {
  char buffer[16384];
  std::size_t n = 0;
  REQUIRE(indicial::write_coef_file(m, buffer, sizeof buffer, &n) == indicial::WriteStatus::ok);
  return std::string(buffer, n);
}

}  // namespace

// Sum of the member sizes of a Snapshot (a DelayedState): the State's Scalars (lag states,
// cached step ends, previous angle, airspeed terms) and ints, the FamilyState's dynamic-stall
// states, then the ring's doubles (time,
// delay cache, history times), Scalars (history angles) and ints.
template <class Pred, class Cap>
std::size_t snapshot_member_bytes() {
  using S = typename Pred::Snapshot;
  using Scalar = decltype(S{}.model_x_prev_rad);
  const std::size_t state_scalars = Cap::max_coefficients * Cap::max_lags +
                                    Cap::max_coefficients * (1 + Cap::max_lags) + 4;  // x, V, V/V_ref, l/V
  const std::size_t doubles = 2 + Cap::max_coefficients + Cap::max_delay_samples;
  const std::size_t family_scalars = Cap::max_coefficients * (sizeof(indicial::StallState<Scalar>) / sizeof(Scalar));
  return state_scalars * sizeof(Scalar) + sizeof(int) + sizeof(S{}.reserved) +
         family_scalars * sizeof(Scalar) +
         doubles * sizeof(double) + Cap::max_delay_samples * sizeof(Scalar) + 3 * sizeof(int) +
         sizeof(S{}.history_reserved);
}

// Steps a float and a double predictor of the same model over `steps` samples of the
// 1 Hz test motion at 100 Hz; the largest |float - double| of the two outputs.
template <class PredictorF, class PredictorD>
double max_float_double_difference(PredictorF& pf, PredictorD& pd, int steps) {
  double max_diff = 0.0;
  for (int k = 1; k <= steps; ++k) {
    typename PredictorF::Outputs of;
    typename PredictorD::Outputs od;
    REQUIRE(pf.step({alpha_at(0.01 * k, 1.0), q_at(0.01 * k, 1.0), 17.667762}, 0.01, &of) == StepStatus::ok);
    REQUIRE(pd.step({alpha_at(0.01 * k, 1.0), q_at(0.01 * k, 1.0), 17.667762}, 0.01, &od) == StepStatus::ok);
    for (int c = 0; c < 2; ++c) max_diff = std::fmax(max_diff, std::fabs(double(of.value[c]) - od.value[c]));
  }
  return max_diff;
}

TEST_CASE("Snapshot has no padding bytes (bytewise comparison is meaningful)") {
  static_assert(std::is_trivially_copyable<P::Snapshot>::value, "snapshot must be plain data");
  using Small = indicial::Capacity<8, 8, 2, 64, 3, 16>;
  using Odd = indicial::Capacity<4, 4, 3, 16, 1, 7>;
  CHECK(sizeof(P::Snapshot) == snapshot_member_bytes<P, indicial::DefaultCapacity>());
  CHECK(sizeof(indicial::Predictor<float>::Snapshot) ==
        snapshot_member_bytes<indicial::Predictor<float>, indicial::DefaultCapacity>());
  CHECK(sizeof(indicial::Predictor<double, Small>::Snapshot) ==
        snapshot_member_bytes<indicial::Predictor<double, Small>, Small>());
  CHECK(sizeof(indicial::Predictor<float, Small>::Snapshot) ==
        snapshot_member_bytes<indicial::Predictor<float, Small>, Small>());
  CHECK(sizeof(indicial::Predictor<double, Odd>::Snapshot) ==
        snapshot_member_bytes<indicial::Predictor<double, Odd>, Odd>());
  CHECK(sizeof(indicial::Predictor<float, Odd>::Snapshot) ==
        snapshot_member_bytes<indicial::Predictor<float, Odd>, Odd>());
  MESSAGE("sizeof(Predictor<double>::Snapshot) = ", sizeof(P::Snapshot), " bytes");
  // The per-instance state without a delay ring: issue 15's target is <= 256 bytes for
  // Model II C_L + C_m in double (DefaultCapacity holds up to 3 coefficients and 2 lags).
  static_assert(sizeof(indicial::State<double, indicial::DefaultCapacity>) <= 256, "state size");
  static_assert(std::is_trivially_copyable<indicial::State<float, indicial::DefaultCapacity>>::value,
                "state must be plain data");
  MESSAGE("sizeof(State<double>) = ", sizeof(indicial::State<double, indicial::DefaultCapacity>),
          ", sizeof(State<float>) = ", sizeof(indicial::State<float, indicial::DefaultCapacity>));
  // The five-parameter form still names a capacity (MaxDelaySamples defaults to 256).
  static_assert(indicial::Capacity<8, 8, 2, 64, 3>::max_delay_samples == 256, "default");
  static_assert(std::is_same<indicial::DefaultCapacity, indicial::Capacity<8, 8, 2, 64, 3, 256>>::value,
                "DefaultCapacity keeps its five listed limits");
}

TEST_CASE("step equals a direct loop over indicial::advance_lags, bit for bit") {
  const Set models[3] = {indicial::test_models::table_one_model_two(),
                         indicial::test_models::lift_and_moment(),
                         indicial::test_models::roll_three()};
  for (const Set& m : models) {
    P p;
    REQUIRE(p.load(text_of(m).data(), text_of(m).size()) == LoadStatus::ok);
    Set direct = m;  // the parsed/prepared form the runtime uses
    for (int c = 0; c < direct.n_coefficients; ++c)
      if (direct.coefficients[c].static_curve.kind == indicial::StaticKind::table)
        indicial::prepare_static_table(direct.coefficients[c].static_curve);
    const double dt_s = 0.01;
    const double f_hz = 0.5;
    const double v_mps = m.airspeed_mps * 1.3;  // away from V_ref so the scaling is exercised
    // Roll: small phi so that beta stays inside the envelope; pitch: the report's motion.
    auto angle = [&](double t) {
      return m.axis == indicial::Axis::pitch ? alpha_at(t, f_hz) : 0.6 * std::sin(2 * kPi * f_hz * t);
    };
    auto rate = [&](double t) {
      return m.axis == indicial::Axis::pitch ? q_at(t, f_hz) : 0.6 * 2 * kPi * f_hz * std::cos(2 * kPi * f_hz * t);
    };
    REQUIRE(p.reset(angle(0.0), v_mps) == StepStatus::ok);
    double y[3][2] = {};
    double x_prev = indicial::model_angle(m.axis, m.alpha0_rad, angle(0.0));
    for (int c = 0; c < m.n_coefficients; ++c) indicial::steady_state(direct.coefficients[c], x_prev, y[c]);
    int compared = 0;
    for (int k = 1; k <= 600; ++k) {
      const double t = k * dt_s;
      P::Outputs out;
      const StepStatus s = p.step({angle(t), rate(t), v_mps}, dt_s, &out);
      REQUIRE(s == StepStatus::ok);
      REQUIRE(out.count == m.n_coefficients);
      const double x1 = indicial::model_angle(m.axis, m.alpha0_rad, angle(t));
      const indicial::StepGeometry<double> g{x_prev, x1, x_prev, x1, dt_s, v_mps / m.airspeed_mps};
      for (int c = 0; c < m.n_coefficients; ++c) {
        indicial::advance_lags(direct.coefficients[c], g, y[c]);
        const double expected = indicial::coefficient_output(
            direct.coefficients[c], x1, rate(t), m.reference_length_m / v_mps, y[c]);
        CHECK(out.value[c] == expected);
        CHECK(std::string(out.name[c]) == std::string(m.coefficients[c].name));
        ++compared;
      }
      x_prev = x1;
    }
    CHECK(compared == 600 * m.n_coefficients);
  }
}

TEST_CASE("outputs come in file order: CL and Cm together, CY Cl Cn together") {
  P p;
  REQUIRE(p.load(indicial::test_models::lift_and_moment()) == LoadStatus::ok);
  REQUIRE(p.reset(0.3, 17.667762) == StepStatus::ok);
  P::Outputs out;
  REQUIRE(p.step({0.31, 1.0, 17.667762}, 0.01, &out) == StepStatus::ok);
  REQUIRE(out.count == 2);
  CHECK(std::string(out.name[0]) == "CL");
  CHECK(std::string(out.name[1]) == "Cm");
  REQUIRE(p.load(indicial::test_models::roll_three()) == LoadStatus::ok);
  REQUIRE(p.reset(0.1, 20.0) == StepStatus::ok);
  REQUIRE(p.step({0.11, 1.0, 20.0}, 0.01, &out) == StepStatus::ok);
  REQUIRE(out.count == 3);
  CHECK(std::string(out.name[0]) == "CY");
  CHECK(std::string(out.name[1]) == "Cl");
  CHECK(std::string(out.name[2]) == "Cn");
}

TEST_CASE("reset sets the steady state, holding the angle keeps it") {
  Set m = indicial::test_models::lift_and_moment();  // CL has con = 0.125 and b1(x) = 4 - 1.5 x
  P p;
  REQUIRE(p.load(m) == LoadStatus::ok);
  const double alpha = 0.6;
  REQUIRE(p.reset(alpha, 17.667762) == StepStatus::ok);
  const P::Snapshot s = p.snapshot();
  CHECK(s.y[0][0] == doctest::Approx(0.125 / (4.0 - 1.5 * alpha)).epsilon(1e-15));
  CHECK(s.y[0][1] == 0.0);
  CHECK(s.y[1][0] == 0.0);  // Cm has no bias
  CHECK(s.model_x_prev_rad == alpha);
  CHECK(indicial::clamped_previous_angle_rad(p.runtime(), s) == alpha);
  // At rest (same angle, zero rate) the state stays at its steady value and the output is
  // static + steady lag state, at any airspeed.
  P::Outputs out;
  for (int k = 0; k < 100; ++k) REQUIRE(p.step({alpha, 0.0, 40.0}, 0.01, &out) == StepStatus::ok);
  const double cl_static = indicial::static_value(p.model().coefficients[0].static_curve, alpha);
  CHECK(out.value[0] == doctest::Approx(cl_static + 0.125 / (4.0 - 1.5 * alpha)).epsilon(1e-13));
  const double cm_static = 0.42 * alpha + 0.34 * alpha * alpha - std::pow(alpha, 3) + 0.4 * std::pow(alpha, 4);
  CHECK(out.value[1] == doctest::Approx(cm_static).epsilon(1e-13));
}

TEST_CASE("bad inputs return their own status and leave state and outputs untouched") {
  P p;
  P::Outputs out;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  CHECK(p.step({0.1, 0.0, 17.0}, 0.01, &out) == StepStatus::not_loaded);
  CHECK(p.reset(0.1, 17.0) == StepStatus::not_loaded);
  CHECK(p.phase() == indicial::PredictorPhase::empty);
  REQUIRE(p.load(indicial::test_models::lift_and_moment()) == LoadStatus::ok);
  CHECK(p.phase() == indicial::PredictorPhase::loaded);
  CHECK(p.step({0.1, 0.0, 17.0}, 0.01, &out) == StepStatus::not_reset);
  REQUIRE(p.reset(0.2, 17.0) == StepStatus::ok);
  for (int k = 1; k <= 50; ++k) REQUIRE(p.step({alpha_at(0.01 * k, 1.0), q_at(0.01 * k, 1.0), 17.0}, 0.01, &out) == StepStatus::ok);
  const P::Snapshot before = p.snapshot();
  const P::Outputs out_before = out;

  struct Case {
    indicial::MotionInput in;
    double dt_s;
    StepStatus expected;
  };
  const Case cases[] = {
      {{nan, 0.0, 17.0}, 0.01, StepStatus::non_finite_input},
      {{inf, 0.0, 17.0}, 0.01, StepStatus::non_finite_input},
      {{0.3, nan, 17.0}, 0.01, StepStatus::non_finite_input},
      {{0.3, -inf, 17.0}, 0.01, StepStatus::non_finite_input},
      {{0.3, 0.0, nan}, 0.01, StepStatus::non_finite_input},
      {{0.3, 0.0, inf}, 0.01, StepStatus::non_finite_input},
      {{0.3, 0.0, 17.0}, nan, StepStatus::non_finite_input},
      {{0.3, 0.0, 17.0}, inf, StepStatus::non_finite_input},
      {{0.3, 0.0, 17.0}, 0.0, StepStatus::non_positive_dt},
      {{0.3, 0.0, 17.0}, -0.01, StepStatus::non_positive_dt},
      {{0.3, 0.0, 17.0}, 1.5, StepStatus::dt_too_large},
      {{0.3, 0.0, 0.0}, 0.01, StepStatus::non_positive_airspeed},
      {{0.3, 0.0, -17.0}, 0.01, StepStatus::non_positive_airspeed},
      // Finite but absurd: l / V overflows the rotary term to Inf.
      {{0.3, 1e300, 1e-300}, 0.01, StepStatus::non_finite_result},
  };
  for (const Case& c : cases) {
    P::Outputs o = out_before;
    CHECK(p.step(c.in, c.dt_s, &o) == c.expected);
    CHECK(same_bytes(p.snapshot(), before));
    CHECK(std::memcmp(&o, &out_before, sizeof o) == 0);
  }
  CHECK(p.step({0.3, 0.0, 17.0}, 0.01, nullptr) == StepStatus::null_output);
  CHECK(same_bytes(p.snapshot(), before));
  CHECK(p.reset(nan, 17.0) == StepStatus::non_finite_input);
  CHECK(p.reset(0.3, 0.0) == StepStatus::non_positive_airspeed);
  CHECK(same_bytes(p.snapshot(), before));
  // dt exactly at the maximum is accepted.
  CHECK(p.step({0.3, 0.0, 17.0}, P::max_dt_s, &out) == StepStatus::ok);
  CHECK(std::isfinite(out.value[0]));
}

TEST_CASE("a refused load keeps the previous model and state") {
  P p;
  REQUIRE(p.load(indicial::test_models::table_one_model_two()) == LoadStatus::ok);
  REQUIRE(p.reset(0.5, 17.667762) == StepStatus::ok);
  const P::Snapshot before = p.snapshot();
  std::string text = text_of(indicial::test_models::table_one_model_one());
  text[text.find("0.42")] = '7';  // corrupt
  indicial::ParseDiagnostic diag;
  CHECK(p.load(text.data(), text.size(), &diag) == LoadStatus::checksum_mismatch);
  CHECK(diag.line > 0);
  CHECK(same_bytes(p.snapshot(), before));
  CHECK(p.model().coefficients[0].lags[0].b.n_knots == 4);  // still Model II
}

TEST_CASE("validation refuses unstable lags and non-finite models") {
  P p;
  Set m = indicial::test_models::table_one_model_two();
  m.coefficients[0].lags[0].b.knot_coef[0] = -20.0;  // b1 dips below zero after 0.349 rad
  indicial::ParseDiagnostic diag;
  CHECK(p.load(m, &diag) == LoadStatus::unstable_lag);
  CHECK(p.load(text_of(m).data(), text_of(m).size()) == LoadStatus::unstable_lag);
  m = indicial::test_models::table_one_model_one();
  m.coefficients[0].lags[0].b.power_coef[0] = 0.0;  // b1 = 0: no decay
  CHECK(p.load(m) == LoadStatus::unstable_lag);
  // b dips to exactly zero only between samples? A step (power 0 knot) makes it negative on
  // a narrow range that the knot check catches.
  m = indicial::test_models::table_one_model_one();
  m.coefficients[0].lags[0].b.n_knots = 2;
  m.coefficients[0].lags[0].b.knot_rad[0] = 0.50000001;
  m.coefficients[0].lags[0].b.knot_power[0] = 0;
  m.coefficients[0].lags[0].b.knot_coef[0] = -3.0;
  m.coefficients[0].lags[0].b.knot_rad[1] = 0.50000002;
  m.coefficients[0].lags[0].b.knot_power[1] = 0;
  m.coefficients[0].lags[0].b.knot_coef[1] = 3.0;
  CHECK(p.load(m) == LoadStatus::unstable_lag);
  m = indicial::test_models::table_one_model_one();
  m.coefficients[0].a.power_coef[2] = std::numeric_limits<double>::infinity();
  CHECK(p.load(m) == LoadStatus::invalid_value);
  m = indicial::test_models::table_one_model_one();
  m.coefficients[0].delay_s = -0.02;
  CHECK(p.load(m) == LoadStatus::invalid_value);
  m.coefficients[0].delay_s = std::numeric_limits<double>::infinity();
  CHECK(p.load(m) == LoadStatus::invalid_value);
  // Longer than (256 - 2) steps of max_dt_s: no step at V_ref could ever serve it.
  m.coefficients[0].delay_s = 254.5;
  CHECK(p.load(m, &diag) == LoadStatus::over_capacity);
  CHECK(p.phase() == indicial::PredictorPhase::empty);
  m.coefficients[0].delay_s = 254.0;  // the longest a 1 s step could serve
  CHECK(p.load(m) == LoadStatus::ok);
  P empty;
  CHECK(empty.phase() == indicial::PredictorPhase::empty);
  // Float: a coefficient beyond float's range is refused.
  indicial::Predictor<float> pf;
  m = indicial::test_models::table_one_model_one();
  m.coefficients[0].rotary.power_coef[1] = 1e60;
  CHECK(pf.load(m) == LoadStatus::invalid_value);
}

TEST_CASE("angles outside the envelope are clamped and flagged, outputs still produced") {
  P p;
  REQUIRE(p.load(indicial::test_models::table_one_model_two()) == LoadStatus::ok);
  const double x_max = p.model().x_max_rad;
  CHECK(p.reset(x_max + 0.2, 17.667762) == StepStatus::angle_clamped);
  // The state keeps the angle itself; the splines' angle is its clamp (clamped_previous_angle_rad).
  CHECK(p.snapshot().model_x_prev_rad == x_max + 0.2);
  CHECK(indicial::clamped_previous_angle_rad(p.runtime(), p.snapshot()) == x_max);
  P::Outputs out;
  CHECK(p.step({x_max + 0.3, 0.5, 17.667762}, 0.01, &out) == StepStatus::angle_clamped);
  P q;
  REQUIRE(q.load(indicial::test_models::table_one_model_two()) == LoadStatus::ok);
  REQUIRE(q.reset(x_max, 17.667762) == StepStatus::ok);
  P::Outputs at_edge;
  CHECK(q.step({x_max, 0.5, 17.667762}, 0.01, &at_edge) == StepStatus::ok);
  CHECK(out.value[0] == at_edge.value[0]);  // same as the clamped angle with the same rate
  CHECK(p.step({-0.5, 0.0, 17.667762}, 0.01, &out) == StepStatus::angle_clamped);
  CHECK(p.snapshot().model_x_prev_rad == -0.5);
  CHECK(indicial::clamped_previous_angle_rad(p.runtime(), p.snapshot()) == 0.0);
  CHECK(std::isfinite(out.value[0]));
  CHECK(p.step({0.5, 0.0, 17.667762}, 0.01, &out) == StepStatus::ok);
}

TEST_CASE("outside the envelope: a static table at the true angle, the unsteady term held at the edge") {
  // CL's static table covers 0..70 deg; the envelope (the training data) only 0..30 deg.
  Set set = indicial::test_models::lift_and_moment();
  set.x_min_rad = 0.0;
  set.x_max_rad = 30 * kPi / 180;
  const double v = 17.667762, x45 = 45 * kPi / 180;
  P p, edge;
  REQUIRE(p.load(set) == LoadStatus::ok);
  REQUIRE(edge.load(set) == LoadStatus::ok);
  CHECK(p.reset(x45, v) == StepStatus::angle_clamped);
  REQUIRE(edge.reset(set.x_max_rad, v) == StepStatus::ok);
  P::Outputs out, at_edge;
  for (int k = 0; k < 400; ++k) {  // 4 s held at 45 deg: the lags settle at the edge's steady state
    REQUIRE(p.step({x45, 0.2, v}, 0.01, &out) == StepStatus::angle_clamped);
    REQUIRE(edge.step({set.x_max_rad, 0.2, v}, 0.01, &at_edge) == StepStatus::ok);
  }
  const auto& cl = p.model().coefficients[0];
  // CL: the table where the angle is, everything else as at the edge.
  const double table_gap = indicial::static_value(cl.static_curve, x45) -
                           indicial::static_value(cl.static_curve, set.x_max_rad);
  CHECK(table_gap < -0.1);  // past the stall peak: the frozen value would be 0.1+ too high
  CHECK(out.value[0] == doctest::Approx(at_edge.value[0] + table_gap).epsilon(1e-12));
  // Cm (a polynomial static curve, fitted): held at the edge like the unsteady term.
  CHECK(out.value[1] == doctest::Approx(at_edge.value[1]).epsilon(1e-12));
  // The lag state is the steady state at the edge: con / b1(edge).
  const double y_edge = cl.con / indicial::spline_value(cl.lags[0].b, set.x_max_rad);
  CHECK(p.snapshot().y[0][0] == doctest::Approx(y_edge).epsilon(1e-9));
  for (int c = 0; c < 2; ++c) CHECK(std::isfinite(out.value[c]));
  // Back inside: status ok and the model continues from the state it kept.
  CHECK(p.step({20 * kPi / 180, 0.0, v}, 0.01, &out) == StepStatus::ok);
}

TEST_CASE("snapshot / restore: replaying the same inputs reproduces the outputs bit for bit") {
  P p;
  REQUIRE(p.load(indicial::test_models::lift_and_moment()) == LoadStatus::ok);
  REQUIRE(p.reset(alpha_at(0.0, 1.0), 17.667762) == StepStatus::ok);
  P::Outputs out;
  for (int k = 1; k <= 137; ++k) REQUIRE(p.step({alpha_at(0.01 * k, 1.0), q_at(0.01 * k, 1.0), 17.667762}, 0.01, &out) == StepStatus::ok);
  const P::Snapshot mark = p.snapshot();
  static double first[1000][2];
  static double second[1000][2];
  for (int pass = 0; pass < 2; ++pass) {
    double (*dst)[2] = pass == 0 ? first : second;
    if (pass == 1) p.restore(mark);
    for (int k = 0; k < 1000; ++k) {
      const double t = 0.01 * (138 + k);
      const double v = 17.667762 * (1.0 + 0.2 * std::sin(0.37 * k));  // varying airspeed too
      REQUIRE(p.step({alpha_at(t, 1.0), q_at(t, 1.0), v}, 0.004 + 0.00001 * (k % 7), &out) == StepStatus::ok);
      dst[k][0] = out.value[0];
      dst[k][1] = out.value[1];
    }
  }
  CHECK(std::memcmp(first, second, sizeof first) == 0);
  // Restore into a fresh copy gives the same too, and a pre-reset snapshot restores the
  // not-reset phase.
  P fresh;
  REQUIRE(fresh.load(indicial::test_models::lift_and_moment()) == LoadStatus::ok);
  const P::Snapshot unreset = fresh.snapshot();
  fresh.restore(mark);
  CHECK(same_bytes(fresh.snapshot(), mark));
  fresh.restore(unreset);
  CHECK(fresh.step({0.3, 0.0, 17.0}, 0.01, &out) == StepStatus::not_reset);
}

TEST_CASE("airspeed scaling: at 2 V a motion twice as fast gives the same coefficients") {
  // Non-dimensional time s = V t / l: doubling V and halving every time interval (so the
  // rate doubles) leaves every sample of the response unchanged.
  const Set m = indicial::test_models::lift_and_moment();
  P slow;
  P fast;
  REQUIRE(slow.load(m) == LoadStatus::ok);
  REQUIRE(fast.load(m) == LoadStatus::ok);
  const double v = 15.0;
  REQUIRE(slow.reset(alpha_at(0.0, 0.5), v) == StepStatus::ok);
  REQUIRE(fast.reset(alpha_at(0.0, 1.0), 2 * v) == StepStatus::ok);
  double max_diff = 0.0;
  double max_lag = 0.0;
  for (int k = 1; k <= 800; ++k) {
    P::Outputs a;
    P::Outputs b;
    REQUIRE(slow.step({alpha_at(0.01 * k, 0.5), q_at(0.01 * k, 0.5), v}, 0.01, &a) == StepStatus::ok);
    REQUIRE(fast.step({alpha_at(0.005 * k, 1.0), q_at(0.005 * k, 1.0), 2 * v}, 0.005, &b) == StepStatus::ok);
    for (int c = 0; c < 2; ++c) max_diff = std::fmax(max_diff, std::fabs(a.value[c] - b.value[c]));
    max_lag = std::fmax(max_lag, std::fabs(slow.snapshot().y[1][0]));
  }
  MESSAGE("max |difference| = ", max_diff, ", max |Cm lag state| = ", max_lag);
  CHECK(max_lag > 0.01);  // the unsteady part is really exercised
  CHECK(max_diff < 1e-12);
  // And at 2 V with the SAME time history the response differs (time constants halve).
  P same;
  REQUIRE(same.load(m) == LoadStatus::ok);
  REQUIRE(same.reset(alpha_at(0.0, 0.5), 2 * v) == StepStatus::ok);
  REQUIRE(slow.reset(alpha_at(0.0, 0.5), v) == StepStatus::ok);
  double diff_same_time = 0.0;
  for (int k = 1; k <= 200; ++k) {
    P::Outputs a;
    P::Outputs b;
    REQUIRE(slow.step({alpha_at(0.01 * k, 0.5), 0.0, v}, 0.01, &a) == StepStatus::ok);
    REQUIRE(same.step({alpha_at(0.01 * k, 0.5), 0.0, 2 * v}, 0.01, &b) == StepStatus::ok);
    diff_same_time = std::fmax(diff_same_time, std::fabs(a.value[1] - b.value[1]));
  }
  CHECK(diff_same_time > 1e-3);
}

TEST_CASE("float instantiation runs and stays close to double") {
  indicial::Predictor<float> pf;
  P pd;
  const Set m = indicial::test_models::lift_and_moment();
  REQUIRE(pf.load(m) == LoadStatus::ok);
  REQUIRE(pd.load(m) == LoadStatus::ok);
  REQUIRE(pf.reset(alpha_at(0.0, 1.0), 17.667762) == StepStatus::ok);
  REQUIRE(pd.reset(alpha_at(0.0, 1.0), 17.667762) == StepStatus::ok);
  const double max_diff = max_float_double_difference(pf, pd, 300);
  MESSAGE("float vs double max |difference| = ", max_diff);
  CHECK(max_diff < 1e-5);
  CHECK(max_diff > 0.0);  // really computed in float
}

// The state keeps the angle itself; the angle its splines and lags were evaluated at is
// derived (clamped_previous_angle_rad): after every reset and step it must be the step's own
// clamp, bit for bit, inside, at and beyond the envelope's edges, -0 and huge angles included.
// Both clamps are detail::clamp_to_envelope; what can go wrong is the angle the state keeps
// (model_x_prev_rad against the step's model angle) and the status of the edges.
template <class Scalar>
void check_clamped_previous_angle() {
  indicial::Predictor<Scalar> p;
  REQUIRE(p.load(indicial::test_models::table_one_model_two()) == LoadStatus::ok);
  const double lo = double(p.runtime().x_min_rad), hi = double(p.runtime().x_max_rad);
  const double angles[] = {0.5 * (lo + hi), lo, hi, -0.0, lo - 0.3, hi + 0.3, 1e300, -1e300,
                           std::nextafter(hi, 10.0), std::nextafter(lo, -10.0), 0.1};
  REQUIRE(p.reset(angles[0], 20.0) == StepStatus::ok);
  typename indicial::Predictor<Scalar>::Outputs out;
  for (double a : angles) {
    INFO("angle ", a);
    const StepStatus st = p.step({a, 0.0, 20.0}, 0.01, &out);
    REQUIRE((st == StepStatus::ok || st == StepStatus::angle_clamped));
    const auto clamp = indicial::detail::clamp_model_angle(p.runtime(), a);
    CHECK(indicial::clamped_previous_angle_rad(p.runtime(), p.snapshot()) == clamp.x_rad);
    CHECK(std::signbit(indicial::clamped_previous_angle_rad(p.runtime(), p.snapshot())) == std::signbit(clamp.x_rad));
    CHECK(p.snapshot().model_x_prev_rad == clamp.model_x_rad);
    CHECK((st == StepStatus::angle_clamped) == (clamp.status == StepStatus::angle_clamped));
    REQUIRE(p.reset(a, 20.0) == clamp.status);
    CHECK(indicial::clamped_previous_angle_rad(p.runtime(), p.snapshot()) == clamp.x_rad);
  }
}

TEST_CASE("the clamped previous angle is the step's clamp, bit for bit, in double and float") {
  check_clamped_previous_angle<double>();
  check_clamped_previous_angle<float>();
}

TEST_CASE("roll and yaw use the model angle transforms") {
  P p;
  Set m = indicial::test_models::roll_three();
  REQUIRE(p.load(m) == LoadStatus::ok);
  const double phi = 0.4;
  REQUIRE(p.reset(phi, 20.0) == StepStatus::ok);
  CHECK(p.snapshot().model_x_prev_rad == std::asin(std::sin(phi) * std::sin(m.alpha0_rad)));
  CHECK(indicial::clamped_previous_angle_rad(p.runtime(), p.snapshot()) ==
        indicial::detail::clamp_model_angle(p.runtime(), phi).x_rad);
  m.axis = indicial::Axis::yaw;
  REQUIRE(p.load(m) == LoadStatus::ok);
  const double psi = 0.3;
  REQUIRE(p.reset(psi, 20.0) == StepStatus::ok);
  CHECK(p.snapshot().model_x_prev_rad == std::asin(-std::sin(psi) * std::cos(m.alpha0_rad)));
  CHECK(indicial::clamped_previous_angle_rad(p.runtime(), p.snapshot()) ==
        indicial::detail::clamp_model_angle(p.runtime(), psi).x_rad);
}

TEST_CASE("to_string names every status") {
  CHECK(std::string(indicial::to_string(StepStatus::dt_too_large)) == "dt_too_large");
  CHECK(std::string(indicial::to_string(StepStatus::angle_clamped)) == "angle_clamped");
  CHECK(std::string(indicial::to_string(LoadStatus::unstable_lag)) == "unstable_lag");
  CHECK(std::string(indicial::to_string(StepStatus::delay_exceeds_history)) == "delay_exceeds_history");
}

// ==========================================================================================
// Delayed forcing (CoefficientModel::delay_s)
// ==========================================================================================
namespace {

// Lift and moment with CL's forcing delayed by delay_cl_s and Cm's by delay_cm_s.
Set delayed_lift_and_moment(double delay_cl_s, double delay_cm_s) {
  Set m = indicial::test_models::lift_and_moment();
  m.coefficients[0].delay_s = delay_cl_s;
  m.coefficients[1].delay_s = delay_cm_s;
  return m;
}

}  // namespace

TEST_CASE("delayed step equals a direct loop over advance_lags with delayed_angle over arrays") {
  // What the fitter will do (ArrayHistory over a run's arrays) and what the runtime does (its
  // ring) must give the same bits: same function, same times, same angles. Varying dt and
  // airspeed, 900 steps, so the 256-sample ring wraps and the delay (scaled by V_ref / V)
  // lands between samples.
  const Set m = delayed_lift_and_moment(0.0237, 0.05);
  P p;
  REQUIRE(p.load(text_of(m).data(), text_of(m).size()) == LoadStatus::ok);
  Set direct = m;
  indicial::prepare_static_table(direct.coefficients[0].static_curve);
  const int n = 900;
  static double t[n + 1];
  static double x[n + 1];
  double y[2][2] = {};
  x[0] = alpha_at(0.0, 1.0);
  t[0] = 0.0;
  REQUIRE(p.reset(x[0], 17.667762) == StepStatus::ok);
  for (int c = 0; c < 2; ++c) indicial::steady_state(direct.coefficients[c], x[0], y[c]);
  double physical_t = 0.0;
  int compared = 0;
  for (int k = 1; k <= n; ++k) {
    const double dt = 0.004 + 0.0003 * (k % 5);
    const double v = 17.667762 * (1.0 + 0.25 * std::sin(0.01 * k));
    physical_t += dt;
    t[k] = t[k - 1] + dt;  // the runtime accumulates its clock the same way
    x[k] = alpha_at(physical_t, 1.0);
    P::Outputs out;
    REQUIRE(p.step({x[k], q_at(physical_t, 1.0), v}, dt, &out) == StepStatus::ok);
    const indicial::ArrayHistory<double> h{t, x, k + 1};
    for (int c = 0; c < 2; ++c) {
      const auto& cm = direct.coefficients[c];
      const double d = indicial::delay_at_airspeed(cm.delay_s, m.airspeed_mps, v);
      const indicial::StepGeometry<double> g{x[k - 1], x[k], indicial::delayed_angle(h, t[k - 1], d),
                                             indicial::delayed_angle(h, t[k], d), dt,
                                             v / m.airspeed_mps};
      indicial::advance_lags(cm, g, y[c]);
      const double expected = indicial::coefficient_output(cm, x[k], q_at(physical_t, 1.0),
                                                           m.reference_length_m / v, y[c]);
      CHECK(out.value[c] == expected);
      ++compared;
    }
  }
  CHECK(compared == 2 * n);
  CHECK(p.snapshot().history_origin == static_cast<int>(indicial::HistoryOrigin::samples_dropped));
}

TEST_CASE("a delayed model sees the reset angle until the delay has passed") {
  // Reset at rest at x0, then move: with a delay d the forcing sees x0 for t <= d, so the lag
  // states stay at their steady values (0 for Cm, no bias) exactly; just after d they move.
  const double d = 0.05;
  const Set m = delayed_lift_and_moment(0.0, d);
  P p;
  REQUIRE(p.load(m) == LoadStatus::ok);
  REQUIRE(p.reset(0.3, 17.667762) == StepStatus::ok);
  const double cl_steady = p.snapshot().y[0][0];
  P::Outputs out;
  // t = 0.01 .. 0.04 < d: at rest for the forcing. (t = 0.05 = d is left out: the clock's
  // rounding decides which side of the reset sample it lands on.)
  for (int k = 1; k <= 4; ++k) {
    REQUIRE(p.step({0.3 + 0.2 * k * 0.01, 0.2, 17.667762}, 0.01, &out) == StepStatus::ok);
    CHECK(p.snapshot().y[1][0] == 0.0);
    CHECK(p.snapshot().y[0][0] != cl_steady);  // CL (undelayed) moves at once
  }
  for (int k = 5; k <= 6; ++k)
    REQUIRE(p.step({0.3 + 0.2 * k * 0.01, 0.2, 17.667762}, 0.01, &out) == StepStatus::ok);
  CHECK(p.snapshot().y[1][0] != 0.0);
  // At twice the airspeed the delay halves: 0.025 s.
  REQUIRE(p.reset(0.3, 2 * 17.667762) == StepStatus::ok);
  for (int i = 1; i <= 2; ++i) {
    REQUIRE(p.step({0.3 + 0.2 * i * 0.01, 0.2, 2 * 17.667762}, 0.01, &out) == StepStatus::ok);
    CHECK(p.snapshot().y[1][0] == 0.0);
  }
  REQUIRE(p.step({0.3 + 0.2 * 0.03, 0.2, 2 * 17.667762}, 0.01, &out) == StepStatus::ok);
  CHECK(p.snapshot().y[1][0] != 0.0);
}

TEST_CASE("a delay longer than the history: delay_exceeds_history, nothing changed") {
  using Small = indicial::Capacity<8, 8, 2, 64, 3, 16>;
  using PS = indicial::Predictor<double, Small>;
  // The same file, loaded with a 16-sample history (Cm delayed by 0.2 s).
  const std::string text = text_of(delayed_lift_and_moment(0.0, 0.2));
  PS p;
  CHECK(p.history_samples_needed(0.01, 17.0) == 0);  // nothing loaded
  REQUIRE(p.load(text.data(), text.size()) == LoadStatus::ok);
  CHECK(PS::history_capacity == 16);
  const double v = p.model().airspeed_mps;
  // 0.2 s at 10 ms is 20 steps: 2 + 20 samples, plus the spare one at an exact multiple.
  CHECK(p.history_samples_needed(0.01, v) == 23);
  CHECK(p.history_samples_needed(0.02, v) == 13);
  CHECK(p.history_samples_needed(0.0213, v) == 12);  // 9.4 steps -> 10
  CHECK(p.history_samples_needed(0.0143, v) == 16);  // 13.99 steps -> 14
  CHECK(p.history_samples_needed(0.02, 2 * v) == 8);  // 2 V: 0.1 s
  CHECK(p.history_samples_needed(0.0, v) == 0);
  CHECK(p.history_samples_needed(1e-9, v) == 2 + 200000001);  // exact multiple: + 1
  CHECK(p.history_samples_needed(1e-12, v) == std::numeric_limits<int>::max());  // saturated
  REQUIRE(p.reset(0.4, v) == StepStatus::ok);
  PS::Outputs out;
  // Until the ring wraps, the reset (rest) sample serves any delay.
  int k = 1;
  for (; k <= 15; ++k) REQUIRE(p.step({0.4 + 0.01 * k, 1.0, v}, 0.01, &out) == StepStatus::ok);
  CHECK(p.snapshot().history_count == 16);
  const PS::Snapshot before = p.snapshot();
  const PS::Outputs out_before = out;
  CHECK(p.step({0.4 + 0.01 * k, 1.0, v}, 0.01, &out) == StepStatus::delay_exceeds_history);
  const PS::Snapshot after = p.snapshot();
  CHECK(std::memcmp(&before, &after, sizeof before) == 0);
  CHECK(std::memcmp(&out, &out_before, sizeof out) == 0);
  // Twice the airspeed halves the delay: 0.1 s fits in 14 steps of 10 ms.
  for (int i = 0; i < 40; ++i) REQUIRE(p.step({0.5, 0.0, 2 * v}, 0.01, &out) == StepStatus::ok);
  CHECK(p.snapshot().history_origin == static_cast<int>(indicial::HistoryOrigin::samples_dropped));
  CHECK(p.step({0.5, 0.0, v}, 0.01, &out) == StepStatus::delay_exceeds_history);
  // A new reset starts at rest again, and 14.3 ms steps need exactly the 16 samples held.
  REQUIRE(p.reset(0.4, v) == StepStatus::ok);
  for (int i = 1; i <= 100; ++i)
    REQUIRE(p.step({0.4 + 0.3 * std::sin(0.05 * i), 1.0, v}, 0.0143, &out) == StepStatus::ok);
  // ... and 10 ms steps at V again do not, once the ring has wrapped.
  REQUIRE(p.reset(0.4, v) == StepStatus::ok);
  int ok_steps = 0;
  while (p.step({0.45, 0.0, v}, 0.01, &out) == StepStatus::ok) ++ok_steps;
  CHECK(ok_steps == 15);
}

TEST_CASE("snapshot / restore with a delay replays bit for bit, the history included") {
  P p;
  REQUIRE(p.load(delayed_lift_and_moment(0.031, 0.0173)) == LoadStatus::ok);
  REQUIRE(p.reset(alpha_at(0.0, 1.0), 17.667762) == StepStatus::ok);
  P::Outputs out;
  for (int k = 1; k <= 300; ++k)  // past the ring's wrap (256)
    REQUIRE(p.step({alpha_at(0.004 * k, 1.0), q_at(0.004 * k, 1.0), 17.667762}, 0.004, &out) ==
            StepStatus::ok);
  const P::Snapshot mark = p.snapshot();
  CHECK(mark.history_count == P::history_capacity);
  static double first[700][2];
  static double second[700][2];
  for (int pass = 0; pass < 2; ++pass) {
    double (*dst)[2] = pass == 0 ? first : second;
    if (pass == 1) p.restore(mark);
    for (int k = 0; k < 700; ++k) {
      const double t = 1.2 + 0.004 * k;
      const double v = 17.667762 * (1.0 + 0.2 * std::sin(0.37 * k));
      REQUIRE(p.step({alpha_at(t, 1.0), q_at(t, 1.0), v}, 0.004 + 0.00001 * (k % 7), &out) ==
              StepStatus::ok);
      dst[k][0] = out.value[0];
      dst[k][1] = out.value[1];
    }
  }
  CHECK(std::memcmp(first, second, sizeof first) == 0);
  // The history matters: a predictor restored with the same lag states but a history of the
  // wrong angles gives different outputs.
  P other;
  REQUIRE(other.load(delayed_lift_and_moment(0.031, 0.0173)) == LoadStatus::ok);
  P::Snapshot altered = mark;
  for (int i = 0; i < P::history_capacity; ++i) altered.history_x_rad[i] += 0.01;
  other.restore(altered);
  p.restore(mark);
  P::Outputs a;
  P::Outputs b;
  REQUIRE(p.step({alpha_at(1.2, 1.0), q_at(1.2, 1.0), 17.667762}, 0.004, &a) == StepStatus::ok);
  REQUIRE(other.step({alpha_at(1.2, 1.0), q_at(1.2, 1.0), 17.667762}, 0.004, &b) == StepStatus::ok);
  CHECK(a.value[1] != b.value[1]);
}

TEST_CASE("airspeed scaling with a delay: at 2 V a motion twice as fast gives the same") {
  // The delay is in s at V_ref and scales by V_ref / V, like every time of the model.
  const Set m = delayed_lift_and_moment(0.0237, 0.05);
  P slow;
  P fast;
  REQUIRE(slow.load(m) == LoadStatus::ok);
  REQUIRE(fast.load(m) == LoadStatus::ok);
  const double v = m.airspeed_mps;
  REQUIRE(slow.reset(alpha_at(0.0, 0.5), v) == StepStatus::ok);
  REQUIRE(fast.reset(alpha_at(0.0, 1.0), 2 * v) == StepStatus::ok);
  double max_diff = 0.0;
  for (int k = 1; k <= 800; ++k) {
    P::Outputs a;
    P::Outputs b;
    REQUIRE(slow.step({alpha_at(0.01 * k, 0.5), q_at(0.01 * k, 0.5), v}, 0.01, &a) == StepStatus::ok);
    REQUIRE(fast.step({alpha_at(0.005 * k, 1.0), q_at(0.005 * k, 1.0), 2 * v}, 0.005, &b) == StepStatus::ok);
    for (int c = 0; c < 2; ++c) max_diff = std::fmax(max_diff, std::fabs(a.value[c] - b.value[c]));
  }
  MESSAGE("delayed, V vs 2 V: max |difference| = ", max_diff);
  CHECK(max_diff < 1e-12);
  // And the delay really acts: the same motion without delays differs.
  P undelayed;
  REQUIRE(undelayed.load(indicial::test_models::lift_and_moment()) == LoadStatus::ok);
  REQUIRE(undelayed.reset(alpha_at(0.0, 0.5), v) == StepStatus::ok);
  REQUIRE(slow.reset(alpha_at(0.0, 0.5), v) == StepStatus::ok);
  double diff_delay = 0.0;
  for (int k = 1; k <= 200; ++k) {
    P::Outputs a;
    P::Outputs b;
    REQUIRE(slow.step({alpha_at(0.01 * k, 0.5), q_at(0.01 * k, 0.5), v}, 0.01, &a) == StepStatus::ok);
    REQUIRE(undelayed.step({alpha_at(0.01 * k, 0.5), q_at(0.01 * k, 0.5), v}, 0.01, &b) == StepStatus::ok);
    diff_delay = std::fmax(diff_delay, std::fabs(a.value[1] - b.value[1]));
  }
  CHECK(diff_delay > 1e-3);
}

TEST_CASE("float predictor with a delay stays close to double") {
  indicial::Predictor<float> pf;
  P pd;
  const Set m = delayed_lift_and_moment(0.0237, 0.05);
  REQUIRE(pf.load(m) == LoadStatus::ok);
  REQUIRE(pd.load(m) == LoadStatus::ok);
  REQUIRE(pf.reset(alpha_at(0.0, 1.0), 17.667762) == StepStatus::ok);
  REQUIRE(pd.reset(alpha_at(0.0, 1.0), 17.667762) == StepStatus::ok);
  const double max_diff = max_float_double_difference(pf, pd, 1000);  // 10 s: the clock is double in both
  MESSAGE("delayed, float vs double max |difference| = ", max_diff);
  CHECK(max_diff < 1e-5);
}
