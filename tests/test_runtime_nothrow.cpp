// The runtime in a translation unit compiled with -fno-exceptions -fno-rtti and linked to
// indicial::runtime only (tests/CMakeLists.txt does that for *_nothrow.cpp): load a model
// from a character buffer, reset, step, and check the outputs.
#define DOCTEST_CONFIG_IMPLEMENT_WITH_MAIN
#include <doctest/doctest.h>

#include <cmath>
#include <cstring>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/tailless_model.hpp"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"

#if defined(__cpp_exceptions) || defined(__GXX_RTTI)
#error "this file must be compiled with -fno-exceptions -fno-rtti"
#endif

namespace {
// Table I, Model II as coefficient-file text, written by the runtime's own writer from the
// one definition (tailless_model.hpp; the same bytes as examples/tailless-model-2.coef).
char kModelTwo[1024];

void write_model_two() {
  std::size_t n = 0;
  const auto m = indicial::tailless_model_set<indicial::DefaultCapacity>(indicial::TaillessModel::model_2);
  REQUIRE(indicial::write_coef_file(m, kModelTwo, sizeof kModelTwo - 1, &n) == indicial::WriteStatus::ok);
  kModelTwo[n] = '\0';
}
}  // namespace

TEST_CASE("load from a char buffer, reset, step without exceptions or RTTI") {
  write_model_two();
  indicial::Predictor<double> p;
  indicial::ParseDiagnostic diag;
  REQUIRE(p.load(kModelTwo, std::strlen(kModelTwo), &diag) == indicial::LoadStatus::ok);
  const double alpha0 = 35.0 * 3.14159265358979323846 / 180.0;
  REQUIRE(p.reset(alpha0, 17.667762) == indicial::StepStatus::ok);
  indicial::Predictor<double>::Outputs out;
  // At rest the output is the static curve (Model I/II have no bias): C_m(alpha0).
  REQUIRE(p.step({alpha0, 0.0, 17.667762}, 0.01, &out) == indicial::StepStatus::ok);
  REQUIRE(out.count == 1);
  CHECK(std::strcmp(out.name[0], "Cm") == 0);
  const double a = alpha0;
  const double cm_static = 0.42 * a + 0.34 * a * a - a * a * a + 0.4 * a * a * a * a;
  CHECK(out.value[0] == doctest::Approx(cm_static).epsilon(1e-14));
  // A pitch-up ramp at 1 rad/s for 0.2 s: a(x) < 0 around 35 deg, so the lag state y = -int
  // exp(.) a(x) x' dt grows positive, and the rotary term (l/V) C_mq q is negative.
  double alpha = alpha0;
  for (int k = 0; k < 20; ++k) {
    alpha += 0.01;
    REQUIRE(p.step({alpha, 1.0, 17.667762}, 0.01, &out) == indicial::StepStatus::ok);
  }
  const double y = p.snapshot().y[0][0];
  CHECK(y > 0.0);
  const double b = alpha;
  const double qs = 0.42 * b + 0.34 * b * b - b * b * b + 0.4 * b * b * b * b +
                    (0.3765 / 17.667762) * (-2.0 + 0.8 * b * b) * 1.0;
  CHECK(out.value[0] == doctest::Approx(qs + y).epsilon(1e-13));
  // Bad input is refused without exceptions.
  CHECK(p.step({alpha, 1.0, 17.667762}, -1.0, &out) == indicial::StepStatus::non_positive_dt);
  // A damaged buffer is refused with its status.
  char damaged[sizeof kModelTwo];
  std::memcpy(damaged, kModelTwo, sizeof kModelTwo);
  damaged[std::strlen("indicial-coef 1\naxis pitch\nreference_length_m 0.37")] = '8';
  CHECK(p.load(damaged, std::strlen(damaged)) == indicial::LoadStatus::checksum_mismatch);
}

TEST_CASE("dynamic-stall families load, reset and step without exceptions or RTTI, double and float") {
  static char text[16384];
  std::size_t n = 0;
  REQUIRE(indicial::write_coef_file(indicial::test_models::lift_and_moment_stall(), text, sizeof text, &n) ==
          indicial::WriteStatus::ok);
  indicial::RuntimeModel<double, indicial::DefaultCapacity> md;
  indicial::RuntimeModel<float, indicial::DefaultCapacity> mf;
  REQUIRE(indicial::load_runtime_model(text, n, &md) == indicial::LoadStatus::ok);
  REQUIRE(indicial::load_runtime_model(text, n, &mf) == indicial::LoadStatus::ok);
  indicial::FamilyState<double, indicial::DefaultCapacity> sd;
  indicial::FamilyState<float, indicial::DefaultCapacity> sf;
  REQUIRE(indicial::reset(md, sd, 0.2, 30.0) == indicial::StepStatus::ok);
  REQUIRE(indicial::reset(mf, sf, 0.2, 30.0) == indicial::StepStatus::ok);
  double od[3];
  float of[3];
  double worst = 0.0;
  double min_f = 1.0;
  for (int k = 1; k <= 1000; ++k) {
    const double a = 0.3 + 0.12 * std::sin(0.025 * k);
    REQUIRE(indicial::step(md, sd, {a, 0.0, 30.0}, 0.001, od) == indicial::StepStatus::ok);
    REQUIRE(indicial::step(mf, sf, {a, 0.0, 30.0}, 0.001, of) == indicial::StepStatus::ok);
    for (int c = 0; c < 2; ++c) worst = std::fmax(worst, std::fabs(double(of[c]) - od[c]));
    min_f = std::fmin(min_f, sd.stall[0].separation_point);
  }
  CHECK(min_f < 0.5);  // the cycle separates
  CHECK(worst < 1e-3);
}
