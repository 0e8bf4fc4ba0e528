// The shared-model runtime: many states of one RuntimeModel, stepped one at a time or in a
// batch (indicial/batch.hpp), and several coefficients of one axis in one state.
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "indicial/batch.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {

using Cap = indicial::DefaultCapacity;
using Set = indicial::ModelSet<double, Cap>;
using Model = indicial::RuntimeModel<double, Cap>;
using State = indicial::State<double, Cap>;
using indicial::StepStatus;

constexpr double kPi = 3.14159265358979323846;

double angle_at(double t, double phase) { return 0.6 + 0.5 * std::sin(2 * kPi * 0.9 * t + phase); }
double rate_at(double t, double phase) { return 0.5 * 2 * kPi * 0.9 * std::cos(2 * kPi * 0.9 * t + phase); }

// Step k (dt 0.004 s) of the status-path tests: instance i on its own phase of the motion, at
// one of three airspeeds that change every 50 steps (the airspeed-term cache's both paths).
void status_path_inputs(int k, std::vector<double>& angle, std::vector<double>& rate,
                        std::vector<double>& airspeed) {
  const double t = 0.004 * k;
  for (std::size_t i = 0; i < angle.size(); ++i) {
    angle[i] = angle_at(t, 0.3 * double(i));
    rate[i] = rate_at(t, 0.3 * double(i));
    airspeed[i] = 17.0 * (1.0 + 0.05 * double((i + std::size_t(k) / 50) % 3));
  }
}

}  // namespace

TEST_CASE("step_batch equals single steps to 1e-12 relative, each instance on its own motion") {
  static Model model;
  REQUIRE(indicial::make_runtime_model(indicial::test_models::lift_and_moment(), &model) ==
          indicial::LoadStatus::ok);
  const std::size_t n = 45;  // 5 full blocks and a partial one
  std::vector<State> batch(n), single(n);
  for (std::size_t i = 0; i < n; ++i) {
    REQUIRE(indicial::reset(model, batch[i], angle_at(0.0, 0.1 * double(i)), 17.0) == StepStatus::ok);
    REQUIRE(indicial::reset(model, single[i], angle_at(0.0, 0.1 * double(i)), 17.0) == StepStatus::ok);
  }
  std::vector<double> angle(n), rate(n), airspeed(n), out(2 * n);
  double worst = 0.0;
  int compared = 0;
  for (int k = 1; k <= 500; ++k) {
    const double t = 0.004 * k;
    for (std::size_t i = 0; i < n; ++i) {
      angle[i] = angle_at(t, 0.1 * double(i));
      rate[i] = rate_at(t, 0.1 * double(i));
      airspeed[i] = 17.0 * (1.0 + 0.02 * double(i % 7));
    }
    REQUIRE(indicial::step_batch(model, batch.data(), n, angle.data(), rate.data(), airspeed.data(),
                                 0.004, out.data()) == StepStatus::ok);
    for (std::size_t i = 0; i < n; ++i) {
      double o[3];
      REQUIRE(indicial::step(model, single[i], {angle[i], rate[i], airspeed[i]}, 0.004, o) == StepStatus::ok);
      for (int c = 0; c < 2; ++c) {
        // Relative to the value, or to 0.01 where the coefficient crosses zero (a difference
        // of one ulp of a value of order 1 is not 1e-12 of a value of 1e-5).
        worst = std::fmax(worst, std::fabs(out[2 * i + c] - o[c]) / std::fmax(std::fabs(o[c]), 1e-2));
        ++compared;
      }
    }
  }
  MESSAGE("batch vs single: max relative difference ", worst, " over ", compared, " outputs");
  // Measured 4.4e-14 (4.4e-16 absolute): the exponentials differ by about an ulp.
  CHECK(compared == 500 * 45 * 2);
  CHECK(worst <= 1e-12);
  // The lag states too (exp to about 1 ulp, so not bit for bit, but within 1e-12).
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 2; ++c)
      CHECK(batch[i].y[c][0] == doctest::Approx(single[i].y[c][0]).epsilon(1e-12));
}

TEST_CASE("step_batch: a refused instance is unchanged, the others step") {
  static Model model;
  REQUIRE(indicial::make_runtime_model(indicial::test_models::lift_and_moment(), &model) ==
          indicial::LoadStatus::ok);
  State s[10];
  for (State& si : s) REQUIRE(indicial::reset(model, si, 0.5, 17.0) == StepStatus::ok);
  State never_reset;  // a default state was never reset
  s[7] = never_reset;
  const State before3 = s[3];
  double angle[10], rate[10], airspeed[10], out[20];
  for (int i = 0; i < 10; ++i) {
    angle[i] = 0.52;
    rate[i] = 0.1;
    airspeed[i] = 17.0;
  }
  angle[3] = NAN;
  angle[5] = 3.0;  // clamped
  for (double& o : out) o = -7.0;
  StepStatus status[10];
  CHECK(indicial::step_batch(model, s, 10, angle, rate, airspeed, 0.01, out, status) ==
        StepStatus::non_finite_input);
  CHECK(status[3] == StepStatus::non_finite_input);
  CHECK(status[7] == StepStatus::not_reset);
  CHECK(status[5] == StepStatus::angle_clamped);
  CHECK(status[0] == StepStatus::ok);
  CHECK(std::memcmp(&before3, &s[3], sizeof before3) == 0);
  CHECK(out[6] == -7.0);
  CHECK(out[7] == -7.0);
  CHECK(out[0] != -7.0);
  CHECK(std::isfinite(out[10]));
  // A delayed model needs DelayedStates.
  static Model delayed;
  Set d = indicial::test_models::lift_and_moment();
  d.coefficients[1].delay_s = 0.02;
  REQUIRE(indicial::make_runtime_model(d, &delayed) == indicial::LoadStatus::ok);
  CHECK(indicial::step_batch(delayed, s, 10, angle, rate, airspeed, 0.01, out) ==
        StepStatus::delay_needs_history);
  CHECK(indicial::step(delayed, s[0], {0.5, 0.0, 17.0}, 0.01, out) == StepStatus::delay_needs_history);
}

TEST_CASE("one state steps C_L and C_m of one file exactly as two single-coefficient models") {
  // examples/synthetic-lift-moment.coef holds CL (a table, two lags) and Cm in one model set.
  const std::string text = indicial::read_text(std::string(INDICIAL_SOURCE_DIR) +
                                               "/examples/synthetic-lift-moment.coef");
  static Model both;
  REQUIRE(indicial::load_runtime_model(text.data(), text.size(), &both) == indicial::LoadStatus::ok);
  REQUIRE(both.set.n_coefficients == 2);
  static Set parsed;
  REQUIRE(indicial::parse_coef_file(text.data(), text.size(), &parsed, nullptr) == indicial::LoadStatus::ok);
  static Model alone[2];
  for (int c = 0; c < 2; ++c) {
    Set one = parsed;
    one.n_coefficients = 1;
    one.coefficients[0] = parsed.coefficients[c];
    REQUIRE(indicial::make_runtime_model(one, &alone[c]) == indicial::LoadStatus::ok);
  }
  State s_both, s_alone[2];
  REQUIRE(indicial::reset(both, s_both, 0.4, 21.0) == StepStatus::ok);
  for (int c = 0; c < 2; ++c) REQUIRE(indicial::reset(alone[c], s_alone[c], 0.4, 21.0) == StepStatus::ok);
  int same = 0;
  for (int k = 1; k <= 1000; ++k) {
    const double t = 0.002 * k;
    const indicial::MotionInput in{angle_at(t, -0.4), rate_at(t, -0.4), 21.0};
    double o2[3], o1[3];
    REQUIRE(indicial::step(both, s_both, in, 0.002, o2) == StepStatus::ok);
    for (int c = 0; c < 2; ++c) {
      REQUIRE(indicial::step(alone[c], s_alone[c], in, 0.002, o1) == StepStatus::ok);
      same += std::memcmp(&o1[0], &o2[c], sizeof(double)) == 0;
    }
  }
  CHECK(same == 2000);
  // A Predictor gives the same, with the names in file order.
  indicial::Predictor<> p;
  REQUIRE(p.use(both) == indicial::LoadStatus::ok);
  REQUIRE(p.reset(0.4, 21.0) == StepStatus::ok);
  indicial::Predictor<>::Outputs out;
  REQUIRE(p.step({0.41, 0.1, 21.0}, 0.002, &out) == StepStatus::ok);
  CHECK(out.count == 2);
  CHECK(std::string(out.name[0]) == "CL");
  CHECK(std::string(out.name[1]) == "Cm");
}

TEST_CASE("many states share one model: the model is not copied, each state is small") {
  static Model model;
  REQUIRE(indicial::make_runtime_model(indicial::test_models::table_one_model_two(), &model) ==
          indicial::LoadStatus::ok);
  CHECK(sizeof(State) <= 256);
  MESSAGE("RuntimeModel<double> ", sizeof(Model), " bytes, State<double> ", sizeof(State), " bytes");
  indicial::Predictor<> a;
  indicial::Predictor<> b;
  REQUIRE(a.use(model) == indicial::LoadStatus::ok);
  REQUIRE(b.use(model) == indicial::LoadStatus::ok);
  CHECK(&a.runtime() == &model);
  CHECK(&b.runtime() == &model);
  // A model whose step constants were tampered with is refused by check_runtime_model.
  static Model tampered;
  tampered = model;
  tampered.x_max_rad = 2.0;
  CHECK(indicial::check_runtime_model(tampered) == indicial::LoadStatus::invalid_value);
  CHECK(a.use(tampered) == indicial::LoadStatus::invalid_value);
  CHECK(&a.runtime() == &model);  // a refused use() changes nothing
}

namespace {

// Steps `batch` with step_batch and `single` one indicial::step at a time on the same inputs
// and compares every instance: the status, and for a stepped instance its outputs and lag
// states to `tolerance` relative (relative to max(|value|, 0.01)); a refused instance must be
// bytewise unchanged in both, its out row untouched. Returns the largest relative difference.
template <class Scalar>
double compare_batch_with_single(const indicial::RuntimeModel<Scalar, Cap>& model,
                                 std::vector<indicial::State<Scalar, Cap>>& batch,
                                 std::vector<indicial::State<Scalar, Cap>>& single,
                                 const std::vector<double>& angle, const std::vector<double>& rate,
                                 const std::vector<double>& airspeed, double dt_s, double tolerance,
                                 indicial::BatchKernel kernel = indicial::BatchKernel::automatic) {
  const std::size_t n = batch.size();
  const int n_out = model.set.n_coefficients;
  std::vector<Scalar> out(n * std::size_t(n_out), Scalar(-7));
  std::vector<StepStatus> status(n);
  const std::vector<indicial::State<Scalar, Cap>> before = batch;
  indicial::step_batch(model, batch.data(), n, angle.data(), rate.data(), airspeed.data(), dt_s,
                       out.data(), status.data(), kernel);
  double worst = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    Scalar o[3] = {Scalar(-7), Scalar(-7), Scalar(-7)};
    const StepStatus s = indicial::step(model, single[i], {angle[i], rate[i], airspeed[i]}, dt_s, o);
    REQUIRE(status[i] == s);
    if (s != StepStatus::ok && s != StepStatus::angle_clamped) {
      CHECK(std::memcmp(&before[i], &batch[i], sizeof batch[i]) == 0);
      for (int c = 0; c < n_out; ++c) CHECK(out[i * std::size_t(n_out) + std::size_t(c)] == Scalar(-7));
      continue;
    }
    for (int c = 0; c < n_out; ++c) {
      const double a = double(out[i * std::size_t(n_out) + std::size_t(c)]), b = double(o[c]);
      worst = std::fmax(worst, std::fabs(a - b) / std::fmax(std::fabs(b), 1e-2));
      for (int j = 0; j < Cap::max_lags; ++j) {
        const double ya = double(batch[i].y[c][j]), yb = double(single[i].y[c][j]);
        worst = std::fmax(worst, std::fabs(ya - yb) / std::fmax(std::fabs(yb), 1e-2));
      }
    }
    CHECK(batch[i].model_x_prev_rad == single[i].model_x_prev_rad);
    CHECK(batch[i].time_scale == single[i].time_scale);
    CHECK(batch[i].l_over_v_s == single[i].l_over_v_s);
  }
  CHECK(worst <= tolerance);
  return worst;
}

}  // namespace

TEST_CASE("step_batch: every status path equals indicial::step lane by lane") {
  // Model II's Cm with a step (knot power 0) in its static correction, so that a plus-function
  // term of power 0 goes through the lanes' select, and CL's static table (evaluated lane by
  // lane).
  Set set = indicial::test_models::lift_and_moment();
  auto& cm = set.coefficients[1].static_correction;
  cm.n_knots = 1;
  cm.knot_rad[0] = 0.6;
  cm.knot_power[0] = 0;
  cm.knot_coef[0] = 0.01;
  static Model model;
  REQUIRE(indicial::make_runtime_model(set, &model) == indicial::LoadStatus::ok);
  const std::size_t n = 21;  // two full blocks and a partial one
  std::vector<State> batch(n), single(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (i == 4) continue;  // never reset: not_reset
    REQUIRE(indicial::reset(model, batch[i], angle_at(0.0, 0.3 * double(i)), 17.0) == StepStatus::ok);
    single[i] = batch[i];
  }
  std::vector<double> angle(n), rate(n), airspeed(n);
  double worst = 0.0;
  for (int k = 1; k <= 300; ++k) {
    status_path_inputs(k, angle, rate, airspeed);
    angle[1] = 0.55;                 // an angle that does not move: interval_mean's midpoint
    angle[2] = 3.0;                  // beyond the envelope: angle_clamped
    angle[3] = -3.0;
    angle[5] = k % 2 == 0 ? NAN : angle[5];         // non_finite_input every other step
    rate[6] = k % 3 == 0 ? HUGE_VAL : rate[6];      // non_finite_input
    airspeed[7] = k % 5 == 0 ? -1.0 : airspeed[7];  // non_positive_airspeed
    // Finite but absurd: l / V overflows, the rotary term is not finite: non_finite_result.
    airspeed[8] = k % 7 == 0 ? 1e-310 : airspeed[8];
    rate[8] = 1e300;
    worst = std::fmax(worst, compare_batch_with_single(model, batch, single, angle, rate, airspeed,
                                                       0.004, 1e-12));
  }
  MESSAGE("every status path: max relative difference ", worst);
  // A dt refused for everybody: every lane reports it, nothing changes.
  compare_batch_with_single(model, batch, single, angle, rate, airspeed, 0.0, 1e-12);
  compare_batch_with_single(model, batch, single, angle, rate, airspeed, 2.0, 1e-12);
}

TEST_CASE("step_batch: roll (three coefficients) and float equal single steps") {
  static Model roll;
  REQUIRE(indicial::make_runtime_model(indicial::test_models::roll_three(), &roll) ==
          indicial::LoadStatus::ok);
  static indicial::RuntimeModel<float, Cap> model_f;
  REQUIRE(indicial::make_runtime_model(indicial::test_models::table_one_model_two(), &model_f) ==
          indicial::LoadStatus::ok);
  const std::size_t n = 13;
  std::vector<State> batch(n), single(n);
  std::vector<indicial::State<float, Cap>> batch_f(n), single_f(n);
  for (std::size_t i = 0; i < n; ++i) {
    REQUIRE(indicial::reset(roll, batch[i], 0.1 * double(i) - 0.6, 20.0) == StepStatus::ok);
    single[i] = batch[i];
    REQUIRE(indicial::reset(model_f, batch_f[i], angle_at(0.0, 0.2 * double(i)), 17.0) ==
            StepStatus::ok);
    single_f[i] = batch_f[i];
  }
  std::vector<double> angle(n), rate(n), airspeed(n, 20.0), angle_f(n), rate_f(n),
      airspeed_f(n, 17.0);
  double worst = 0.0, worst_f = 0.0;
  for (int k = 1; k <= 300; ++k) {
    const double t = 0.005 * k;
    for (std::size_t i = 0; i < n; ++i) {
      angle[i] = 0.8 * std::sin(2 * kPi * 0.7 * t + 0.4 * double(i));  // roll angle phi
      rate[i] = 0.8 * 2 * kPi * 0.7 * std::cos(2 * kPi * 0.7 * t + 0.4 * double(i));
      angle_f[i] = angle_at(t, 0.2 * double(i));
      rate_f[i] = rate_at(t, 0.2 * double(i));
    }
    worst = std::fmax(worst, compare_batch_with_single(roll, batch, single, angle, rate, airspeed,
                                                       0.005, 1e-12));
    // float: bit for bit. The single float step and the lanes take the same exponential
    // (model.hpp's exp_on); with different ones (glibc's expf and a lane exp, an ulp apart)
    // phi1 = (1 - exp(-z)) / z amplified that ulp by 1 / z into 1e-4 after 300 steps.
    worst_f = std::fmax(worst_f, compare_batch_with_single(model_f, batch_f, single_f, angle_f,
                                                           rate_f, airspeed_f, 0.005, 0.0));
  }
  MESSAGE("roll: ", worst, ", float: ", worst_f);
}

TEST_CASE("step_batch: the AVX2 kernel gives the portable kernel's bits") {
  using indicial::BatchKernel;
  MESSAGE("automatic runs the ", indicial::to_string(indicial::batch_kernel_in_use()), " kernel here");
  CHECK(indicial::batch_kernel_in_use(BatchKernel::portable) == BatchKernel::portable);
  if (indicial::batch_kernel_in_use(BatchKernel::avx2) != BatchKernel::avx2)
    MESSAGE("no AVX2 kernel on this CPU or in this build: avx2 requests run the portable one");
  static Model model;
  REQUIRE(indicial::make_runtime_model(indicial::test_models::lift_and_moment(), &model) ==
          indicial::LoadStatus::ok);
  const std::size_t n = 19;  // two full blocks and a partial one
  std::vector<State> portable(n), avx2(n);
  for (std::size_t i = 0; i < n; ++i) {
    REQUIRE(indicial::reset(model, portable[i], angle_at(0.0, 0.3 * double(i)), 17.0) == StepStatus::ok);
    avx2[i] = portable[i];
  }
  std::vector<double> angle(n), rate(n), airspeed(n), out_p(2 * n, -7.0), out_a(2 * n, -7.0);
  std::vector<StepStatus> status_p(n), status_a(n);
  int refused = 0, clamped = 0;
  for (int k = 1; k <= 200; ++k) {
    status_path_inputs(k, angle, rate, airspeed);
    angle[2] = 3.0;                                   // angle_clamped
    angle[5] = k % 2 == 0 ? NAN : angle[5];           // non_finite_input
    airspeed[8] = k % 7 == 0 ? 1e-310 : airspeed[8];  // non_finite_result (with the rate below)
    rate[8] = 1e300;
    indicial::step_batch(model, portable.data(), n, angle.data(), rate.data(), airspeed.data(), 0.004,
                         out_p.data(), status_p.data(), BatchKernel::portable);
    indicial::step_batch(model, avx2.data(), n, angle.data(), rate.data(), airspeed.data(), 0.004,
                         out_a.data(), status_a.data(), BatchKernel::avx2);
    for (std::size_t i = 0; i < n; ++i) {
      CHECK(status_p[i] == status_a[i]);
      refused += status_p[i] != StepStatus::ok && status_p[i] != StepStatus::angle_clamped;
      clamped += status_p[i] == StepStatus::angle_clamped;
      CHECK(std::memcmp(&portable[i], &avx2[i], sizeof(State)) == 0);
    }
    CHECK(std::memcmp(out_p.data(), out_a.data(), out_p.size() * sizeof(double)) == 0);
  }
  // Every path was taken: 100 NaN inputs, 28 non-finite results, 200 clamps.
  CHECK(refused == 100 + 28);
  CHECK(clamped == 200);
}
