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

namespace {

using Cap = indicial::DefaultCapacity;
using Set = indicial::ModelSet<double, Cap>;
using Model = indicial::RuntimeModel<double, Cap>;
using State = indicial::State<double, Cap>;
using indicial::StepStatus;

constexpr double kPi = 3.14159265358979323846;

double angle_at(double t, double phase) { return 0.6 + 0.5 * std::sin(2 * kPi * 0.9 * t + phase); }
double rate_at(double t, double phase) { return 0.5 * 2 * kPi * 0.9 * std::cos(2 * kPi * 0.9 * t + phase); }

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
