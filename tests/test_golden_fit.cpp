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
// Tolerance. On the machine that generated them the files are reproduced bit for bit
// (INDICIAL_GOLDEN_BITWISE=1 checks exactly that: tolerance 0). Across machines they are not:
// on the 2026-11-25 development VM (AMD EPYC, AVX-512, glibc 2.36) the very commit that last
// regenerated them (0438e75) differs from them by up to 1.4e-12 relative in the colored bounds,
// 5e-15 in the estimates and 3.7e-6 in output_error_log's max_step_in_bounds (the size of a
// converged Levenberg-Marquardt step: a difference of nearly equal numbers) and 2.7e-10 in a
// stepwise partial F near 0.1 (the same cancellation), while the current
// code reproduces 0438e75's fit.json on that machine bit for bit. So by default a number must
// agree to 1e-10 relative (1e-4 for max_step_in_bounds, 1e-8 for partial F), model.coef token by
// token to the same 1e-10: a real change of the fitter moves far more than that. A change
// that is MEANT to move the numbers regenerates the expected files (and says why in its commit):
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

double rel_tol_for(const std::string& at) {
  static const bool bitwise = std::getenv("INDICIAL_GOLDEN_BITWISE") != nullptr;
  if (bitwise) return 0.0;
  if (at.find("max_step_in_bounds") != std::string::npos) return 1e-4;
  // A stepwise partial F of a term that explains almost nothing is a difference of nearly
  // equal residual sums (measured 2.7e-10 relative across machines for F = 0.1).
  if (at.find("partial_f") != std::string::npos) return 1e-8;
  return 1e-10;
}

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
  // Warnings name the experiment by its path: compared relative to tests/golden/.
  const std::string root = kGolden.string() + "/";
  if (j.contains("warnings"))
    for (json& w : j["warnings"]) {
      std::string text = w.get<std::string>();
      for (std::size_t at = text.find(root); at != std::string::npos; at = text.find(root))
        text.erase(at, root.size());
      w = text;
    }
  j["exit_code"] = exit_code;
  return j;
}

bool same_number(double a, double b, double rel_tol) {
  if (std::isnan(a) || std::isnan(b)) return std::isnan(a) && std::isnan(b);
  if (rel_tol == 0.0) return a == b;
  return std::abs(a - b) <= rel_tol * std::max(std::abs(a), std::abs(b));
}

// The coefficient files token by token: words exactly, numbers to rel_tol_for("coef").
bool same_coef_text(const std::string& want, const std::string& got) {
  std::istringstream a(want), b(got);
  std::string ta, tb;
  while (true) {
    const bool more_a = static_cast<bool>(a >> ta), more_b = static_cast<bool>(b >> tb);
    if (more_a != more_b) return false;
    if (!more_a) return true;
    if (ta == tb) continue;
    char* end_a = nullptr;
    char* end_b = nullptr;
    const double va = std::strtod(ta.c_str(), &end_a), vb = std::strtod(tb.c_str(), &end_b);
    if (*end_a != '\0' || *end_b != '\0' || !same_number(va, vb, rel_tol_for("coef")))
      return false;
  }
}

// Collects the paths where `got` differs from `want`.
void diff(const json& want, const json& got, const std::string& at, std::vector<std::string>& out) {
  if (want.is_number() && got.is_number()) {
    if (!same_number(want.get<double>(), got.get<double>(), rel_tol_for(at)))
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
    CHECK(same_coef_text(indicial::strip_provenance_header(indicial::testing::slurp(want_coef)),
                         indicial::strip_provenance_header(coef)));
  }
}
