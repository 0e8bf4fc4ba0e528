// The simple start of the output-error stepwise (fit_two_stage.cpp restart_simply): when the
// stepwise structure is to be finished on the output-error fit (the fallback, or
// --stepwise-refinement output_error) but the start values give a model whose output is not
// finite, the fit restarts from a plain first-order lag (the pool's lowest a(x) and b1(x)
// terms, by least squares) instead of giving up with exit 4, and says so.
// Data: the report's Model I (Table I: a1, a2, A1 at 25 deg, A3 at 55 deg, b1_0 = 2.5 1/s)
// integrated by the simulator's reference integration (Boost.Odeint), three sines, white noise
// SNR 40; the start that cannot be propagated is a1 = 1e308 (the forcing a(x) x' overflows).
#include <doctest/doctest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "cli_test_support.hpp"
#include "fit_test_data.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/runtime_limits.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;

namespace {

// Model I with a pool around the truth: a0..a2, knots 25, 40, 55 deg, b1_0, b1_1.
Experiment model1_pool(std::uint64_t seed, double* sigma) {
  Experiment e = testing::simulated_experiment("tailless-model-1", 40.0, seed, sigma);
  e.model.structure = StructureMode::stepwise;
  e.model.a = SplineConfig{{0, 1, 2}, {0.4363, 0.6981, 0.9599}, 2};
  e.model.b1 = SplineConfig{{0, 1}, {}, 1};
  return e;
}

}  // namespace

// Both triggers of the output-error stepwise: the fallback (forced with fallback_r_squared = 1:
// every R^2 is below it) and the explicit refinement.
TEST_CASE("a start that cannot be propagated: the output-error stepwise restarts from the simple start") {
  double sigma = 0.0;
  const Experiment e = model1_pool(7301, &sigma);
  FitOptions plain;
  plain.stepwise_refinement = StepwiseRefinement::output_error;
  const FitResult reference = fit_experiment(e, plain);
  REQUIRE(reference.output_error.termination == Termination::converged);
  for (const bool explicit_refinement : {false, true}) {
    FitOptions o;
    if (explicit_refinement) o.stepwise_refinement = StepwiseRefinement::output_error;
    else o.fallback_r_squared = 1.0;
    o.start_values = {{"a1", 1e308}};
    const FitResult r = fit_experiment(e, o);
    CAPTURE(explicit_refinement);
    INFO(r.stepwise_fallback);
    INFO(r.output_error.message);
    CHECK(r.stepwise_fallback.find("the start values cannot be propagated (the start value a1 = 1e+308 gives a "
                                   "model with a non-finite output") != std::string::npos);
    CHECK(r.stepwise_fallback.find("started from the simple start a0 = ") != std::string::npos);
    CHECK(r.stepwise_fallback.find("b1_0 = ") != std::string::npos);
    CHECK(r.stepwise_fallback.find("(least squares of a first-order lag)") != std::string::npos);
    CHECK(r.output_error.termination == Termination::converged);
    CHECK(runtime_acceptance(r.model).capacity != RuntimeCapacity::refused);
    const std::set<std::string> got(r.output_error_stepwise.selected.begin(), r.output_error_stepwise.selected.end());
    std::string list;
    for (const auto& n : got) list += n + " ";
    MESSAGE("simple start -> " << list << "s(v) " << r.fit_error << " (noise " << sigma
                               << ", the regression's start: " << reference.fit_error << ")");
    for (const char* t : {"a1", "a2", "A1", "A3", "b1_0"}) CHECK(got.count(t) == 1);
    CHECK(std::abs(r.fit_error / sigma - 1.0) < 0.1);
    CHECK(r.fit_error <= 1.01 * reference.fit_error);
  }
  // Without an output-error stepwise to run (the regression's selection, fixed afterwards), the
  // start is the user's to fix: exit 4's non-finite fit, as before.
  FitOptions none;
  none.stepwise_fallback = StepwiseFallback::off;
  none.start_values = {{"a1", 1e308}};
  const FitResult kept = fit_experiment(e, none);
  CHECK(!std::isfinite(kept.output_error.cost));
  CHECK(kept.stepwise_fallback.empty());
}

// The CLI: the golden Model I stepwise experiment, --start-value a1=1e308 with the fallback
// forced: exit 0, one note naming the failed start and the simple start, fit.json's
// stepwise_fallback, a model.coef the runtime loads.
TEST_CASE("indicial fit --start-value a1=1e308 on a stepwise fit: the simple start, exit 0, said in fit.json") {
  indicial::testing::TempDir tmp("fallback-start");
  const std::string experiment =
      (std::filesystem::path(INDICIAL_SOURCE_DIR) / "tests" / "golden" / "model1" / "experiment-stepwise.toml")
          .string();
  const indicial::testing::CliRun r = indicial::testing::run_indicial(
      "fit '" + experiment + "' --no-plots --quiet --fallback-r-squared 1 --start-value a1=1e308 --out '" +
          tmp.path.string() + "/out'",
      tmp.path);
  INFO(r.err);
  CHECK(r.exit_code == 0);
  CHECK(r.err.find("indicial: note: ") != std::string::npos);
  CHECK(r.err.find("the start value a1 = 1e+308 gives a model with a non-finite output") != std::string::npos);
  CHECK(r.err.find("started from the simple start a0 = ") != std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(indicial::testing::slurp(tmp.path / "out" / "fit.json"));
  CHECK(j.at("stepwise_fallback").get<std::string>().find("simple start") != std::string::npos);
  CHECK(j.at("termination") == "converged");
  CHECK(j.at("runtime_check").at("loads_with").get<std::string>() != "refused");
}
