// The diagnose evaluation matrix (tests/diagnose_test_matrix.hpp): ctest runs the representative
// cases here; the whole matrix is bench/experiment_diagnose_matrix.cpp, run by
// tools/diagnose-matrix.sh, which writes the measured table into docs/diagnose.md.
// ctest: skipped under sanitizers -- whole diagnoses of the evaluation matrix, statistics; test_diagnose_effects_a runs diagnose under the sanitizers (tools/run-sanitizers.sh; tests/CMakeLists.txt)
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "diagnose_test_matrix.hpp"
#include "fit_test_data.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

namespace {
MatrixRow check_case(const MatrixCase& mc, const DiagnoseOptions& o = {}) {
  const MatrixRow r = run_matrix_case(mc, o);
  INFO(matrix_row_markdown(r));
  MESSAGE(matrix_row_markdown(r));
  if (mc.expected != "none") CHECK(r.first_right);
  if (mc.expected != "none") CHECK(std::abs(r.final_over_sigma - 1.0) <= 0.15);
  return r;
}
}  // namespace

// The failures, one case each (the matrix runs them all, more seeds and sizes).
TEST_CASE("diagnose matrix subset: Model II's four-knot b1 from the mean angle is b1_alpha") {
  check_case({"Cm", "model2_b1", "b1_alpha", 1.0, MatrixMotion::sine_from_mean, MatrixNoise::white, 11});
}

// The likelihood-ratio rule (what fewer than three runs get): under leave-one-run-out these data
// name `bias` first (the mean of the error, con / b1; fewer parameters) with `static_error`
// within one standard error of it, then `static_error` (docs/diagnose.md, "Which rule decides").
TEST_CASE("diagnose matrix subset: 0.03 sin(3 alpha), nonzero mean, is static_error (likelihood ratio)") {
  DiagnoseOptions lr;
  lr.rule = RuleChoice::likelihood_ratio;
  check_case({"Cm", "static_sin3", "static_error", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 12}, lr);
}

TEST_CASE("diagnose matrix subset: AR(1) noise, a hidden bias is found and nothing more") {
  const MatrixRow r = check_case({"Cm", "bias", "bias", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::ar1, 13});
  CHECK(r.steps == 1);
}

TEST_CASE("diagnose matrix subset: AR(1) 0.8 noise and a complete model: nothing named") {
  int clean = 0;
  const std::vector<std::uint64_t> seeds = test_seeds({21, 22, 23, 24, 25}, 1);
  for (std::uint64_t seed : seeds)
    clean += check_case({"Cm", "none", "none", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::ar1, seed}).first_right;
  CHECK(clean >= static_cast<int>(seeds.size()) - 1);
}
