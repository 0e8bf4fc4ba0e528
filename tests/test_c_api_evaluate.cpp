// indicial_evaluate (runtime/src/indicial_c.cpp): the outputs of a state without stepping it,
// "what indicial predict writes at its first sample" (indicial.h), here outside the fitted
// envelope, where a static TABLE is evaluated at the angle itself and the rest at the edge
// (runtime.hpp warning 3). A user's trial (2026-11-27) found the C API's and the FMU's first
// output at a reset outside the envelope holding the table at the edge (0.6708 against the
// step's and predict's 0.9259): the state kept only the clamped angle.
#include <doctest/doctest.h>

#include <cmath>
#include <string>

#include "indicial/coef_file.hpp"
#include "indicial/indicial.h"
#include "indicial/runtime.hpp"
#include "runtime_test_models.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace {
constexpr double kPi = 3.14159265358979323846;

// The lift-and-moment test model (C_L from a static table over 0..70 deg) with its envelope,
// the training data's angle range, cut to 0..30 deg; as coefficient-file text.
std::string narrow_envelope_model() {
  auto set = indicial::test_models::lift_and_moment();
  set.x_min_rad = 0.0;
  set.x_max_rad = 30 * kPi / 180;
  static char buffer[65536];
  std::size_t n = 0;
  REQUIRE(indicial::write_coef_file(set, buffer, sizeof buffer, &n) == indicial::WriteStatus::ok);
  return std::string(buffer, n);
}
}  // namespace

TEST_CASE("indicial_evaluate outside the envelope: the static table at the angle itself, as a step gives it") {
  const std::string text = narrow_envelope_model();
  alignas(16) static double model[1 << 14];
  REQUIRE(indicial_model_bytes() <= sizeof model);
  char error[256];
  REQUIRE(indicial_model_load(model, text.data(), text.size(), error, sizeof error) == INDICIAL_OK);
  alignas(16) static double state[64], stepped[64];
  REQUIRE(indicial_state_bytes(model) <= sizeof state);
  const double v = 17.667762, x45 = 45 * kPi / 180, x30 = 30 * kPi / 180;
  double at_reset[2], after_step[2], evaluated_after_step[2], at_edge[2];
  CHECK(indicial_reset(model, state, x45, v) == INDICIAL_ANGLE_CLAMPED);
  REQUIRE(indicial_evaluate(model, state, 0.0, v, at_reset) == INDICIAL_OK);
  // A step to the same angle at rest leaves the steady state as it is: its output is what the
  // state's evaluation must be.
  REQUIRE(indicial_reset(model, stepped, x45, v) == INDICIAL_ANGLE_CLAMPED);
  CHECK(indicial_step(model, stepped, x45, 0.0, v, 0.01, after_step) == INDICIAL_ANGLE_CLAMPED);
  for (int c = 0; c < 2; ++c) CHECK(at_reset[c] == doctest::Approx(after_step[c]).epsilon(1e-12));
  REQUIRE(indicial_evaluate(model, stepped, 0.0, v, evaluated_after_step) == INDICIAL_OK);
  for (int c = 0; c < 2; ++c) CHECK(evaluated_after_step[c] == after_step[c]);
  // And it is not the value at the edge: the table is past its peak there (0.1+ lower).
  alignas(16) static double edge[64];
  REQUIRE(indicial_reset(model, edge, x30, v) == INDICIAL_OK);
  REQUIRE(indicial_evaluate(model, edge, 0.0, v, at_edge) == INDICIAL_OK);
  CHECK(at_reset[0] < at_edge[0] - 0.1);
  CHECK(at_reset[1] == doctest::Approx(at_edge[1]).epsilon(1e-12));  // C_m: a fitted polynomial, held at the edge
}
