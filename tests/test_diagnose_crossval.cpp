// Diagnose's leave-one-run-out rule (issue 21, item 2; diagnose_crossval.cpp): with three runs
// an effect enters only when it lowers the error of runs left out of its fit. Here the held-out
// test itself and the fallback with too few runs; the rule on simulated turbulence-noise data
// is test_diagnose_crossval_turbulence.cpp.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "diagnose/diagnose_internal.hpp"
#include "indicial/fitter/error.hpp"
#include "diagnose_test_data.hpp"
#include "diagnose_test_matrix.hpp"
#include "fit_test_data.hpp"

TEST_SUITE_BEGIN("statistical");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

namespace {

diagnose_detail::HeldOut held_out(std::vector<double> mse) {
  diagnose_detail::HeldOut h;
  h.mse = std::move(mse);
  h.ok = true;
  return h;
}

}  // namespace

TEST_CASE("held-out test: paired one-standard-error rule with a minimum gain") {
  using diagnose_detail::held_out_test;
  const auto base = held_out({4.0, 1.0, 9.0});
  CHECK(diagnose_detail::majority_improved(2, 3));
  CHECK_FALSE(diagnose_detail::majority_improved(1, 3));
  CHECK_FALSE(diagnose_detail::majority_improved(2, 4));
  // Every run's error halves: enters (the runs' different scales do not matter).
  CHECK(held_out_test(Effect::bias, "con", "first term", base, held_out({2.0, 0.5, 4.5}), 0.10).enters);
  // Better on two runs, much worse on the third: the mean is not below one SE.
  CHECK_FALSE(held_out_test(Effect::bias, "con", "first term", base, held_out({3.0, 0.8, 20.0}), 0.10).enters);
  // Consistently better by 6 %: below the minimum gain (10 %).
  CHECK_FALSE(held_out_test(Effect::bias, "con", "first term", base, held_out({3.76, 0.94, 8.46}), 0.10).enters);
  // Much better on one run, a little worse on two: not a majority.
  CHECK_FALSE(held_out_test(Effect::bias, "con", "first term", base, held_out({0.5, 1.02, 9.1}), 0.10).enters);
  // Much better on two runs, a little worse on the third: enters.
  CHECK(held_out_test(Effect::bias, "con", "first term", base, held_out({1.0, 0.25, 9.1}), 0.10).enters);
  // A fold that could not be scored: cannot enter, and says why.
  diagnose_detail::HeldOut failed = held_out({2.0, 0.5, 4.5});
  failed.ok = false;
  failed.message = "not determined without run 2";
  const HeldOutTest t = held_out_test(Effect::bias, "con", "first term", base, failed, 0.10);
  CHECK_FALSE(t.enters);
  CHECK(t.message == "not determined without run 2");
}

TEST_CASE("too few runs: the rule before issue 21, said to be that") {
  double sigma = 0.0;
  Experiment e = matrix_experiment({"Cm", "none", "none", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 91}, &sigma);
  e.runs.resize(2);
  const DiagnoseResult d = diagnose_experiment(e, DiagnoseOptions{});
  CHECK(d.rule == DecisionRule::lr_residual);
  CHECK(d.rule_reason.find("no replication") != std::string::npos);
  const std::vector<std::string> w = diagnose_warnings(d);
  CHECK(std::any_of(w.begin(), w.end(), [](const std::string& s) { return s.find("without prediction") != std::string::npos; }));
  DiagnoseOptions forced;
  forced.rule = RuleChoice::leave_one_run_out;
  CHECK_THROWS_AS(diagnose_experiment(e, forced), InputError);
}


