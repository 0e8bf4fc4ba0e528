// The output-error stepwise fallback (issue 12, item 2): when the equation-error stepwise
// selects no term or explains little (R^2 < FitOptions::fallback_r_squared), the output-error
// stepwise selects the structure, and the fit says so. Data: the dynamic-stall generator
// (dynamic_stall.hpp: a Goman-Khrabrov separation-point truth OUTSIDE the model class,
// integrated accurately, AR(1) phi 0.8 noise on the raw samples, ensemble-averaged cycles of
// 128 samples), its three fit cycles (at one airspeed, below), C_m, SNR 20; the pool a0..a2, knots 10, 14, 17 deg,
// b1_0, b1_1.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cli_test_support.hpp"
#include "indicial/fitter/dynamic_stall.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/runtime_limits.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
namespace ds = indicial::dynamic_stall;

namespace {

// The fit cycles all at 30 m/s (the default campaign has them at 25, 30 and 35 m/s). Why: at
// one airspeed the regression on seed 1 selects nothing, the fallback's first branch; at three
// it selects 6 terms with R^2 0.70 on every seed 1-16 (measured), so the test would only see
// the low-R^2 branch. The phase-averaged cycles are the same either way (same reduced
// frequencies, the noise by seed): the output-error fits end at the same s(v) (seeds 1-5).
Experiment stall_experiment(std::uint64_t seed, const std::string& coefficient) {
  ds::Campaign c = ds::default_campaign();
  for (ds::PitchCycle& p : c.cycles) p.airspeed_mps = c.reference_airspeed_mps;
  const std::vector<ds::PhaseAveragedCycle> cycles = ds::simulate_campaign(c, 20.0, seed, c.default_noise);
  Experiment e = ds::campaign_experiment(c, cycles, coefficient, ds::CycleRole::fit);
  e.model.structure = StructureMode::stepwise;
  e.model.b1.powers = {0, 1};
  return e;
}

FitOptions with_fallback(StepwiseFallback f) {
  FitOptions o;
  o.stepwise_fallback = f;
  return o;
}

}  // namespace

// Seed 1: the regression's first candidate (A3, white F 25) has colored F below 4 -- its
// residual is the unmodelled dynamic stall, correlated over the cycle -- so nothing enters.
// (No ';' in a test name: doctest_discover_tests splits the name there into two ctest tests
// that each run nothing.)
TEST_CASE("fallback: the regression selects no term, the output-error stepwise finds a model the runtime takes") {
  const Experiment e = stall_experiment(1, "Cm");
  CHECK_THROWS_WITH_AS(fit_experiment(e, with_fallback(StepwiseFallback::off)),
                       doctest::Contains("stepwise regression selected no term"), InputError);
  const FitResult r = fit_experiment(e, FitOptions{});
  INFO(r.stepwise_fallback);
  CHECK(r.equation_error.stepwise.selected.empty());
  CHECK(r.stepwise_fallback.find("selected no term") != std::string::npos);
  CHECK(r.stepwise_fallback.find("a0 and b1_0") != std::string::npos);  // where it started
  CHECK(r.output_error.termination == Termination::converged);
  REQUIRE(r.output_error_stepwise.selected.size() >= 3);  // more than the start's two terms
  CHECK(runtime_acceptance(r.model).capacity != RuntimeCapacity::refused);
  // Better than the start model it grew from (a0, b1_0 alone, fixed structure).
  Experiment start = e;
  start.model.structure = StructureMode::fixed;
  start.model.a = SplineConfig{{0}, {}, 2};
  start.model.b1 = SplineConfig{{0}, {}, 1};
  const FitResult s = fit_experiment(start, FitOptions{});
  MESSAGE("fallback s(v) " << r.fit_error << ", start model " << s.fit_error);
  CHECK(r.fit_error < 0.8 * s.fit_error);
}

// Seed 2: the regression selects six terms but explains little (R^2 0.69 < 0.9); the
// output-error stepwise from its selection ends with a lower output error than the
// regression's selection fitted as it is (measured 0.00755 vs 0.00839).
TEST_CASE("fallback: low R^2 -- the output-error stepwise beats the regression's selection") {
  const Experiment e = stall_experiment(2, "Cm");
  const FitResult ee_only = fit_experiment(e, with_fallback(StepwiseFallback::off));
  const FitResult r = fit_experiment(e, FitOptions{});
  INFO(r.stepwise_fallback);
  CHECK(ee_only.stepwise_fallback.empty());
  CHECK(ee_only.output_error_stepwise.steps.empty());
  REQUIRE(r.equation_error.r_squared < FitOptions{}.fallback_r_squared);
  CHECK(r.stepwise_fallback.find("explains little (R^2 = ") != std::string::npos);
  CHECK(r.output_error.termination == Termination::converged);
  CHECK(runtime_acceptance(r.model).capacity != RuntimeCapacity::refused);
  MESSAGE("fallback s(v) " << r.fit_error << ", regression's selection " << ee_only.fit_error);
  CHECK(r.fit_error < 0.95 * ee_only.fit_error);
}

// The CLI: one note line on stderr, fit.json's stepwise_fallback and options, exit 0, and
// --stepwise-fallback off restores the regression's selection (no note, no output-error
// stepwise). The CLI's files carry the fit cycles at 25, 30 and 35 m/s and phase columns
// rounded to their printed digits; on these data the regression selects terms but explains
// little (R^2 0.70 < 0.9), so the fallback's reason is the low R^2.
TEST_CASE("fallback: indicial fit says so on stderr and in fit.json") {
  indicial::testing::TempDir tmp("fallback");
  const std::string exe_dir = tmp.path.string();
  REQUIRE(indicial::testing::run_indicial("simulate --case dynamic-stall --snr 20 --seed 1 --out '" + exe_dir + "/d'",
                                          tmp.path).exit_code == 0);
  std::string toml = indicial::testing::slurp(tmp.path / "d" / "experiment-Cm.toml");
  const auto replace = [&](const std::string& from, const std::string& to) {
    const std::size_t at = toml.find(from);
    REQUIRE(at != std::string::npos);
    toml.replace(at, from.size(), to);
  };
  replace("structure = \"fixed\"", "structure = \"stepwise\"");
  replace("b1_degree = 0", "b1_degree = 1");
  std::ofstream(tmp.path / "d" / "stepwise-Cm.toml") << toml;
  const std::string fit = "fit '" + exe_dir + "/d/stepwise-Cm.toml' --no-plots --quiet --out '" + exe_dir;
  const indicial::testing::CliRun on = indicial::testing::run_indicial(fit + "/on'", tmp.path);
  INFO(on.err);
  CHECK(on.exit_code == 0);
  CHECK(on.err.find("indicial: note: ") != std::string::npos);
  CHECK(on.err.find("stepwise-Cm.toml: the equation-error regression explains little (R^2 = ") != std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(indicial::testing::slurp(tmp.path / "on" / "fit.json"));
  CHECK(j.at("stepwise_fallback").get<std::string>().find("explains little") != std::string::npos);
  CHECK(j.at("options").at("stepwise_fallback") == "automatic");
  CHECK(j.at("output_error_stepwise").at("selected").size() >= 3);
  const indicial::testing::CliRun off =
      indicial::testing::run_indicial(fit + "/off' --stepwise-fallback off", tmp.path);
  INFO(off.err);
  CHECK(off.exit_code == 0);
  CHECK(off.err.find("explains little") == std::string::npos);
  const nlohmann::json k = nlohmann::json::parse(indicial::testing::slurp(tmp.path / "off" / "fit.json"));
  CHECK(k.at("options").at("stepwise_fallback") == "off");
  CHECK(!k.contains("stepwise_fallback"));  // written only when the fallback ran
  CHECK(!k.contains("output_error_stepwise"));
}

// Exit 4, "cannot be propagated" (issue 12, item 2): the message names the start value that
// fails and what to do; --start-value gives one by name.
TEST_CASE("exit 4: the start value that cannot be propagated is named, with what to do") {
  indicial::testing::TempDir tmp("start-value");
  const std::string experiment =
      (std::filesystem::path(INDICIAL_SOURCE_DIR) / "tests" / "golden" / "model1" / "experiment.toml").string();
  const std::string fit = "fit '" + experiment + "' --no-plots --quiet --out '" + tmp.path.string();
  // a1 = 1e308: the forcing a(x) x' overflows, so the lag state is not finite.
  const indicial::testing::CliRun r = indicial::testing::run_indicial(fit + "/big' --start-value a1=1e308", tmp.path);
  INFO(r.err);
  CHECK(r.exit_code == 4);
  CHECK(r.err.find("the start value a1 = 1e+308 gives a model with a non-finite output") != std::string::npos);
  CHECK(r.err.find("What to do: give that start value (fit --start-value NAME=VALUE)") != std::string::npos);
  CHECK(r.err.find("--stepwise-refinement output_error") != std::string::npos);
  CHECK(r.err.find("check the angle and rate units") != std::string::npos);
  // A sensible start value by name is taken (the fit converges from it).
  const indicial::testing::CliRun ok = indicial::testing::run_indicial(fit + "/ok' --start-value b1_0=3", tmp.path);
  INFO(ok.err);
  CHECK(ok.exit_code == 0);
  // Malformed: one line naming the option, exit 1.
  const indicial::testing::CliRun bad = indicial::testing::run_indicial(fit + "/bad' --start-value a1", tmp.path);
  CHECK(bad.exit_code == 1);
  CHECK(bad.err.find("--start-value: expected NAME=VALUE") != std::string::npos);
}
