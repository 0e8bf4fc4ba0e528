// The fitter's behaviour on fixed inputs, pinned: `indicial fit` on the committed data sets
// under tests/golden/ (the report's Model I and II, Table IV's two-stage loop, an F-16XL-like
// C_L, a roll case, and Model I with two lags, a delay, stepwise pools and diagnose's
// extensions) must reproduce the committed fit.json and model.coef.
//
// What is compared: every field of fit.json except the ones that are not the fit's result
// (elapsed_s, the experiment's path as written, plots, the runtime replay check), number by
// number; model.coef line by line; the exit status. The inputs are committed CSVs (simulated
// once with `indicial simulate`/`example`, SNR 40, seed 1), so a change of the simulator does
// not move these goldens -- only a change of the fitter does.
//
// Tolerance: kRelTol = 0, bit-identical. A change that is MEANT to move the numbers regenerates
// the expected files (and says why in its commit):
//   INDICIAL_REGENERATE_GOLDEN=1 build/tests/test_golden_fit
// History: generated before the issue-11 refactor (commit bed4f1f); the refactor reproduced
// them bit for bit with the old power basis (std::pow) and the old residual arithmetic, then
// moved them on purpose (tests/golden/README.md says by how much and why).
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "indicial/fitter/provenance.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
using indicial::testing::TempDir;
using nlohmann::json;

namespace {

constexpr double kRelTol = 0.0;

struct GoldenCase {
  const char* name;        // expected files: tests/golden/expected/NAME.{fit.json,coef}
  const char* experiment;  // relative to tests/golden/
  const char* options;     // extra `indicial fit` options
};

const GoldenCase kCases[] = {
    {"model1", "model1/experiment.toml", ""},
    {"model1-cmq-estimated", "model1/experiment-cmq-estimated.toml", ""},
    {"model1-2lag", "model1/experiment-2lag.toml", ""},
    {"model1-delay", "model1/experiment-delay.toml", ""},
    {"model1-stepwise", "model1/experiment-stepwise.toml", ""},
    {"model1-stepwise-oe", "model1/experiment-stepwise.toml", "--stepwise-refinement output_error"},
    {"model1-extensions", "model1/experiment-extensions.toml", ""},
    {"model1-modulating", "model1/experiment.toml", "--state-derivative modulating"},
    {"model2", "model2/experiment.toml", ""},
    {"f16xl-CL", "f16xl-CL/experiment.toml", ""},
    {"lateral-roll", "lateral-roll/experiment.toml", ""},
};

const fs::path kGolden = fs::path(INDICIAL_SOURCE_DIR) / "tests" / "golden";

// fit.json without what is not the fit's result; the exit status added.
json comparable(const fs::path& fit_json, int exit_code) {
  json j = json::parse(indicial::testing::slurp(fit_json));
  j.erase("elapsed_s");
  j.erase("plots");
  j.erase("runtime_check");
  j.erase("provenance");  // version, commit, command line, input digests: not the fit's result
  if (j.contains("warnings") && j["warnings"].empty()) j.erase("warnings");
  if (j.contains("experiment")) j["experiment"].erase("path");
  j["exit_code"] = exit_code;
  return j;
}

bool same_number(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (kRelTol == 0.0) return a == b;
  return std::abs(a - b) <= kRelTol * std::max(std::abs(a), std::abs(b));
}

// Collects the paths where `got` differs from `want`.
void diff(const json& want, const json& got, const std::string& at, std::vector<std::string>& out) {
  if (want.is_number() && got.is_number()) {
    if (!same_number(want.get<double>(), got.get<double>()))
      out.push_back(at + ": " + want.dump() + " -> " + got.dump());
    return;
  }
  if (want.type() != got.type()) {
    out.push_back(at + ": " + want.dump() + " -> " + got.dump());
    return;
  }
  if (want.is_object()) {
    for (auto it = want.begin(); it != want.end(); ++it) {
      if (!got.contains(it.key())) out.push_back(at + "/" + it.key() + ": missing");
      else diff(it.value(), got[it.key()], at + "/" + it.key(), out);
    }
    for (auto it = got.begin(); it != got.end(); ++it)
      if (!want.contains(it.key())) out.push_back(at + "/" + it.key() + ": new");
    return;
  }
  if (want.is_array()) {
    if (want.size() != got.size()) {
      out.push_back(at + ": " + std::to_string(want.size()) + " -> " +
                    std::to_string(got.size()) + " elements");
      return;
    }
    for (std::size_t i = 0; i < want.size(); ++i)
      diff(want[i], got[i], at + "/" + std::to_string(i), out);
    return;
  }
  if (want != got) out.push_back(at + ": " + want.dump() + " -> " + got.dump());
}

}  // namespace

TEST_CASE("golden: indicial fit reproduces the committed fit.json and model.coef") {
  const bool regenerate = std::getenv("INDICIAL_REGENERATE_GOLDEN") != nullptr;
  TempDir tmp("golden");
  for (const GoldenCase& c : kCases) {
    const std::string name = c.name;
    CAPTURE(name);
    const fs::path out = tmp.path / c.name;
    const indicial::testing::CliRun run = indicial::testing::run_indicial(
        "fit '" + (kGolden / c.experiment).string() + "' --out '" + out.string() +
            "' --no-plots " + c.options,
        tmp.path);
    INFO(run.err);
    REQUIRE(fs::exists(out / "fit.json"));
    const json got = comparable(out / "fit.json", run.exit_code);
    const std::string coef = indicial::testing::slurp(out / "model.coef");
    const fs::path want_json = kGolden / "expected" / (std::string(c.name) + ".fit.json");
    const fs::path want_coef = kGolden / "expected" / (std::string(c.name) + ".coef");
    if (regenerate) {
      fs::create_directories(want_json.parent_path());
      std::ofstream(want_json, std::ios::binary) << got.dump(1) << "\n";
      // Without provenance (and its checksum line), as the comparison below reads it, so a
      // regeneration does not change a .coef file whose model did not move.
      std::ofstream(want_coef, std::ios::binary) << indicial::strip_provenance_header(coef);
      continue;
    }
    std::vector<std::string> differences;
    diff(json::parse(indicial::testing::slurp(want_json)), got, "", differences);
    std::string first;
    for (std::size_t i = 0; i < differences.size() && i < 12; ++i) first += differences[i] + "\n";
    INFO(differences.size() << " differences in fit.json:\n" << first);
    CHECK(differences.empty());
    // The coefficient file apart from provenance: its leading # lines (and so the checksum).
    CHECK(indicial::strip_provenance_header(coef) ==
          indicial::strip_provenance_header(indicial::testing::slurp(want_coef)));
  }
}
