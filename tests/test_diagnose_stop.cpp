// Diagnose says what it could not finish and what it cannot tell apart (issue 13, items 2 and
// 4): the max-steps stop (library, diagnosis.json, stderr, exit status 6), bias named with its
// structural twin (a constant static offset), and the residual signatures of the report.
// ctest: skipped under sanitizers -- four whole diagnoses, 9 minutes under ASan (measured 2026-11-28); test_cmd_diagnose and test_diagnose_effects_a run diagnose there (tools/run-sanitizers.sh; tests/CMakeLists.txt)
#include <doctest/doctest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_test_support.hpp"
#include "diagnose_test_common.hpp"
#include "diagnose_test_matrix.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
using namespace indicial;
using namespace indicial::testing;

namespace {
DiagnoseResult diagnose_case(const MatrixCase& mc, const DiagnoseOptions& o) {
  double sigma = 0.0;
  return diagnose_experiment(matrix_experiment(mc, &sigma), o);
}
}  // namespace

TEST_CASE("diagnose at --max-steps with an effect still significant says so") {
  // Model II's four-knot b1(alpha) needs several b1 terms; one step of one term cannot finish.
  DiagnoseOptions o;
  o.max_steps = 1;
  o.max_family_terms = 1;
  const DiagnoseResult d =
      diagnose_case({"Cm", "model2_b1", "b1_alpha", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 31}, o);
  REQUIRE(d.steps.size() == 1);
  CHECK(d.stopped == DiagnoseStop::max_steps);
  CHECK(!d.still_significant.empty());
  CHECK(d.rounds.back().check_only);
  const nlohmann::json j = diagnosis_json(d, d.experiment, o, nullptr);
  CHECK(j["stopped"] == "max_steps");
  CHECK(j["still_significant"] == d.still_significant);
  // Without the limit the same data end with nothing significant.
  const DiagnoseResult full =
      diagnose_case({"Cm", "model2_b1", "b1_alpha", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 31}, {});
  CHECK(full.stopped == DiagnoseStop::nothing_significant);
  CHECK(full.verdict == "b1_alpha");
}

TEST_CASE("indicial diagnose: exit status 6 and a warning line at --max-steps") {
  const fs::path dir = fs::temp_directory_path() / ("indicial-test-diagnose-stop-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  SimulationCase c = find_simulation_case("tailless-model-2");
  c.experiment.model.b1 = SplineConfig{{0}, {}, 1};  // configured as Model I
  write_simulation_case(c, (dir / "data").string(), 40.0, 5, Overwrite::refuse);
  const CliRun r = run_indicial("diagnose " + (dir / "data" / "experiment.toml").string() + " --out " +
                                    (dir / "out").string() + " --max-steps 1 --max-family-terms 1 --no-plots",
                                dir);
  INFO(r.out, r.err);
  CHECK(r.exit_code == 6);
  CHECK(r.err.find("stopped at --max-steps 1") != std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(slurp(dir / "out" / "diagnosis.json"));
  CHECK(j["stopped"] == "max_steps");
  CHECK(slurp(dir / "out" / "report.md").find("Stopped at --max-steps") != std::string::npos);
  fs::remove_all(dir);
}

TEST_CASE("diagnose names bias with its structural twin, a constant static offset") {
  const DiagnoseResult d = check_single_effect("tailless-model-1", "bias", hidden_effect("bias"), 101);
  REQUIRE(!d.steps.empty());
  const auto& tied = d.steps.front().indistinguishable;
  CHECK(std::find(tied.begin(), tied.end(), Effect::static_error) != tied.end());
}

// The likelihood-ratio rule: under leave-one-run-out these ramps name rotary_alpha alone (the
// second lag's held-out gain is not within one SE of it).
TEST_CASE("diagnose names a small fast second lag on ramps together with its look-alike, a rotary term (likelihood ratio)") {
  DiagnoseOptions lr;
  lr.rule = RuleChoice::likelihood_ratio;
  // b2 = 20 1/s (0.05 s) at half size under AR(1) 0.8 noise: on ramps its response is nearly
  // proportional to the rate, the 0.05 s it continues after a ramp ends is within the noise's
  // correlation time, and the two families' BIC differ by less than indistinguishable_bic.
  const MatrixRow r = run_matrix_case({"Cm", "second_lag", "second_lag", 0.5, MatrixMotion::ramps, MatrixNoise::ar1, 1104}, lr);
  MESSAGE(matrix_row_markdown(r));
  CHECK((r.first_right || r.first_tied));
  const DiagnoseResult d =
      diagnose_case({"Cm", "second_lag", "second_lag", 0.5, MatrixMotion::ramps, MatrixNoise::ar1, 1104}, lr);
  REQUIRE(!d.steps.empty());
  // The other is named, with the experiment that separates each (report.md prints the same).
  const nlohmann::json step = diagnosis_json(d, d.experiment, lr, nullptr)["steps"][0];
  const std::string other = d.verdict == "second_lag" ? "rotary_alpha" : "second_lag";
  const auto& names = step["indistinguishable"];
  const auto it = std::find(names.begin(), names.end(), other);
  REQUIRE(it != names.end());
  const std::string separated = step["indistinguishable_separated_by"][static_cast<std::size_t>(it - names.begin())];
  CHECK(separated == effect_descriptions()[static_cast<std::size_t>(other == "second_lag" ? Effect::second_lag
                                                                                           : Effect::rotary_alpha)]
                         .separated_by);
}

TEST_CASE("residual signatures: a static error depends on the angle alone, a delay on the stroke") {
  DiagnoseOptions o;
  o.max_steps = 0;  // the configured model's residuals only
  const DiagnoseResult st =
      diagnose_case({"Cm", "static_sin3", "static_error", 1.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 41}, o);
  const ResidualSignature s = residual_signature(st.fits.back().runs);
  MESSAGE("static: angle ", s.angle_only, " hysteresis ", s.hysteresis, " rate ", s.rate_in_phase, " const ", s.constant);
  CHECK(s.angle_only > 0.6);
  CHECK(s.angle_only > 2.0 * s.hysteresis);  // the configured fit bends a(x), b1 towards part of it
  const DiagnoseResult de =
      diagnose_case({"Cm", "time_delay", "time_delay", 2.0, MatrixMotion::sine_from_rest, MatrixNoise::white, 42}, o);
  const ResidualSignature g = residual_signature(de.fits.back().runs);
  MESSAGE("delay: angle ", g.angle_only, " hysteresis ", g.hysteresis, " rate ", g.rate_in_phase, " const ", g.constant);
  CHECK(g.hysteresis > g.angle_only);
  // The delay's hysteresis grows with the rate: the fastest run's is the largest.
  CHECK(g.run_hysteresis.back() > g.run_hysteresis.front());
}
