// A held angle never leaves a state in the subnormal range (model.hpp's flush_below_normal):
// the lag states, and the vortex states of the dynamic-stall families, decay to +0 through
// the normal range. Why a test: a trial's HIL loop held an angle at 1 kHz and the step slowed
// from 120 to 161 ns median after 400 s, for as long as the hold lasted (subnormal arithmetic
// on x86), with nothing in the docs. Double and float, the single step and the batch's lanes.
#include <doctest/doctest.h>

#include <cmath>
#include <string>
#include <vector>

#include "indicial/batch.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using indicial::StepStatus;
using Set = indicial::ModelSet<double, indicial::DefaultCapacity>;

std::string text_of(const Set& m) {
  std::vector<char> buffer(16384);
  std::size_t n = 0;
  REQUIRE(indicial::write_coef_file(m, buffer.data(), buffer.size(), &n) == indicial::WriteStatus::ok);
  return std::string(buffer.data(), n);
}

// Stepped: ok, or with the angle clamped to the envelope (outputs still produced).
bool stepped(StepStatus s) { return s == StepStatus::ok || s == StepStatus::angle_clamped; }

template <class S>
bool subnormal(S v) {
  return std::fpclassify(v) == FP_SUBNORMAL;
}

// Every decaying number of a Predictor's state: the lag states and the family states.
template <class Snapshot>
int subnormal_states(const Snapshot& s) {
  int count = 0;
  for (const auto& per_coefficient : s.y)
    for (const auto& y : per_coefficient) count += subnormal(y) ? 1 : 0;
  for (const auto& st : s.stall)
    count += (subnormal(st.vortex_lift) ? 1 : 0) + (subnormal(st.vortex_clock_semichords) ? 1 : 0) +
             (subnormal(st.separation_point) ? 1 : 0);
  return count;
}

// A pitch-up into the model's range, then the angle held for `hold_steps` steps of dt_s: the
// largest count of subnormal states seen at any step of the hold, and whether every output
// stayed finite.
template <class Scalar>
int worst_hold(const Set& model, double from_rad, double to_rad, double dt_s, int hold_steps) {
  indicial::Predictor<Scalar> p;
  const std::string text = text_of(model);
  REQUIRE(p.load(text.data(), text.size()) == indicial::LoadStatus::ok);
  const double v = model.airspeed_mps;
  REQUIRE(p.reset(Scalar(from_rad), Scalar(v)) == StepStatus::ok);
  typename indicial::Predictor<Scalar>::Outputs out;
  const double rate = (to_rad - from_rad) / 0.2;
  for (int k = 1; k <= 20; ++k)
    REQUIRE(stepped(p.step({Scalar(from_rad + rate * 0.01 * k), Scalar(rate), Scalar(v)}, Scalar(0.01), &out)));
  int worst = 0;
  for (int k = 0; k < hold_steps; ++k) {
    REQUIRE(stepped(p.step({Scalar(to_rad), Scalar(0), Scalar(v)}, Scalar(dt_s), &out)));
    for (int c = 0; c < out.count; ++c) REQUIRE(std::isfinite(out.value[c]));
    worst = std::max(worst, subnormal_states(p.snapshot()));
  }
  return worst;
}

}  // namespace

TEST_CASE("a held angle: no lag state is ever subnormal (Model II, double and float)") {
  const Set m = indicial::test_models::table_one_model_two();
  // 0.05 s steps decay the lag from the ramp's transient through the whole subnormal range
  // (double: 1e-308 .. 5e-324) within the hold; without the flush some step leaves it there.
  CHECK(worst_hold<double>(m, 0.3, 0.6, 0.05, 40000) == 0);
  CHECK(worst_hold<float>(m, 0.3, 0.6, 0.05, 8000) == 0);
}

// Into stall and back: the vortex fed past the shedding criterion (24 deg), then the angle
// held attached (5 deg) while the vortex lift and its clock decay; or held in deep stall
// where the static separation is clipped to 0 (the test model's f0 table set to 0 above 20
// deg), while the separation point decays. The largest count of subnormal family states seen
// at any step of the hold, and whether the decaying state ended at +0.
template <class Scalar>
int worst_stall_hold(const Set& m, double hold_deg, bool* ended_at_zero) {
  const double deg = 0.017453292519943295;
  indicial::Predictor<Scalar> p;
  const std::string text = text_of(m);
  REQUIRE(p.load(text.data(), text.size()) == indicial::LoadStatus::ok);
  const Scalar v = Scalar(m.airspeed_mps);
  REQUIRE(p.reset(Scalar(5 * deg), v) == StepStatus::ok);
  typename indicial::Predictor<Scalar>::Outputs out;
  for (int k = 1; k <= 200; ++k)
    REQUIRE(stepped(p.step({Scalar((5 + 0.095 * k) * deg), Scalar(0.095 * deg / 0.005), v}, Scalar(0.005), &out)));
  CHECK(p.snapshot().stall[0].vortex_lift != Scalar(0));  // a vortex was fed
  int worst = 0;
  for (int k = 0; k < 40000; ++k) {
    REQUIRE(stepped(p.step({Scalar(hold_deg * deg), Scalar(0), v}, Scalar(0.01), &out)));
    for (int c = 0; c < out.count; ++c) REQUIRE(std::isfinite(out.value[c]));
    worst = std::max(worst, subnormal_states(p.snapshot()));
  }
  const auto& st = p.snapshot().stall[0];
  *ended_at_zero = hold_deg < 20 ? st.vortex_lift == Scalar(0) : st.separation_point == Scalar(0);
  return worst;
}

TEST_CASE("a held angle out of stall or in deep stall: no family state is ever subnormal (double and float)") {
  const Set attached = indicial::test_models::lift_and_moment_stall();
  Set clipped = attached;  // f0 clipped to 0 above 20 deg
  for (auto& c : clipped.coefficients)
    for (int i = 0; i < c.stall.separation.n_f0; ++i)
      if (c.stall.separation.f0_x_rad[i] > 20 * 0.017453292519943295) c.stall.separation.f0_value[i] = 0.0;
  bool zero = false;
  CHECK(worst_stall_hold<double>(attached, 5.0, &zero) == 0);
  CHECK(zero);  // the vortex lift decayed to +0, not held subnormal
  CHECK(worst_stall_hold<float>(attached, 5.0, &zero) == 0);
  CHECK(zero);
  CHECK(worst_stall_hold<double>(clipped, 25.0, &zero) == 0);
  CHECK(zero);  // the separation point decayed to +0
  CHECK(worst_stall_hold<float>(clipped, 25.0, &zero) == 0);
  CHECK(zero);
}

TEST_CASE("a held angle in a batch: no lane's lag state is ever subnormal, and the lanes equal single steps") {
  static indicial::RuntimeModel<double, indicial::DefaultCapacity> model;
  REQUIRE(indicial::make_runtime_model(indicial::test_models::table_one_model_two(), &model) ==
          indicial::LoadStatus::ok);
  const std::size_t n = 5;
  std::vector<indicial::State<double, indicial::DefaultCapacity>> batch(n), single(n);
  std::vector<double> angle(n), rate(n, 0.0), airspeed(n, model.set.airspeed_mps), out(n);
  for (std::size_t i = 0; i < n; ++i) {
    REQUIRE(indicial::reset(model, batch[i], 0.3, airspeed[i]) == StepStatus::ok);
    REQUIRE(indicial::reset(model, single[i], 0.3, airspeed[i]) == StepStatus::ok);
    angle[i] = 0.4 + 0.05 * double(i);  // one jump, then held
  }
  int worst = 0;
  for (int k = 0; k < 40000; ++k) {
    REQUIRE(indicial::step_batch(model, batch.data(), n, angle.data(), rate.data(), airspeed.data(), 0.05,
                                 out.data()) == StepStatus::ok);
    for (std::size_t i = 0; i < n; ++i) {
      double o[indicial::DefaultCapacity::max_coefficients];  // as step may write: the capacity
      REQUIRE(stepped(indicial::step(model, single[i], {angle[i], 0.0, airspeed[i]}, 0.05, o)));
      for (const auto& y : batch[i].y[0]) worst = std::max(worst, subnormal(y) ? 1 : 0);
      if (k == 39999) CHECK(batch[i].y[0][0] == single[i].y[0][0]);
    }
  }
  CHECK(worst == 0);
}
