// The line `indicial diagnose` prints per step (diagnose_step_line): what decided it, and every
// effect the data cannot tell from it by name (it said "another effect" before: a user had to
// open report.md to learn which).
#include <doctest/doctest.h>

#include <string>

#include "indicial/fitter/diagnose.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

namespace {

DiagnoseStep step_of(Effect e, DecisionRule rule) {
  DiagnoseStep s;
  s.step = 1;
  s.effect = e;
  s.detail = "T_d";
  s.rule = rule;
  s.held_out_log_ratio = -0.25;
  s.held_out_standard_error = 0.05;
  s.statistic = 42.0;
  s.log10_p = -9.0;
  s.threshold = 0.01;
  s.fit_error_before = 0.2;
  s.fit_error_after = 0.1;
  return s;
}

bool has(const std::string& s, const std::string& part) { return s.find(part) != std::string::npos; }

}  // namespace

TEST_CASE("diagnose step line: the effects the data cannot tell apart are named") {
  DiagnoseStep s = step_of(Effect::time_delay, DecisionRule::leave_one_run_out);
  s.indistinguishable = {Effect::b1_alpha, Effect::second_lag};
  const std::string line = diagnose_step_line(s);
  INFO(line);
  CHECK(has(line, "step 1: time_delay (T_d)"));
  CHECK(has(line, "held-out mean ln(MSE ratio) -0.250 +- 0.050"));
  CHECK(has(line, "fit error 0.2 -> 0.1"));
  CHECK(has(line, "indistinguishable on these data from b1_alpha, second_lag"));
  CHECK_FALSE(has(line, "another effect"));
}

TEST_CASE("diagnose step line: the likelihood-ratio rule, nothing tied") {
  const std::string line = diagnose_step_line(step_of(Effect::time_delay, DecisionRule::lr_residual));
  INFO(line);
  CHECK(has(line, "LR/kappa 42.0, log10 p -9.0 < -2.00"));
  CHECK_FALSE(has(line, "indistinguishable"));
}
