// The diagnose evaluation matrix (tests/diagnose_test_matrix.hpp). The whole matrix is the
// skipped test case below, run by tools/diagnose-matrix.sh (doctest --no-skip), which writes the
// measured table into docs/diagnose.md; ctest runs the representative cases.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "diagnose_test_matrix.hpp"
#include "fit_test_data.hpp"

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

// Environment: INDICIAL_DIAGNOSE_MATRIX = quick | full (default quick),
// INDICIAL_DIAGNOSE_MATRIX_OUT = the Markdown file to write (default diagnose-matrix.md),
// INDICIAL_DIAGNOSE_MATRIX_SHARD = "i/n" to run cases i, i + n, ... (the script runs shards in
// parallel and merges them).
TEST_CASE("diagnose matrix: every effect x motion x size x noise x coefficient" * doctest::skip()) {
  const char* mode_env = std::getenv("INDICIAL_DIAGNOSE_MATRIX");
  const char* out_env = std::getenv("INDICIAL_DIAGNOSE_MATRIX_OUT");
  const char* shard_env = std::getenv("INDICIAL_DIAGNOSE_MATRIX_SHARD");  // "i/n": every n-th case from i
  const bool quick = !(mode_env && std::string(mode_env) == "full");
  const std::string out_path = out_env ? out_env : "diagnose-matrix.md";
  int shard = 0, shards = 1;
  if (shard_env) REQUIRE(std::sscanf(shard_env, "%d/%d", &shard, &shards) == 2);
  std::ofstream out(out_path);
  REQUIRE(out.good());
  out << matrix_header_markdown() << std::flush;
  int effect_cases = 0, first_right = 0, first_tied = 0, within = 0, null_cases = 0, null_clean = 0;
  std::vector<double> times;
  const std::vector<MatrixCase> cases = diagnose_matrix(quick);
  for (std::size_t i = static_cast<std::size_t>(shard); i < cases.size(); i += static_cast<std::size_t>(shards)) {
    const MatrixCase& mc = cases[i];
    const MatrixRow r = run_matrix_case(mc);
    out << matrix_row_markdown(r) << std::flush;
    MESSAGE(matrix_row_markdown(r));
    times.push_back(r.seconds);
    if (mc.expected == "none") {
      ++null_cases;
      null_clean += r.first == "none" ? 1 : 0;
    } else {
      ++effect_cases;
      first_right += r.first_right ? 1 : 0;
      first_tied += r.first_tied ? 1 : 0;
      within += std::abs(r.final_over_sigma - 1.0) <= 0.15 ? 1 : 0;
    }
  }
  std::sort(times.begin(), times.end());
  out << fmt::format(
      "\nSummary ({}): first named effect right in {} of {} effect cases ({} more named as "
      "indistinguishable from the first); final fit error within 15 % "
      "of the noise level in {} of {}; no effect named in {} of {} null cases (colored noise); "
      "diagnose time median {:.1f} s, max {:.1f} s.\n",
      quick ? "quick" : "full", first_right, effect_cases, first_tied, within, effect_cases, null_clean, null_cases,
      times.empty() ? 0.0 : times[times.size() / 2], times.empty() ? 0.0 : times.back());
}

// The size of each hidden effect: the configured model's fit error / sigma (no diagnose step).
TEST_CASE("diagnose matrix: effect sizes (initial fit error / sigma)" * doctest::skip()) {
  DiagnoseOptions o;
  o.max_steps = 0;
  for (const char* coef : {"Cm", "CL"})
    for (const EffectDescription& ef : effect_descriptions())
      for (MatrixMotion mo : {MatrixMotion::sine_from_rest, MatrixMotion::sine_from_mean, MatrixMotion::ramps}) {
        const MatrixRow r = run_matrix_case({coef, ef.name, ef.name, 1.0, mo, MatrixNoise::white, 7}, o);
        const std::string line = std::string(coef) + " " + ef.name + " " + matrix_motion_name(mo) +
                                 ": initial / sigma " + std::to_string(r.initial_over_sigma);
        MESSAGE(line);
      }
}
