// The `indicial diagnose` command (tools/cmd_diagnose.cpp) end to end: contract fields of
// diagnosis.json, model.coef loaded by the runtime, report and plots, output-directory rules.
// Two hidden effects at once in the library are test_diagnose_two_effects.cpp.
#include <doctest/doctest.h>
#include <unistd.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "cli_test_support.hpp"
#include "diagnose_test_common.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/simulate.hpp"
#include "indicial/runtime.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
using namespace indicial;
using namespace indicial::testing;

// ------------------------------------------------------------------------------------------
namespace {
using Cmd = CliRun;
const fs::path& scratch() { return scratch_directory("diagnose"); }
Cmd run(const std::string& args) { return run_indicial(args, scratch()); }
}  // namespace

TEST_CASE("indicial diagnose: contract outputs, model.coef in the runtime, directory rules") {
  // Data: Model I with a hidden delay, written as run CSVs + experiment.toml.
  const SimulationCase& base = find_simulation_case("tailless-model-1");
  SimulationCase c = base;
  c.truth.coefficients[0].delay_s = 0.02;
  const fs::path data = scratch() / "data";
  write_simulation_case(c, data.string(), 40.0, 7, Overwrite::refuse);
  const fs::path out = scratch() / "diag";
  const Cmd d = run("diagnose " + (data / "experiment.toml").string() + " --out " + out.string());
  INFO(d.out, d.err);
  REQUIRE(d.exit_code == 0);
  const nlohmann::json j = nlohmann::json::parse(slurp(out / "diagnosis.json"));
  for (const char* k : {"initial_fit_error", "noise_estimate", "steps", "final_fit_error", "verdict"})
    CHECK(j.contains(k));
  CHECK(j["verdict"] == "time_delay");
  // The search's limits at their defaults (docs/formats.md).
  CHECK(j["max_steps"] == 6);
  CHECK(j["knot_spacing_deg"].get<double>() == 5.0);
  CHECK(j["max_family_terms"] == 4);
  CHECK(j["stall_start_search"] == "configured");
  REQUIRE(j["steps"].size() >= 1);
  for (const char* k : {"effect", "detail", "statistic", "p_value", "fit_error_before", "fit_error_after"})
    CHECK(j["steps"][0].contains(k));
  CHECK(j["steps"][0]["detail"].get<std::string>().rfind("delay ", 0) == 0);
  CHECK(j["final_fit_error"].get<double>() < j["initial_fit_error"].get<double>());
  // The final model loads in the runtime (default capacity) and carries the delay.
  const std::string coef = slurp(out / "model.coef");
  auto p = std::make_unique<Predictor<double, DefaultCapacity>>();
  CHECK(p->load(coef.data(), coef.size()) == LoadStatus::ok);
  CHECK(coef.find("delay_s") != std::string::npos);
  CHECK(j["runtime_check"]["fit"] == "default_capacity");
  CHECK(j["runtime_check"]["max_abs_difference"].get<double>() < 1e-9);
  // report.md: the step table and the plots.
  const std::string md = slurp(out / "report.md");
  CHECK(md.find("| step | effect | detail |") != std::string::npos);
  CHECK(md.find("time_delay") != std::string::npos);
  CHECK(fs::exists(out / "plots" / "plots.gp"));
  if (md.find("plots/step1_time.png") != std::string::npos) {
    CHECK(fs::file_size(out / "plots" / "step1_time.png") > 0);
    CHECK(fs::file_size(out / "plots" / "step1_angle.png") > 0);
  }
  // DIR/experiment.toml: the diagnosed model as an experiment file (extension keys); `indicial
  // fit` on it refits the same model: the same parameters, the same estimates to well inside
  // their bounds (the optimizer's tolerance).
  const std::string next = slurp(out / "experiment.toml");
  CHECK(next.find("delay = \"estimated\"") != std::string::npos);
  const fs::path refit = scratch() / "refit";
  const Cmd f = run("fit " + (out / "experiment.toml").string() + " --out " + refit.string() + " --no-plots");
  INFO(f.out, f.err);
  REQUIRE(f.exit_code == 0);
  const nlohmann::json fj = nlohmann::json::parse(slurp(refit / "fit.json"));
  REQUIRE(fj["parameters"].size() == j["final_parameters"].size());
  for (const auto& est : j["final_parameters"]) {
    const std::string name = est["name"].get<std::string>();
    const auto q = std::find_if(fj["parameters"].begin(), fj["parameters"].end(),
                                [&](const nlohmann::json& x) { return x["name"] == name; });
    REQUIRE_MESSAGE(q != fj["parameters"].end(), "fit.json lacks " << name);
    const double diff = std::abs((*q)["value"].get<double>() - est["value"].get<double>());
    INFO(name << ": diagnose " << est["value"] << ", refit " << (*q)["value"] << ", bound " << est["cr_bound"]);
    CHECK(diff < 0.05 * est["cr_bound"].get<double>());
  }
  // No overwrite without --force; with --force it is replaced.
  const Cmd again = run("diagnose " + (data / "experiment.toml").string() + " --out " + out.string());
  CHECK(again.exit_code == 1);
  CHECK(again.err.find("indicial: error:") != std::string::npos);
  // The in-sample materiality floor (--min-in-sample-gain, default 0.04) is in diagnosis.json
  // and is used: the delay lowers the MSE of the fit to all three runs by ~88 % (ln ratio -2.1),
  // so a floor of 95 % names nothing. With --force the outputs are replaced.
  CHECK(j["cv_min_in_sample_gain"].get<double>() == doctest::Approx(0.04));
  const Cmd forced = run("diagnose " + (data / "experiment.toml").string() + " --out " + out.string() +
                         " --force --alpha 0.001 --min-in-sample-gain 0.95 --no-plots --max-steps 1"
                         " --knot-spacing-deg 20 --max-family-terms 1");
  INFO(forced.out, forced.err);
  CHECK(forced.exit_code == 0);
  const nlohmann::json jf = nlohmann::json::parse(slurp(out / "diagnosis.json"));
  CHECK(jf["cv_min_in_sample_gain"].get<double>() == doctest::Approx(0.95));
  CHECK(jf["verdict"] == "none");
  const Cmd floor1 = run("diagnose " + (data / "experiment.toml").string() + " --out " +
                         (scratch() / "floor1").string() + " --min-in-sample-gain 1");
  CHECK(floor1.exit_code == 1);
  CHECK(floor1.err.find("--min-in-sample-gain") != std::string::npos);
  CHECK(!fs::exists(scratch() / "floor1"));
  // Bad input: one line, exit 1, nothing written.
  const Cmd bad = run("diagnose " + (scratch() / "missing.toml").string() + " --out " +
                      (scratch() / "none").string());
  CHECK(bad.exit_code == 1);
  CHECK(!fs::exists(scratch() / "none"));
  const Cmd help = run("diagnose --help");
  CHECK(help.exit_code == 0);
  CHECK(help.out.find("--alpha") != std::string::npos);
  CHECK(help.out.find("--min-in-sample-gain") != std::string::npos);
}

TEST_CASE("indicial diagnose: the written experiment.toml keeps the run files' [columns] and [csv]") {
  // Runs as a database writes them: whitespace-delimited, the header a `%` comment line, the
  // angle under the database's own name (Model I, SNR 40). Before, diagnose's experiment.toml
  // dropped [columns] and [csv], and `indicial fit` on it could not read these runs.
  const SimulationCase& c = find_simulation_case("tailless-model-1");
  const fs::path sim = scratch() / "db-sim";
  write_simulation_case(c, sim.string(), 40.0, 1, Overwrite::replace);
  const fs::path data = scratch() / "db-data";
  fs::create_directories(data);
  std::string runs;
  for (const auto& entry : fs::directory_iterator(sim)) {
    if (entry.path().extension() != ".csv") continue;
    std::istringstream in(slurp(entry.path()));
    std::ofstream out(data / entry.path().filename().replace_extension(".dat"));
    std::string line;
    while (std::getline(in, line)) {
      if (line.empty() || line[0] == '#') continue;
      std::replace(line.begin(), line.end(), ',', ' ');
      if (line.rfind("time_s", 0) == 0) line = "% time_s AoA(deg) q_degps Cm Cm_true y_true";
      out << line << "\n";
    }
    runs += (runs.empty() ? "\"" : ", \"") + entry.path().filename().replace_extension(".dat").string() + "\"";
  }
  const std::string toml = slurp(sim / "experiment.toml");
  const std::string head = "runs = [" + runs + "]\n\n[columns]\nalpha_deg = \"AoA(deg)\"\n\n[csv]\n"
                           "delimiter = \"whitespace\"\ncomment = \"%\"\n";
  const std::size_t r0 = toml.find("runs = ["), r1 = toml.find('\n', r0);
  REQUIRE(r0 != std::string::npos);
  std::ofstream(data / "experiment.toml") << toml.substr(0, r0) + head + toml.substr(r1 + 1);
  const fs::path out = scratch() / "db-diag";
  const Cmd d = run("diagnose " + (data / "experiment.toml").string() + " --out " + out.string() +
                    " --no-plots --max-steps 1 --force");
  INFO(d.out, d.err);
  REQUIRE(d.exit_code == 0);
  const std::string next = slurp(out / "experiment.toml");
  CHECK(next.find("[columns]\nalpha_deg = \"AoA(deg)\"\n") != std::string::npos);
  CHECK(next.find("[csv]\ndelimiter = \"whitespace\"\ncomment = \"%\"\n") != std::string::npos);
  const Cmd f = run("fit " + (out / "experiment.toml").string() + " --out " + (scratch() / "db-refit").string() +
                    " --no-plots --force");
  INFO(f.out, f.err);
  CHECK(f.exit_code == 0);
}

TEST_CASE("indicial diagnose: the rule's options reach diagnosis.json, a bad one is refused") {
  // Model I with a hidden delay, three runs (leave-one-run-out by default).
  SimulationCase c = find_simulation_case("tailless-model-1");
  c.truth.coefficients[0].delay_s = 0.02;
  const fs::path data = scratch() / "options-data";
  write_simulation_case(c, data.string(), 40.0, 7, Overwrite::refuse);
  const std::string experiment = (data / "experiment.toml").string();
  // Every option away from its default (--min-gain 0.2 and --min-in-sample-gain 0.05: the
  // delay gains ~88 % in sample, far more held out, so it still enters; a coarse knot grid and
  // one term per effect: fewer candidate fits, the delay is no knot; --stall-start-search grid:
  // this model has no stall family, so it is only recorded).
  const fs::path cv = scratch() / "options-cv";
  const Cmd d = run("diagnose " + experiment + " --out " + cv.string() +
                    " --no-plots --quiet --max-steps 1 --rule cv --max-folds 2 --min-gain 0.2"
                    " --min-in-sample-gain 0.05 --threads 1 --knot-spacing-deg 20 --max-family-terms 1"
                    " --stall-start-search grid");
  INFO(d.out, d.err);
  REQUIRE(d.exit_code != 1);
  const nlohmann::json j = nlohmann::json::parse(slurp(cv / "diagnosis.json"));
  CHECK(j["rule"] == "leave_one_run_out");
  CHECK(j["cv_folds"] == 2);  // three runs dealt into two folds
  CHECK(j["cv_min_gain"].get<double>() == 0.2);
  CHECK(j["cv_min_in_sample_gain"].get<double>() == 0.05);
  CHECK(j["threads"] == 1);
  CHECK(j["max_steps"] == 1);
  CHECK(j["knot_spacing_deg"].get<double>() == 20.0);
  CHECK(j["max_family_terms"] == 1);
  CHECK(j["stall_start_search"] == "grid");
  // Each round says on what share of each run its held-out errors were taken (runs of one motion
  // share their angle range: every sample).
  REQUIRE(!j["rounds"].empty());
  const auto& shares = j["rounds"][0]["held_out_scored_fraction"];
  REQUIRE(shares.size() == 3);
  for (const auto& s : shares) CHECK(s.get<double>() == 1.0);
  CHECK(j["test"].get<std::string>().find("ln(1 - 0.2)") != std::string::npos);
  CHECK(j["cv_min_gain_applied"].get<double>() == 0.2);  // three runs: the minimum as given
  CHECK(j["verdict"] == "time_delay");
  // report.md says the LR columns did not decide a held-out step (their p-value may exceed its
  // threshold); under --rule lr they did, and nothing says otherwise.
  const std::string report_cv = slurp(cv / "report.md");
  CHECK(report_cv.find("This diagnose decided by held-out error") != std::string::npos);
  CHECK(report_cv.find("they did not decide it)") != std::string::npos);
  // --rule lr: the likelihood ratio decides even with three runs; no cross-validation keys.
  const fs::path lr = scratch() / "options-lr";
  const Cmd l = run("diagnose " + experiment + " --out " + lr.string() +
                    " --no-plots --quiet --max-steps 1 --rule lr --knot-spacing-deg 20 --max-family-terms 1");
  INFO(l.out, l.err);
  REQUIRE(l.exit_code != 1);
  const nlohmann::json jl = nlohmann::json::parse(slurp(lr / "diagnosis.json"));
  CHECK(jl["rule"].get<std::string>().rfind("lr_", 0) == 0);
  CHECK(!jl.contains("cv_folds"));
  CHECK(!jl.contains("cv_min_gain"));
  CHECK(jl["threads"] == 2);
  CHECK(jl["stall_start_search"] == "configured");  // diagnose's default
  CHECK(slurp(lr / "report.md").find("did not decide") == std::string::npos);
  // A bad value: DiagnoseOptions::IsValid's line, exit 1, nothing written.
  for (const char* bad : {"--min-gain 1", "--max-folds 1", "--threads 0"}) {
    const fs::path none = scratch() / "options-none";
    const Cmd b = run("diagnose " + experiment + " --out " + none.string() + " " + bad);
    INFO(bad, ": ", b.err);
    CHECK(b.exit_code == 1);
    CHECK(b.err.rfind("indicial: error: ", 0) == 0);
    CHECK(count_lines(b.err) == 1);
    CHECK(b.err.find(std::string(bad).substr(0, std::string(bad).find(' '))) != std::string::npos);
    CHECK(!fs::exists(none));
  }
  CHECK(run("diagnose --help").out.find("--min-gain") != std::string::npos);
  // --cv-min-runs: with 4 runs required, the three runs are too few for cross-validation: `auto`
  // falls back to the likelihood ratio (the reason asks for 4 runs), `cv` is an error naming 4,
  // and 1 (below IsValid's range) is IsValid's line.
  const fs::path few = scratch() / "options-few";
  const Cmd f = run("diagnose " + experiment + " --out " + few.string() + " --no-plots --quiet --max-steps 0 --cv-min-runs 4");
  INFO(f.out, f.err);
  REQUIRE(f.exit_code == 0);
  const nlohmann::json jfew = nlohmann::json::parse(slurp(few / "diagnosis.json"));
  CHECK(jfew["rule"].get<std::string>().rfind("lr_", 0) == 0);
  CHECK(jfew["rule_reason"].get<std::string>().find("give 4 or more runs") != std::string::npos);
  const Cmd cv4 = run("diagnose " + experiment + " --out " + (scratch() / "options-cv4").string() +
                      " --no-plots --quiet --rule cv --cv-min-runs 4");
  CHECK(cv4.exit_code == 1);
  CHECK(cv4.err.find("leave_one_run_out needs at least 4 runs (--cv-min-runs); the experiment has 3") !=
        std::string::npos);
  CHECK(!fs::exists(scratch() / "options-cv4"));
  const Cmd one = run("diagnose " + experiment + " --out " + (scratch() / "options-one").string() + " --cv-min-runs 1");
  CHECK(one.exit_code == 1);
  CHECK(one.err == "indicial: error: cv_min_runs (--cv-min-runs): must be >= 2 (runs: one left out, one fitted), "
                   "found 1\n");
  CHECK(!fs::exists(scratch() / "options-one"));
}
