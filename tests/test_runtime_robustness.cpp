// tests/test_runtime_robustness.cpp -- the runtime Predictor under a long random stream of inputs.
//
// For each of four model sets (Table I Models I and II, a two-coefficient two-lag set with a
// static table and a bias, a three-coefficient roll set) and for double and float, a fixed-seed
// stream of steps with random finite inputs across and far beyond the envelope (angles, rates
// and airspeeds up to 1e300), random dt in the allowed range (0, max_dt_s], random resets,
// snapshots and restores, and a share of bad inputs (NaN, Inf, dt <= 0, dt > max_dt_s,
// airspeed <= 0, a null output). Checked at every step:
//  1. a good input is answered ok or angle_clamped -- angle_clamped exactly when the model angle
//     is outside the envelope -- with finite outputs and every lag state inside its bound (below);
//     non_finite_result is allowed only for the absurd magnitudes (|value| >= 1e100 or
//     airspeed <= 1e-100) and then changes nothing;
//  2. a bad input is answered by its own status and changes neither the state (snapshots
//     compared bytewise) nor *out;
//  3. a restore gives back the snapshot bytewise.
//
// The state bound: y_j(k+1) = exp(-z) y_j(k) + phi1(z) (-c_j dA + con dt V/V_ref) with z > 0 and
// phi1(z) = (1 - exp(-z)) / z in (0, 1]; A is evaluated at clamped angles only, so every dA is
// within range(A) over the envelope, and the con term alone settles at con / b. A sum of such
// steps with weights in (0, 1] that decay whenever phi1 is small stays within a small multiple
// of range(A) |c_j| + |con| / min b; the test allows twice that (a growing state would pass it
// within a few thousand steps) and prints the largest |y| / allowed seen. One step from one end
// of the envelope to the other with a tiny dt reaches range(A) |c_j| exactly, i.e. 0.5.
//
// Steps: 1e8 in total for double (2.5e7 per model) plus 4e7 for float (1e7 per model) in
// Release; measured on the shared 2-core machine at about 190 ns a step including the checks
// (see docs/bad-inputs.md for the figures). Under a sanitizer build (tools/run-sanitizers.sh,
// ~10x slower) every count is divided by 20. INDICIAL_ROBUSTNESS_STEPS=<n> overrides the
// double count per model (float gets n / 2.5).
#include <doctest/doctest.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>

#include "indicial/model.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_UNDEFINED__)
#define INDICIAL_ROBUSTNESS_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(undefined_behavior_sanitizer)
#define INDICIAL_ROBUSTNESS_SANITIZED 1
#endif
#endif
#ifndef INDICIAL_ROBUSTNESS_SANITIZED
#define INDICIAL_ROBUSTNESS_SANITIZED 0
#endif

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::MotionInput;
using indicial::StepStatus;
using Set = indicial::test_models::Set;

long steps_per_model(double release_steps) {
  if (const char* env = std::getenv("INDICIAL_ROBUSTNESS_STEPS")) {
    return std::max(1000L, static_cast<long>(std::atof(env) * release_steps / 2.5e7));
  }
  return static_cast<long>(INDICIAL_ROBUSTNESS_SANITIZED ? release_steps / 20 : release_steps);
}

// splitmix64: tiny, fast and the same sequence on every platform (std distributions are not).
struct Rng {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double unit() { return static_cast<double>(next() >> 11) * 0x1.0p-53; }  // [0, 1)
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  int below(int n) { return static_cast<int>(next() % static_cast<std::uint64_t>(n)); }
  // lo * (hi / lo)^u computed in logs: hi / lo overflows for ranges like [denorm_min, 1e-6].
  double log_uniform(double lo, double hi) {
    const double v = std::exp(std::log(lo) + (std::log(hi) - std::log(lo)) * unit());
    return std::min(std::max(v, lo), hi);
  }
  double sign() { return (next() & 1u) ? 1.0 : -1.0; }
};

// Per coefficient and lag: the bound of the comment at the top.
struct Bounds {
  double y[indicial::DefaultCapacity::max_coefficients][indicial::DefaultCapacity::max_lags] = {};
};

Bounds state_bounds(const Set& m) {
  Bounds b;
  for (int c = 0; c < m.n_coefficients; ++c) {
    const auto& cm = m.coefficients[c];
    double a_min = HUGE_VAL, a_max = -HUGE_VAL, b_min = HUGE_VAL;
    for (int i = 0; i <= 4096; ++i) {
      const double x = m.x_min_rad + (m.x_max_rad - m.x_min_rad) * i / 4096.0;
      const double a = indicial::spline_antiderivative(cm.a, x);
      a_min = std::min(a_min, a);
      a_max = std::max(a_max, a);
      for (int j = 0; j < cm.n_lags; ++j) b_min = std::min(b_min, indicial::spline_value(cm.lags[j].b, x));
    }
    REQUIRE(b_min > 0.0);
    for (int j = 0; j < cm.n_lags; ++j) {
      const double gain = j == 0 ? 1.0 : std::abs(cm.lags[j].gain);
      b.y[c][j] = 2.0 * (gain * (a_max - a_min) + (j == 0 ? std::abs(cm.con) / b_min : 0.0)) + 1e-12;
    }
  }
  return b;
}

template <class P>
bool same_bytes(const typename P::Snapshot& a, const typename P::Snapshot& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

template <class P>
bool same_outputs(const typename P::Outputs& a, const typename P::Outputs& b) {
  if (a.count != b.count) return false;
  for (int c = 0; c < P::max_coefficients; ++c) {
    if (std::memcmp(&a.value[c], &b.value[c], sizeof a.value[c]) != 0 || a.name[c] != b.name[c])
      return false;
  }
  return true;
}

struct Tally {
  long steps = 0, good = 0, clamped = 0, absurd_refused = 0, bad = 0, resets = 0, restores = 0;
  double worst_bound_ratio = 0.0;
};

// One bad input and the status it must get.
struct BadInput {
  MotionInput in;
  double dt_s;
  bool null_output;
  StepStatus expected;
};

BadInput make_bad(Rng& rng, const MotionInput& good, double good_dt, double max_dt) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  BadInput b{good, good_dt, false, StepStatus::ok};
  switch (rng.below(9)) {
    case 0: b.in.motion_angle_rad = rng.below(2) ? nan : rng.sign() * inf; b.expected = StepStatus::non_finite_input; break;
    case 1: b.in.rate_radps = rng.below(2) ? nan : rng.sign() * inf; b.expected = StepStatus::non_finite_input; break;
    case 2: b.in.airspeed_mps = rng.below(2) ? nan : rng.sign() * inf; b.expected = StepStatus::non_finite_input; break;
    case 3: b.dt_s = rng.below(2) ? nan : rng.sign() * inf; b.expected = StepStatus::non_finite_input; break;
    case 4: b.dt_s = rng.below(4) == 0 ? 0.0 : (rng.below(2) ? -0.0 : -rng.log_uniform(1e-300, 1e300));
            b.expected = StepStatus::non_positive_dt; break;
    case 5: b.dt_s = rng.below(2) ? std::nextafter(max_dt, inf) : rng.log_uniform(max_dt * 1.000001, 1e300);
            b.expected = StepStatus::dt_too_large; break;
    case 6: b.in.airspeed_mps = rng.below(4) == 0 ? (rng.below(2) ? 0.0 : -0.0) : -rng.log_uniform(1e-300, 1e300);
            b.expected = StepStatus::non_positive_airspeed; break;
    case 7: b.null_output = true; b.expected = StepStatus::null_output; break;
    default:  // several bad fields at once: the first check in step()'s order decides
      b.in.motion_angle_rad = nan;
      b.dt_s = -1.0;
      b.in.airspeed_mps = -1.0;
      b.expected = StepStatus::non_finite_input;
      break;
  }
  return b;
}

// A good (finite, in-range) input: mostly plausible, sometimes far out, sometimes absurd.
struct GoodInput {
  MotionInput in;
  double dt_s;
  bool absurd;
};

GoodInput make_good(Rng& rng, const Set& m, double max_dt) {
  const double span = m.x_max_rad - m.x_min_rad;
  // The motion angle: alpha in pitch; phi / psi in roll / yaw cover the model angle's range
  // through the asin transform, so draw them over +-pi/2 widened.
  const bool pitch = m.axis == indicial::Axis::pitch;
  const double lo = pitch ? m.x_min_rad - 0.25 * span : -2.0;
  const double hi = pitch ? m.x_max_rad + 0.25 * span : 2.0;
  GoodInput g{{rng.uniform(lo, hi), rng.uniform(-10.0, 10.0), m.airspeed_mps * rng.log_uniform(0.2, 5.0)},
              rng.log_uniform(1e-6, max_dt), false};
  const int kind = rng.below(1000);
  if (kind < 40) {  // far out but sane: big angles, rates, airspeeds, tiny and maximal dt
    switch (rng.below(5)) {
      case 0: g.in.motion_angle_rad = rng.sign() * rng.log_uniform(1.0, 1e6); break;
      case 1: g.in.rate_radps = rng.sign() * rng.log_uniform(10.0, 1e6); break;
      case 2: g.in.airspeed_mps = rng.log_uniform(1e-3, 1e5); break;
      case 3: g.dt_s = rng.below(2) ? max_dt : rng.log_uniform(std::numeric_limits<double>::denorm_min(), 1e-6); break;
      default: g.in.motion_angle_rad = rng.below(2) ? m.x_min_rad : m.x_max_rad; break;
    }
  } else if (kind < 50) {  // absurd magnitudes: finite, but may overflow inside the model
    g.absurd = true;
    switch (rng.below(4)) {
      case 0: g.in.motion_angle_rad = rng.sign() * rng.log_uniform(1e100, 1.7e308); break;
      case 1: g.in.rate_radps = rng.sign() * rng.log_uniform(1e100, 1.7e308); break;
      case 2: g.in.airspeed_mps = rng.log_uniform(1e100, 1.7e308); break;
      default: g.in.airspeed_mps = rng.log_uniform(std::numeric_limits<double>::denorm_min(), 1e-100); break;
    }
  }
  return g;
}

template <class Scalar>
void run_stream(const Set& model, const char* label, long n_steps, std::uint64_t seed) {
  using P = indicial::Predictor<Scalar>;
  static P p;  // static: ~23 KB, keep it off the test's stack
  p = P{};
  REQUIRE(p.load(model) == indicial::LoadStatus::ok);
  const Bounds bounds = state_bounds(model);
  const double max_dt = P::max_dt_s;
  Rng rng{seed};
  Tally t;
  typename P::Snapshot saved[4] = {};
  bool have_saved[4] = {false, false, false, false};
  typename P::Outputs out;
  out.count = -1;

  REQUIRE(p.reset(0.5 * (model.x_min_rad + model.x_max_rad), model.airspeed_mps) == StepStatus::ok);
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  long failures = 0;
  auto fail = [&](const std::string& what) {
    if (++failures <= 5) FAIL_CHECK(std::string(label) << " step " << t.steps << ": " << what);
  };

  for (t.steps = 0; t.steps < n_steps && failures == 0; ++t.steps) {
    const int event = rng.below(10000);
    if (event < 2) {  // reset at a random angle (possibly outside the envelope)
      const GoodInput g = make_good(rng, model, max_dt);
      const typename P::Snapshot before = p.snapshot();
      const StepStatus s = p.reset(g.in.motion_angle_rad, g.in.airspeed_mps);
      ++t.resets;
      if (s == StepStatus::non_finite_result) {
        if (!g.absurd) fail("reset refused a sane input");
        if (!same_bytes<P>(before, p.snapshot())) fail("refused reset changed the state");
      } else if (s != StepStatus::ok && s != StepStatus::angle_clamped) {
        fail(std::string("reset: ") + indicial::to_string(s));
      }
      continue;
    }
    if (event < 4) {  // snapshot into a random slot
      const int k = rng.below(4);
      saved[k] = p.snapshot();
      have_saved[k] = true;
      continue;
    }
    if (event < 6) {  // restore a random slot
      const int k = rng.below(4);
      if (have_saved[k]) {
        p.restore(saved[k]);
        ++t.restores;
        if (!same_bytes<P>(saved[k], p.snapshot())) fail("restore did not give the snapshot back");
      }
      continue;
    }

    const GoodInput g = make_good(rng, model, max_dt);
    if (event < 206) {  // 2 %: a bad input
      const BadInput b = make_bad(rng, g.in, g.dt_s, max_dt);
      const typename P::Snapshot before = p.snapshot();
      const typename P::Outputs out_before = out;
      const StepStatus s = p.step(b.in, b.dt_s, b.null_output ? nullptr : &out);
      ++t.bad;
      if (s != b.expected)
        fail(std::string("bad input answered ") + indicial::to_string(s) + ", expected " +
             indicial::to_string(b.expected));
      if (!same_bytes<P>(before, p.snapshot())) fail("bad input changed the state");
      if (!same_outputs<P>(out_before, out)) fail("bad input changed *out");
      continue;
    }

    const typename P::Snapshot before = p.snapshot();
    const typename P::Outputs out_before = out;
    const StepStatus s = p.step(g.in, g.dt_s, &out);
    if (s == StepStatus::non_finite_result) {
      ++t.absurd_refused;
      if (!g.absurd) fail("non_finite_result for a sane input");
      if (!same_bytes<P>(before, p.snapshot())) fail("non_finite_result changed the state");
      if (!same_outputs<P>(out_before, out)) fail("non_finite_result changed *out");
      continue;
    }
    // In the predictor's Scalar, as the runtime clamps (a float predictor rounds the angle to
    // float first: an angle within float rounding of the envelope's end is at that end).
    // (An angle beyond Scalar's range is taken in double in roll and yaw, as the runtime does.)
    const Scalar motion = Scalar(g.in.motion_angle_rad);
    const Scalar x = std::isfinite(motion) || model.axis == indicial::Axis::pitch
                         ? indicial::model_angle_from_factor(
                               model.axis, Scalar(indicial::model_angle_factor(model.axis, model.alpha0_rad)), motion)
                         : Scalar(indicial::model_angle<double>(model.axis, model.alpha0_rad, g.in.motion_angle_rad));
    const bool outside = x < Scalar(model.x_min_rad) || x > Scalar(model.x_max_rad);
    if (s != (outside ? StepStatus::angle_clamped : StepStatus::ok)) {
      fail(std::string("good input answered ") + indicial::to_string(s) + (outside ? " (outside)" : " (inside)"));
      continue;
    }
    ++(outside ? t.clamped : t.good);
    if (out.count != model.n_coefficients) fail("wrong output count");
    const typename P::Snapshot now = p.snapshot();
    for (int c = 0; c < model.n_coefficients; ++c) {
      if (!std::isfinite(out.value[c])) fail("non-finite output");
      for (int j = 0; j < model.coefficients[c].n_lags; ++j) {
        const double y = static_cast<double>(now.y[c][j]);
        if (!std::isfinite(y)) fail("non-finite state");
        const double ratio = std::abs(y) / bounds.y[c][j];
        t.worst_bound_ratio = std::max(t.worst_bound_ratio, ratio);
        if (ratio > 1.0) fail("lag state beyond its bound: " + std::to_string(y));
      }
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double cpu_seconds = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  MESSAGE(std::string(label) << ": " << t.steps << " events in " << seconds << " s wall, " << cpu_seconds
                << " s CPU (" << 1e9 * cpu_seconds / double(t.steps) << " ns CPU each): " << t.good << " ok, " << t.clamped << " clamped, " << t.bad
                << " bad inputs refused, " << t.absurd_refused << " absurd inputs refused (non_finite_result), "
                << t.resets << " resets, " << t.restores << " restores; largest |y| / bound "
                << t.worst_bound_ratio);
  CHECK(failures == 0);
  CHECK(t.steps == n_steps);
  // The stream must have exercised every branch, or it proves nothing.
  CHECK(t.good + t.clamped > n_steps * 9 / 10);
  CHECK(t.good > n_steps / 4);
  CHECK(t.clamped > n_steps / 20);
  CHECK(t.bad > n_steps / 100);
  CHECK(t.resets > 0);
  CHECK(t.restores > 0);
}

}  // namespace

TEST_CASE("robustness: Model I (double)") {
  run_stream<double>(indicial::test_models::table_one_model_one(), "Model I double", steps_per_model(2.5e7), 1);
}
TEST_CASE("robustness: Model II, b1(alpha) with knots (double)") {
  run_stream<double>(indicial::test_models::table_one_model_two(), "Model II double", steps_per_model(2.5e7), 2);
}
TEST_CASE("robustness: CL and Cm, static table, two lags, bias (double)") {
  run_stream<double>(indicial::test_models::lift_and_moment(), "lift+moment double", steps_per_model(2.5e7), 3);
}
TEST_CASE("robustness: roll, three coefficients (double)") {
  run_stream<double>(indicial::test_models::roll_three(), "roll double", steps_per_model(2.5e7), 4);
}
TEST_CASE("robustness: every model in float") {
  run_stream<float>(indicial::test_models::table_one_model_one(), "Model I float", steps_per_model(1e7), 5);
  run_stream<float>(indicial::test_models::table_one_model_two(), "Model II float", steps_per_model(1e7), 6);
  run_stream<float>(indicial::test_models::lift_and_moment(), "lift+moment float", steps_per_model(1e7), 7);
  run_stream<float>(indicial::test_models::roll_three(), "roll float", steps_per_model(1e7), 8);
}
