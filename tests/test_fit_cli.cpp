// `indicial fit` end to end: the contract fields of fit.json, model.coef in the runtime, the
// report and its plots, output-directory rules, and bad input.
#include <doctest/doctest.h>
#include <unistd.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>

#include "cli_test_support.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/runtime.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;

namespace {

using Run = indicial::testing::CliRun;
using indicial::testing::count_lines;
using indicial::testing::slurp;

const fs::path& scratch() { return indicial::testing::scratch_directory("fit-cli"); }

Run run_cli(const std::string& args) { return indicial::testing::run_indicial(args, scratch()); }

// The simulated data set every test case fits (seed not used by any tuning).
const fs::path& data_dir() {
  static const fs::path dir = [] {
    const fs::path d = scratch() / "data";
    const Run r = run_cli("simulate --case tailless-model-1 --out '" + d.string() + "' --snr 40 --seed 11");
    REQUIRE_MESSAGE(r.exit_code == 0, r.err);
    return d;
  }();
  return dir;
}

const fs::path& fitted_dir() {
  static const fs::path dir = [] {
    const fs::path d = scratch() / "fit";
    const Run r = run_cli("fit '" + (data_dir() / "experiment.toml").string() + "' --out '" + d.string() + "'");
    REQUIRE_MESSAGE(r.exit_code == 0, r.err);
    CHECK(r.out.find("fit: output error converged") != std::string::npos);
    return d;
  }();
  return dir;
}

}  // namespace

TEST_CASE("fit writes fit.json with the contract fields") {
  const nlohmann::json j = nlohmann::json::parse(slurp(fitted_dir() / "fit.json"));
  REQUIRE(j.contains("converged"));
  CHECK(j["converged"].is_boolean());
  CHECK(j["converged"].get<bool>());
  CHECK(j["iterations"].is_number_integer());
  CHECK(j["iterations"].get<int>() >= 1);
  REQUIRE(j["fit_error"].is_number());
  // s(v) near the noise level of SNR 40 on this case (about 0.0036).
  CHECK(j["fit_error"].get<double>() > 0.002);
  CHECK(j["fit_error"].get<double>() < 0.006);
  CHECK(j["termination"] == "converged");
  CHECK_FALSE(j.contains("two_stage"));  // rotary.estimate = false
  REQUIRE(j["parameters"].is_array());
  std::set<std::string> names;
  for (const auto& p : j["parameters"]) {
    REQUIRE(p["name"].is_string());
    names.insert(p["name"].get<std::string>());
    CHECK(p["value"].is_number());
    CHECK(p["cr_bound"].is_number());
    CHECK(p["cr_bound_colored"].is_number());
    CHECK(p["cr_bound"].get<double>() > 0.0);
    CHECK(p["identifiable"].get<bool>());
  }
  for (const char* n : {"a0", "a1", "a2", "A1", "A2", "b1_0", "y0_1", "y0_2", "y0_3"}) CHECK(names.count(n) == 1);
  CHECK(j["equation_error"]["parameters"].is_array());
  CHECK(j["output_error_log"].is_array());
  CHECK(j["elapsed_s"].is_number());
}

TEST_CASE("fit.json agrees with an in-process fit, and model.coef predicts the fitter's model output") {
  using namespace indicial;
  const Experiment e = load_experiment((data_dir() / "experiment.toml").string());
  const FitResult r = fit_experiment(e, FitOptions{});
  const nlohmann::json j = nlohmann::json::parse(slurp(fitted_dir() / "fit.json"));
  REQUIRE(j["parameters"].size() == r.parameters.size());
  for (std::size_t i = 0; i < r.parameters.size(); ++i) {
    CHECK(j["parameters"][i]["name"] == r.parameters[i].name);
    // The same fit: equal to rounding, relative 1e-12 (scale 0; y0_r values are ~1e-4 and CR
    // bounds ~1e-3, on which the former absolute 1e-12 / 1e-9 allowed 1e-8 / 1e-6).
    CHECK(j["parameters"][i]["value"].get<double>() == doctest::Approx(r.parameters[i].value).epsilon(1e-12).scale(0));
    CHECK(j["parameters"][i]["cr_bound"].get<double>() == doctest::Approx(r.parameters[i].cr_bound).epsilon(1e-12).scale(0));
  }
  // Per run: the RMS and the mean of measured - model, from the in-process fit's residuals.
  REQUIRE(j["runs"].size() == r.runs.size());
  for (std::size_t ri = 0; ri < r.runs.size(); ++ri) {
    double sum = 0.0, sum2 = 0.0;
    const auto& s = r.runs[ri];
    for (std::size_t k = 0; k < s.residual.size(); ++k) {
      CHECK(s.residual[k] == doctest::Approx(s.measured[k] - s.model[k]).epsilon(1e-12));
      sum += s.residual[k];
      sum2 += s.residual[k] * s.residual[k];
    }
    const double n = static_cast<double>(s.residual.size());
    CHECK(j["runs"][ri]["mean_residual"].get<double>() == doctest::Approx(sum / n).epsilon(1e-9).scale(1e-15));
    CHECK(j["runs"][ri]["fit_error"].get<double>() == doctest::Approx(std::sqrt(sum2 / n)).epsilon(1e-9));
  }

  // The runtime, written independently of report.cpp's replay: load the file, start each run from
  // its y0_r, step through it and compare every sample with the fitter's model series.
  const std::string text = slurp(fitted_dir() / "model.coef");
  auto p = std::make_unique<Predictor<>>();
  ParseDiagnostic diag;
  REQUIRE_MESSAGE(p->load(text.data(), text.size(), &diag) == LoadStatus::ok, diag.reason);
  REQUIRE(r.runs.size() == e.runs.size());
  double worst = 0.0;
  std::size_t compared = 0;
  for (std::size_t ri = 0; ri < e.runs.size(); ++ri) {
    double y0 = std::nan("");
    for (const auto& q : j["parameters"])
      if (q["name"] == "y0_" + std::to_string(ri + 1)) y0 = q["value"].get<double>();
    REQUIRE(std::isfinite(y0));
    const indicial::Run& run = e.runs[ri];
    REQUIRE(p->reset(run.motion_angle_rad[0], e.airspeed_mps) == StepStatus::ok);
    auto snap = p->snapshot();
    snap.y[0][0] = y0;
    p->restore(snap);
    Predictor<>::Outputs out;
    for (std::size_t k = 1; k < run.size(); ++k) {
      const StepStatus st = p->step({run.motion_angle_rad[k], run.rate_radps[k], e.airspeed_mps},
                                    run.time_s[k] - run.time_s[k - 1], &out);
      REQUIRE((st == StepStatus::ok || st == StepStatus::angle_clamped));
      worst = std::max(worst, std::fabs(out.value[0] - r.runs[ri].model[k]));
      ++compared;
    }
  }
  CHECK(compared > 2000);
  CHECK(worst < 1e-10);
  // The fit reported its own replay too.
  CHECK(j["runtime_check"]["loads_with"] == "default_capacity");
  CHECK(j["runtime_check"]["max_abs_difference"].get<double>() < 1e-10);
}

TEST_CASE("report.md and the plots exist and are referenced") {
  const std::string md = slurp(fitted_dir() / "report.md");
  CHECK(md.find("| parameter | estimate | CR bound") != std::string::npos);
  CHECK(md.find("b1_0") != std::string::npos);
  CHECK(md.find("## Equation error") != std::string::npos);
  CHECK(md.find("## Output-error iterations") != std::string::npos);
  CHECK(md.find("Termination: **converged**") != std::string::npos);
  for (const char* png : {"plots/run1_fit.png", "plots/run1_residual.png", "plots/run3_fit.png",
                          "plots/a_band.png", "plots/b1_band.png", "plots/caq_band.png"}) {
    CAPTURE(png);
    CHECK(fs::exists(fitted_dir() / png));
    CHECK(fs::file_size(fitted_dir() / png) > 1000);
    CHECK(md.find(std::string("](") + png + ")") != std::string::npos);
  }
  // PNG signature.
  CHECK(slurp(fitted_dir() / "plots/a_band.png").substr(1, 3) == "PNG");
}

TEST_CASE("what the readers did with the files travels with the result: fit.json input_notes, report.md") {
  // A run with a column indicial does not read (a rig temperature): the reader's note that it
  // was ignored is in fit.json and report.md, not only on stderr.
  const fs::path d = scratch() / "noted-data";
  fs::remove_all(d);
  fs::copy(data_dir(), d, fs::copy_options::recursive);
  {
    std::istringstream in(slurp(d / "run_f0.25.csv"));
    std::ostringstream out;
    for (std::string line; std::getline(in, line);)
      out << line << (line.empty() || line[0] == '#' ? "" : line.rfind("time_s", 0) == 0 ? ",rig_temp_C" : ",20.5")
          << "\n";
    std::ofstream(d / "run_f0.25.csv") << out.str();
  }
  const fs::path o = scratch() / "noted-fit";
  fs::remove_all(o);
  const Run r = run_cli("fit '" + (d / "experiment.toml").string() + "' --out '" + o.string() + "' --no-plots");
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  CHECK(r.err.find("rig_temp_C") != std::string::npos);  // still said on stderr
  const nlohmann::json j = nlohmann::json::parse(slurp(o / "fit.json"));
  REQUIRE(j["input_notes"].is_array());
  bool noted = false;
  for (const auto& n : j["input_notes"]) noted = noted || n.get<std::string>().find("rig_temp_C") != std::string::npos;
  CHECK(noted);
  const std::string md = slurp(o / "report.md");
  CHECK(md.find("## Notes and warnings") != std::string::npos);
  CHECK(md.find("rig_temp_C") != std::string::npos);
  // A fit whose reader had nothing to say has an empty list and no section.
  CHECK(nlohmann::json::parse(slurp(fitted_dir() / "fit.json"))["input_notes"].empty());
  CHECK(slurp(fitted_dir() / "report.md").find("## Notes and warnings") == std::string::npos);
}

TEST_CASE("without gnuplot everything else is still written and the report says so") {
  const fs::path d = scratch() / "fit-no-gnuplot";
  const Run r = run_cli("fit '" + (data_dir() / "experiment.toml").string() + "' --out '" + d.string() +
                        "' --gnuplot /nonexistent/gnuplot");
  CHECK_MESSAGE(r.exit_code == 0, r.err);
  CHECK(r.err.find("warning") != std::string::npos);
  CHECK(fs::exists(d / "fit.json"));
  CHECK(fs::exists(d / "model.coef"));
  const std::string md = slurp(d / "report.md");
  CHECK(md.find("No plots") != std::string::npos);
  CHECK(md.find("![") == std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "fit.json"));
  CHECK(j["plots"]["status"] == "gnuplot_not_found");
}

// A copy of the data set with the experiment file edited (old -> new, which must occur).
fs::path edited_data(const std::string& name, const std::string& old_text, const std::string& new_text) {
  const fs::path d = scratch() / name;
  fs::create_directories(d);
  for (const auto& ent : fs::directory_iterator(data_dir()))
    fs::copy_file(ent.path(), d / ent.path().filename(), fs::copy_options::overwrite_existing);
  std::string toml = slurp(d / "experiment.toml");
  const std::size_t at = toml.find(old_text);
  REQUIRE(at != std::string::npos);
  toml.replace(at, old_text.size(), new_text);
  { std::ofstream(d / "experiment.toml", std::ios::trunc) << toml; }
  return d;
}

TEST_CASE("stepwise structure: the report and fit.json carry every step of the log") {
  const fs::path d = edited_data("data-stepwise", "structure = \"fixed\"", "structure = \"stepwise\"");
  const Run r = run_cli("fit '" + (d / "experiment.toml").string() + "' --out '" + (d / "fit").string() + "' --no-plots");
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "fit" / "fit.json"));
  const auto& steps = j["equation_error"]["stepwise"]["steps"];
  REQUIRE(steps.is_array());
  REQUIRE(steps.size() >= 1);
  for (const auto& st : steps) {
    CHECK(st["term"].is_string());
    CHECK(st["partial_f"].is_number());
    CHECK(st["r_squared"].is_number());
    CHECK(st["pse"].is_number());
  }
  const std::string md = slurp(d / "fit" / "report.md");
  CHECK(md.find("### Stepwise regression") != std::string::npos);
  CHECK(md.find("| step | term | action | partial F | R^2 | PSE |") != std::string::npos);
  CHECK(md.find("Selected at the minimum PSE") != std::string::npos);
  CHECK_FALSE(j.contains("output_error_stepwise"));
  CHECK(j["options"]["stepwise_refinement"] == "none");
  // --stepwise-refinement output_error: fit.json carries the refinement and its selection.
  const Run refined = run_cli("fit '" + (d / "experiment.toml").string() + "' --out '" +
                              (d / "fit-oe").string() + "' --no-plots --stepwise-refinement output_error");
  REQUIRE_MESSAGE(refined.exit_code == 0, refined.err);
  const nlohmann::json jr = nlohmann::json::parse(slurp(d / "fit-oe" / "fit.json"));
  CHECK(jr["options"]["stepwise_refinement"] == "output_error");
  REQUIRE(jr.contains("output_error_stepwise"));
  CHECK(jr["output_error_stepwise"]["steps"].is_array());
  CHECK(jr["output_error_stepwise"]["selected"].size() >= 2);
  const Run bad = run_cli("fit '" + (d / "experiment.toml").string() + "' --out '" +
                          (d / "fit-bad").string() + "' --stepwise-refinement sometimes");
  // A usage error: exit 1 and one line naming the option (docs/bad-inputs.md), not merely
  // non-zero (a crash is -1 here and passed that).
  CHECK(bad.exit_code == 1);
  INFO(bad.err);
  CHECK(bad.err.find("--stepwise-refinement") != std::string::npos);
  CHECK(count_lines(bad.err) == 1);
  CHECK_FALSE(fs::exists(d / "fit-bad"));
}

TEST_CASE("rotary.estimate = true: fit.json has the two_stage log and report.md the loop's table") {
  const fs::path d = edited_data("data-two-stage", "polynomial = [-2, 0, 0.8]  # x^0, x^1, ... with x in rad\nestimate = false",
                                 "polynomial = [-1.4]\nestimate = true\ndegree = 2");
  const Run r = run_cli("fit '" + (d / "experiment.toml").string() + "' --out '" + (d / "fit").string() + "'");
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "fit" / "fit.json"));
  REQUIRE(j.contains("two_stage"));
  REQUIRE(j["two_stage"].is_array());
  REQUIRE(j["two_stage"].size() >= 1);
  CHECK(j["two_stage"].size() <= 5);
  for (const auto& it : j["two_stage"]) {
    CHECK(it["iteration"].is_number_integer());
    CHECK(it["cost"].is_number());
    CHECK(it["rotary"].is_array());
  }
  // The final C_aq near the truth -2 + 0.8 x^2 (x^0 and x^2 terms; x^1 small or absent).
  const auto& rot = j["rotary"]["polynomial"];
  REQUIRE(rot.size() >= 3);
  auto estimate = [&](const std::string& name) {
    for (const auto& p : j["parameters"])
      if (p["name"] == name) return std::make_pair(p["value"].get<double>(), p["cr_bound"].get<double>());
    FAIL("fit.json has no parameter " << name);
    return std::make_pair(0.0, 0.0);
  };
  const auto c0 = estimate("Caq_0"), c2 = estimate("Caq_2");
  INFO("Caq_0 " << c0.first << " (" << c0.second << "), Caq_2 " << c2.first << " (" << c2.second << ")");
  // Within 3 Cramer-Rao bounds of the truth (the former epsilon(0.05) / (0.1) with doctest's
  // default scale allowed 0.15 and 0.18: 7 % and 22 %).
  CHECK(std::abs(rot[0].get<double>() + 2.0) < 3.0 * c0.second);
  CHECK(std::abs(rot[2].get<double>() - 0.8) < 3.0 * c2.second);
  CHECK(rot[0].get<double>() == c0.first);  // the model's C_aq is the estimate
  CHECK(rot[2].get<double>() == c2.first);
  const std::string md = slurp(d / "fit" / "report.md");
  CHECK(md.find("## Two-stage loop") != std::string::npos);
  CHECK(fs::exists(d / "fit" / "plots" / "caq_band.png"));
}

TEST_CASE("a non-empty output directory is refused without --force, and replaced with it only when indicial wrote every file") {
  const fs::path d = scratch() / "busy";
  fs::create_directories(d);
  { std::ofstream(d / "keep.txt") << "precious\n"; }
  const std::string base = "fit '" + (data_dir() / "experiment.toml").string() + "' --out '" + d.string() + "'";
  const Run refused = run_cli(base);
  CHECK(refused.exit_code == 1);
  CHECK(count_lines(refused.err) == 1);
  CHECK(refused.err.find("not empty") != std::string::npos);
  CHECK(slurp(d / "keep.txt") == "precious\n");
  std::size_t entries = 0;
  for (const auto& ent : fs::directory_iterator(d)) (void)ent, ++entries;
  CHECK(entries == 1);
  // No staging directory left beside it.
  for (const auto& ent : fs::directory_iterator(scratch()))
    CHECK(ent.path().filename().string().find(".busy.staging") == std::string::npos);

  // --force never deletes a file indicial did not write: keep.txt is named, nothing touched.
  const Run foreign = run_cli(base + " --force");
  CHECK(foreign.exit_code == 1);
  CHECK(count_lines(foreign.err) == 1);
  CHECK(foreign.err.find("files indicial did not write") != std::string::npos);
  CHECK(foreign.err.find("keep.txt") != std::string::npos);
  CHECK(slurp(d / "keep.txt") == "precious\n");

  // A directory of indicial's outputs is replaced with --force.
  fs::remove(d / "keep.txt");
  const Run first = run_cli(base);
  CHECK_MESSAGE(first.exit_code == 0, first.err);
  CHECK(fs::exists(d / ".indicial-outputs"));
  const Run forced = run_cli(base + " --force");
  CHECK_MESSAGE(forced.exit_code == 0, forced.err);
  CHECK(fs::exists(d / "fit.json"));
  CHECK(fs::exists(d / "model.coef"));
  CHECK(fs::exists(d / "report.md"));
}

TEST_CASE("a missing experiment file gives one line naming it, exit 1, nothing written") {
  const fs::path d = scratch() / "never";
  const Run r = run_cli("fit '" + (scratch() / "no-such-experiment.toml").string() + "' --out '" + d.string() + "'");
  CHECK(r.exit_code == 1);
  CHECK(count_lines(r.err) == 1);
  CHECK(r.err.find("no-such-experiment.toml") != std::string::npos);
  CHECK_FALSE(fs::exists(d));
}

TEST_CASE("a bad experiment (unknown key) gives one line naming the file and exit 1") {
  const fs::path bad = data_dir().parent_path() / "bad-data";
  fs::create_directories(bad);
  for (const auto& ent : fs::directory_iterator(data_dir())) fs::copy_file(ent.path(), bad / ent.path().filename(),
                                                                           fs::copy_options::overwrite_existing);
  { std::ofstream(bad / "experiment.toml", std::ios::app) << "\nunknown_key = 3\n"; }
  const Run r = run_cli("fit '" + (bad / "experiment.toml").string() + "' --out '" + (scratch() / "bad-out").string() + "'");
  CHECK(r.exit_code == 1);
  CHECK(count_lines(r.err) == 1);
  CHECK(r.err.find("experiment.toml") != std::string::npos);
  CHECK_FALSE(fs::exists(scratch() / "bad-out"));
}

TEST_CASE("an iteration limit still writes the best estimate, exits 0 and warns") {
  const fs::path d = scratch() / "fit-limited";
  const Run r = run_cli("fit '" + (data_dir() / "experiment.toml").string() + "' --out '" + d.string() +
                        "' --max-iterations 1 --no-plots");
  CHECK_MESSAGE(r.exit_code == 0, r.err);
  const nlohmann::json j = nlohmann::json::parse(slurp(d / "fit.json"));
  if (j["termination"] == "iteration_limit") {
    CHECK_FALSE(j["converged"].get<bool>());
    CHECK(r.err.find("warning") != std::string::npos);
    CHECK(r.err.find("iteration limit") != std::string::npos);
  } else {
    // A start from the equation-error estimates may already satisfy the tests in one step.
    CHECK(j["termination"] == "converged");
  }
  CHECK(j["parameters"].size() > 5);
  CHECK(fs::exists(d / "model.coef"));
}

TEST_CASE("bad option values are refused with one line") {
  const Run r = run_cli("fit '" + (data_dir() / "experiment.toml").string() + "' --out '" +
                        (scratch() / "opt-out").string() + "' --state-derivative wavelet");
  CHECK(r.exit_code == 1);
  CHECK(count_lines(r.err) == 1);
  CHECK(r.err.find("--state-derivative") != std::string::npos);
}

TEST_CASE("an option out of its range is FitOptions::IsValid's line, exit 1, nothing written") {
  // One check for the library, the command line and Python (fitter/src/estimate/fit_options.cpp):
  // the command line reports IsValid's own line, word for word, before it reads the experiment.
  struct Case {
    const char* flags;
    std::function<void(indicial::FitOptions&)> set;
  };
  const Case cases[] = {
      {"--f-to-enter 2 --f-to-remove 3", [](indicial::FitOptions& o) { o.f_to_enter = 2.0, o.f_to_remove = 3.0; }},
      {"--max-iterations -1", [](indicial::FitOptions& o) { o.max_iterations = -1; }},
      {"--fallback-r-squared 1.5", [](indicial::FitOptions& o) { o.fallback_r_squared = 1.5; }},
      {"--start-value b1_0=nan", [](indicial::FitOptions& o) { o.start_values = {{"b1_0", std::nan("")}}; }},
  };
  for (const Case& c : cases) {
    indicial::FitOptions o;
    c.set(o);
    std::string expected;
    REQUIRE_FALSE(o.IsValid(&expected));
    const fs::path out = scratch() / "range-out";
    const Run r = run_cli("fit '" + (data_dir() / "no-such-experiment.toml").string() + "' --out '" + out.string() +
                          "' " + c.flags);
    INFO(c.flags, ": ", r.err);
    CHECK(r.exit_code == 1);
    CHECK(r.err == "indicial: error: " + expected + "\n");  // before the (missing) experiment is read
    CHECK_FALSE(fs::exists(out));
  }
}
