// merge_model_sets (fitter/include/indicial/fitter/model_merge.hpp): separately fitted
// coefficients become one model set that the runtime steps from one Predictor, and every
// disagreement between the parts is refused naming the field and both values.
#include <doctest/doctest.h>

#include <cmath>
#include <memory>
#include <string>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/model_merge.hpp"
#include "indicial/fitter/provenance.hpp"
#include "indicial/fitter/simulate.hpp"
#include "indicial/runtime.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace {

using Model = indicial::ModelSet<double, indicial::FitCapacity>;

const Model& truth(const char* name) { return indicial::find_simulation_case(name).truth; }

std::string merge_error(const std::vector<indicial::NamedModelSet>& parts) {
  try {
    indicial::merge_model_sets(parts);
  } catch (const indicial::InputError& e) {
    return e.what();
  }
  FAIL("no InputError thrown");
  return "";
}

}  // namespace

TEST_CASE("merged CL and Cm load in the default runtime and step both outputs from one instance") {
  const Model& cl = truth("f16xl-like-CL");
  const Model& cm = truth("f16xl-like-Cm");
  const indicial::ModelMerge m = indicial::merge_model_sets({{"CL.coef", &cl}, {"Cm.coef", &cm}});
  CHECK(m.warnings.empty());
  REQUIRE(m.model.n_coefficients == 2);
  CHECK(std::string(m.model.coefficients[0].name) == "CL");
  CHECK(std::string(m.model.coefficients[1].name) == "Cm");
  const std::string text = indicial::coef_file_text(m.model, "AB.coef");
  const std::string text_cl = indicial::coef_file_text(cl, "CL.coef");
  const std::string text_cm = indicial::coef_file_text(cm, "Cm.coef");

  // The merged file and each part, in the default runtime.
  auto both = std::make_unique<indicial::Predictor<>>();
  auto only_cl = std::make_unique<indicial::Predictor<>>();
  auto only_cm = std::make_unique<indicial::Predictor<>>();
  REQUIRE(both->load(text.data(), text.size()) == indicial::LoadStatus::ok);
  REQUIRE(only_cl->load(text_cl.data(), text_cl.size()) == indicial::LoadStatus::ok);
  REQUIRE(only_cm->load(text_cm.data(), text_cm.size()) == indicial::LoadStatus::ok);
  const double v = cl.airspeed_mps, kDeg = 3.14159265358979323846 / 180;
  for (auto* p : {both.get(), only_cl.get(), only_cm.get()}) REQUIRE(p->reset(10 * kDeg, v) == indicial::StepStatus::ok);
  double max_diff = 0.0, max_value = 0.0;
  for (int k = 1; k <= 2000; ++k) {
    const double t = k * 1e-3, w = 2 * 3.14159265358979323846 * 0.5;
    const indicial::MotionInput in{(35 - 25 * std::cos(w * t)) * kDeg, 25 * w * std::sin(w * t) * kDeg, v};
    indicial::Predictor<>::Outputs ob, ol, om;
    REQUIRE(both->step(in, 1e-3, &ob) == indicial::StepStatus::ok);
    REQUIRE(only_cl->step(in, 1e-3, &ol) == indicial::StepStatus::ok);
    REQUIRE(only_cm->step(in, 1e-3, &om) == indicial::StepStatus::ok);
    max_diff = std::max({max_diff, std::abs(ob.value[0] - ol.value[0]), std::abs(ob.value[1] - om.value[0])});
    max_value = std::max(max_value, std::abs(ob.value[0]));
  }
  CHECK(max_value > 0.5);   // CL moves: the comparison means something
  CHECK(max_diff == 0.0);   // the same equations on the same numbers
}

TEST_CASE("merge refuses parts that disagree, naming the field and both values") {
  const Model& cl = truth("f16xl-like-CL");
  Model other = truth("f16xl-like-Cm");
  other.airspeed_mps = 30.0;
  CHECK(merge_error({{"CL.coef", &cl}, {"Cm.coef", &other}}) ==
        "Cm.coef: cannot merge: the reference airspeed is 30 m/s here but " +
            indicial::format_double(cl.airspeed_mps) + " m/s in CL.coef");
  other = truth("f16xl-like-Cm");
  other.reference_length_m = 1.5;
  CHECK(merge_error({{"CL.coef", &cl}, {"Cm.coef", &other}}).find("reference_length_m is 1.5 here but") !=
        std::string::npos);
  other = truth("f16xl-like-Cm");
  other.axis = indicial::Axis::roll;
  CHECK(merge_error({{"CL.coef", &cl}, {"Cm.coef", &other}}) ==
        "Cm.coef: cannot merge: the axis is roll here but pitch in CL.coef");
  other = truth("f16xl-like-Cm");
  other.alpha0_rad = 0.5;
  CHECK(merge_error({{"CL.coef", &cl}, {"Cm.coef", &other}}).find("alpha0 is 28.6479 deg here but 0 deg in CL.coef") !=
        std::string::npos);
  CHECK(merge_error({{"CL.coef", &cl}, {"CL2.coef", &cl}}) ==
        "CL2.coef: cannot merge: coefficient CL is already in an earlier file");
  const Model& cm = truth("f16xl-like-Cm");
  CHECK(merge_error({{"a", &cl}, {"b", &cm}, {"c", &cm}, {"d", &cm}}) ==
        "d: cannot merge: 4 coefficients; the runtime (indicial::DefaultCapacity) holds at most 3");
  other = truth("f16xl-like-Cm");
  other.x_min_rad = 1.4;
  other.x_max_rad = 1.5;
  CHECK(merge_error({{"CL.coef", &cl}, {"Cm.coef", &other}}) ==
        "Cm.coef: cannot merge: the envelopes do not overlap (their intersection is [80.2141, 75] deg)");
}

TEST_CASE("merge: the envelope is the intersection, with a warning for each part it shrinks") {
  const Model& cl = truth("f16xl-like-CL");
  Model cm = truth("f16xl-like-Cm");
  cm.x_max_rad = 60.0 * 3.14159265358979323846 / 180;
  const indicial::ModelMerge m = indicial::merge_model_sets({{"CL.coef", &cl}, {"Cm.coef", &cm}});
  CHECK(m.model.x_min_rad == cl.x_min_rad);
  CHECK(m.model.x_max_rad == cm.x_max_rad);
  REQUIRE(m.warnings.size() == 1);
  CHECK(m.warnings[0] == "CL.coef: envelope [-5, 75] deg shrinks to the common [-5, 60] deg in the merged model");
}

// ---- the command line: coef merge, fit with `coefficients`, diagnose's refusal --------------
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "cli_test_support.hpp"
#include "test_support.hpp"

namespace {

namespace fs = std::filesystem;

struct TempDir : indicial::testing::TempDir {
  TempDir() : indicial::testing::TempDir("merge") {}
};

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

// A's run file with B's coefficient column appended (same motions, same times).
void append_column(const fs::path& a, const fs::path& b, const std::string& column) {
  const std::vector<std::string> la = lines_of(indicial::testing::slurp(a)), lb = lines_of(indicial::testing::slurp(b));
  REQUIRE(la.size() == lb.size());
  std::size_t col = 0;
  std::string out;
  for (std::size_t i = 0; i < la.size(); ++i) {
    if (la[i].empty() || la[i][0] == '#') {
      out += la[i] + "\n";
      continue;
    }
    std::vector<std::string> cells;
    std::istringstream ss(lb[i]);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    if (la[i].rfind("time_s", 0) == 0) col = static_cast<std::size_t>(std::find(cells.begin(), cells.end(), column) - cells.begin());
    REQUIRE(col < cells.size());
    out += la[i] + "," + cells[col] + "\n";
  }
  std::ofstream(a) << out;
}

// The experiment's sections from "[static]" on, each renamed [section.coefficient].
std::string sections_for(std::string toml, const std::string& coefficient) {
  toml = toml.substr(toml.find("[static]"));
  for (const char* s : {"[static]", "[rotary]", "[model]"}) {
    const std::size_t at = toml.find(s);
    if (at != std::string::npos) toml.replace(at, std::string(s).size(), std::string(s).insert(std::string(s).size() - 1, "." + coefficient));
  }
  return toml;
}

}  // namespace

TEST_CASE("CLI: coef merge, a two-coefficient fit into one model.coef, diagnose needs --coefficient") {
  using indicial::testing::run_indicial;
  TempDir d;
  const fs::path a = d.path / "A", b = d.path / "B";
  REQUIRE(run_indicial("simulate --case f16xl-like-CL --out " + q(a), d.path).exit_code == 0);
  REQUIRE(run_indicial("simulate --case f16xl-like-Cm --out " + q(b), d.path).exit_code == 0);

  // coef merge of the two truths: one file, both coefficients, loadable by the default runtime.
  auto m = run_indicial("coef merge " + q(a / "truth.coef") + " " + q(b / "truth.coef") + " --out " + q(d.path / "AB.coef"), d.path);
  CHECK(m.exit_code == 0);
  const std::string ab = indicial::testing::slurp(d.path / "AB.coef");
  auto p = std::make_unique<indicial::Predictor<>>();
  REQUIRE(p->load(ab.data(), ab.size()) == indicial::LoadStatus::ok);
  CHECK(p->model().n_coefficients == 2);
  // Where it came from: the version, the command and each input's digest, as a fit's model.coef.
  CHECK(ab.rfind("# indicial ", 0) == 0);
  CHECK_HAS(ab, "# command: ");
  CHECK_HAS(ab, "# input model sha256 " + indicial::sha256_file(a / "truth.coef") + " " + (a / "truth.coef").string());
  CHECK_HAS(ab, "# input model sha256 " + indicial::sha256_file(b / "truth.coef"));
  m = run_indicial("coef merge " + q(a / "truth.coef") + " " + q(a / "truth.coef") + " --out " + q(d.path / "AA.coef"), d.path);
  CHECK(m.exit_code == 1);
  CHECK(m.err == "indicial: error: " + (a / "truth.coef").string() +
                     ": cannot merge: coefficient CL is already in an earlier file\n");
  CHECK_FALSE(fs::exists(d.path / "AA.coef"));
  // --out exists: refused without --force.
  m = run_indicial("coef merge " + q(a / "truth.coef") + " " + q(b / "truth.coef") + " --out " + q(d.path / "AB.coef"), d.path);
  CHECK(m.exit_code == 1);

  // One experiment with both coefficients, from the same runs.
  for (const auto& entry : fs::directory_iterator(a))
    if (entry.path().extension() == ".csv") append_column(entry.path(), b / entry.path().filename(), "Cm");
  std::string top = indicial::testing::slurp(a / "experiment.toml");
  top = top.substr(0, top.find("[static]"));
  const std::size_t at = top.find("coefficient = \"CL\"");
  REQUIRE(at != std::string::npos);
  top.replace(at, 18, "coefficients = [\"CL\", \"Cm\"]");
  const std::string both = top + sections_for(indicial::testing::slurp(a / "experiment.toml"), "CL") + "\n" +
                           sections_for(indicial::testing::slurp(b / "experiment.toml"), "Cm");
  std::ofstream(a / "both.toml") << both;
  const auto f = run_indicial("fit " + q(a / "both.toml") + " --out " + q(d.path / "F") + " --no-plots", d.path);
  INFO(f.err);
  CHECK(f.exit_code == 0);
  const std::string coef = indicial::testing::slurp(d.path / "F" / "model.coef");
  REQUIRE(p->load(coef.data(), coef.size()) == indicial::LoadStatus::ok);
  CHECK(coef.rfind("# indicial ", 0) == 0);  // the merged model.coef carries the fit's provenance
  CHECK_HAS(coef, "# input experiment sha256 " + indicial::sha256_file(a / "both.toml"));
  REQUIRE(p->model().n_coefficients == 2);
  CHECK(std::string(p->model().coefficients[0].name) == "CL");
  CHECK(std::string(p->model().coefficients[1].name) == "Cm");
  const auto j = nlohmann::json::parse(indicial::testing::slurp(d.path / "F" / "fit.json"));
  REQUIRE(j["coefficients"].size() == 2);
  for (const auto& c : j["coefficients"]) {
    for (const char* key : {"coefficient", "directory", "converged", "iterations", "fit_error", "parameters"})
      CHECK(c.contains(key));
    CHECK(fs::exists(d.path / "F" / c["directory"].get<std::string>() / "fit.json"));
  }
  // The merged file holds exactly the per-coefficient fits.
  const std::string cl_alone = indicial::testing::slurp(d.path / "F" / "CL" / "model.coef");
  auto p_cl = std::make_unique<indicial::Predictor<>>();
  REQUIRE(p_cl->load(cl_alone.data(), cl_alone.size()) == indicial::LoadStatus::ok);
  CHECK(p_cl->model().coefficients[0].a.power_coef[1] == p->model().coefficients[0].a.power_coef[1]);

  const auto dg = run_indicial("diagnose " + q(a / "both.toml") + " --out " + q(d.path / "D"), d.path);
  CHECK(dg.exit_code == 1);
  CHECK(dg.err.find("'coefficients' lists several coefficients; this command works on one: name it (e.g. "
                    "--coefficient CL)") != std::string::npos);
}
