// test_fmu.cpp -- `indicial fmu` checked by an FMI 2.0 importer of our own: unzip the package
// (the `unzip` tool, an independent zip reader), parse modelDescription.xml with libxml2 and
// check it against the rules of the FMI 2.0 schema and standard that the unit relies on,
// dlopen the binary, run the whole call sequence on a motion with variable steps and compare
// every output with `indicial predict` on the same motion; then the bad call sequences, bad
// values and damaged packages, each of which must give fmi2Error (or NULL) and never crash.
#include <dlfcn.h>
#include <libxml/parser.h>
#include <libxml/tree.h>

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <doctest/doctest.h>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "fmi2.h"
#include "fmu_layout.hpp"
#include "indicial/indicial.h"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
using indicial::testing::run_indicial;
using indicial::testing::slurp;

namespace {

const fs::path& dir() { return indicial::testing::scratch_directory("fmu"); }

// ---- the importer's memory and logger callbacks --------------------------------------------
long g_live_allocations = 0;
std::vector<std::string> g_log;

void* test_allocate(size_t n, size_t size) {
  void* p = std::calloc(n, size);
  if (p != nullptr) ++g_live_allocations;
  return p;
}
void test_free(void* p) {
  if (p != nullptr) --g_live_allocations;
  std::free(p);
}
void test_logger(fmi2ComponentEnvironment, fmi2String name, fmi2Status status, fmi2String category,
                 fmi2String message, ...) {
  char text[2048];
  va_list args;
  va_start(args, message);
  std::vsnprintf(text, sizeof text, message, args);
  va_end(args);
  g_log.push_back(std::string(name) + " [" + category + "/" + std::to_string(status) + "] " + text);
}
const fmi2CallbackFunctions g_callbacks = {test_logger, test_allocate, test_free, nullptr, nullptr};

bool logged(const std::string& part) {
  for (const std::string& l : g_log)
    if (l.find(part) != std::string::npos) return true;
  return false;
}

// ---- the binary: every function an FMI 2.0 co-simulation slave must export ------------------
struct Api {
  void* handle = nullptr;
#define INDICIAL_FMI2_FN(name) decltype(&::name) name = nullptr;
#define INDICIAL_FMI2_FUNCTIONS(X)                                                                         \
  X(fmi2GetTypesPlatform) X(fmi2GetVersion) X(fmi2SetDebugLogging) X(fmi2Instantiate) X(fmi2FreeInstance) \
  X(fmi2SetupExperiment) X(fmi2EnterInitializationMode) X(fmi2ExitInitializationMode) X(fmi2Terminate)    \
  X(fmi2Reset) X(fmi2GetReal) X(fmi2GetInteger) X(fmi2GetBoolean) X(fmi2GetString) X(fmi2SetReal)         \
  X(fmi2SetInteger) X(fmi2SetBoolean) X(fmi2SetString) X(fmi2GetFMUstate) X(fmi2SetFMUstate)              \
  X(fmi2FreeFMUstate) X(fmi2SerializedFMUstateSize) X(fmi2SerializeFMUstate) X(fmi2DeSerializeFMUstate)   \
  X(fmi2GetDirectionalDerivative) X(fmi2SetRealInputDerivatives) X(fmi2GetRealOutputDerivatives)          \
  X(fmi2DoStep) X(fmi2CancelStep) X(fmi2GetStatus) X(fmi2GetRealStatus) X(fmi2GetIntegerStatus)           \
  X(fmi2GetBooleanStatus) X(fmi2GetStringStatus)
  INDICIAL_FMI2_FUNCTIONS(INDICIAL_FMI2_FN)
};

Api load_api(const fs::path& so) {
  Api a;
  a.handle = ::dlopen(so.c_str(), RTLD_NOW | RTLD_LOCAL);
  REQUIRE_MESSAGE(a.handle != nullptr, ::dlerror());
#define INDICIAL_FMI2_SYM(name)                                               \
  a.name = reinterpret_cast<decltype(a.name)>(::dlsym(a.handle, #name));     \
  CHECK_MESSAGE(static_cast<bool>(a.name != nullptr), "the FMU does not export " #name);
  INDICIAL_FMI2_FUNCTIONS(INDICIAL_FMI2_SYM)
  return a;
}

// ---- modelDescription.xml ------------------------------------------------------------------
struct Variable {
  std::string name, causality, variability, initial, type;
  unsigned vr = 0;
  bool has_start = false;
  double start = 0.0;
};

struct Description {
  std::string fmi_version, guid, model_identifier;
  std::map<std::string, std::string> co_simulation;  // its attributes
  std::vector<Variable> variables;                     // index i+1
  std::vector<int> outputs, initial_unknowns;          // ModelStructure indices
  std::set<std::string> units;
  std::map<int, std::string> output_dependencies;
};

std::string attr(xmlNode* n, const char* name, bool* present = nullptr) {
  xmlChar* v = xmlGetProp(n, reinterpret_cast<const xmlChar*>(name));
  if (present != nullptr) *present = v != nullptr;
  std::string s = v != nullptr ? reinterpret_cast<const char*>(v) : "";
  xmlFree(v);
  return s;
}

bool is(xmlNode* n, const char* name) {
  return n->type == XML_ELEMENT_NODE && std::strcmp(reinterpret_cast<const char*>(n->name), name) == 0;
}

std::vector<xmlNode*> children(xmlNode* n, const char* name = nullptr) {
  std::vector<xmlNode*> r;
  for (xmlNode* c = n->children; c != nullptr; c = c->next)
    if (c->type == XML_ELEMENT_NODE && (name == nullptr || is(c, name))) r.push_back(c);
  return r;
}

Variable read_variable(xmlNode* sv) {
  Variable v;
  v.name = attr(sv, "name");
  v.vr = static_cast<unsigned>(std::stoul(attr(sv, "valueReference")));
  v.causality = attr(sv, "causality");
  v.variability = attr(sv, "variability");
  v.initial = attr(sv, "initial");
  const auto types = children(sv);
  REQUIRE_MESSAGE(types.size() == 1, (v.name + ": a ScalarVariable has exactly one type element"));
  v.type = reinterpret_cast<const char*>(types[0]->name);
  const std::string start = attr(types[0], "start", &v.has_start);
  if (v.has_start) v.start = std::stod(start);
  return v;
}

// The element order fmiModelDescription's xs:sequence prescribes (fmi2ModelDescription.xsd).
const std::vector<std::string> kTopOrder = {"ModelExchange",  "CoSimulation",      "UnitDefinitions",
                                            "TypeDefinitions", "LogCategories",     "DefaultExperiment",
                                            "VendorAnnotations", "ModelVariables", "ModelStructure"};

Description parse_description(const fs::path& xml) {
  xmlDoc* doc = xmlReadFile(xml.c_str(), nullptr, XML_PARSE_NONET);
  REQUIRE_MESSAGE(doc != nullptr, "modelDescription.xml is not well-formed XML");
  xmlNode* root = xmlDocGetRootElement(doc);
  REQUIRE(is(root, "fmiModelDescription"));
  Description d;
  d.fmi_version = attr(root, "fmiVersion");
  d.guid = attr(root, "guid");
  CHECK(!attr(root, "modelName").empty());
  std::size_t last = 0;
  for (xmlNode* c : children(root)) {
    const auto it = std::find(kTopOrder.begin(), kTopOrder.end(), reinterpret_cast<const char*>(c->name));
    REQUIRE_MESSAGE(it != kTopOrder.end(), (std::string("unknown element ") + reinterpret_cast<const char*>(c->name)));
    const auto pos = static_cast<std::size_t>(it - kTopOrder.begin());
    CHECK_MESSAGE(pos >= last, "elements out of the schema's order");
    last = pos;
    if (is(c, "CoSimulation")) {
      for (xmlAttr* a = c->properties; a != nullptr; a = a->next)
        d.co_simulation[reinterpret_cast<const char*>(a->name)] = attr(c, reinterpret_cast<const char*>(a->name));
      d.model_identifier = attr(c, "modelIdentifier");
    } else if (is(c, "UnitDefinitions")) {
      for (xmlNode* u : children(c, "Unit")) d.units.insert(attr(u, "name"));
    } else if (is(c, "ModelVariables")) {
      for (xmlNode* sv : children(c)) {
        REQUIRE(is(sv, "ScalarVariable"));
        d.variables.push_back(read_variable(sv));
      }
    } else if (is(c, "ModelStructure")) {
      for (xmlNode* part : children(c)) {
        for (xmlNode* u : children(part, "Unknown")) {
          const int index = std::stoi(attr(u, "index"));
          if (is(part, "Outputs")) {
            d.outputs.push_back(index);
            bool has = false;
            const std::string deps = attr(u, "dependencies", &has);
            if (has) d.output_dependencies[index] = deps;
          } else if (is(part, "InitialUnknowns")) {
            d.initial_unknowns.push_back(index);
          }
        }
      }
    }
  }
  xmlFreeDoc(doc);
  return d;
}

// The FMI 2.0 rules on variables (section 2.2.7, "combinations of variability/causality" and
// "initial") that this unit's variables fall under, and the ModelStructure rules.
void check_description_rules(const Description& d) {
  CHECK(d.fmi_version == "2.0");
  CHECK(d.guid.size() + 1 == indicial::fmu::kGuidChars);
  CHECK(d.co_simulation.at("canHandleVariableCommunicationStepSize") == "true");
  CHECK(d.co_simulation.at("canGetAndSetFMUstate") == "false");
  std::set<std::string> names;
  std::map<std::string, std::set<unsigned>> vrs;  // per base type
  std::vector<int> expected_outputs, expected_initial;
  for (std::size_t i = 0; i < d.variables.size(); ++i) {
    const Variable& v = d.variables[i];
    INFO("variable " << v.name);
    CHECK(names.insert(v.name).second);
    CHECK(vrs[v.type].insert(v.vr).second);
    CHECK((v.type == "Real" || v.type == "Integer"));
    if (v.causality == "input") {
      CHECK(v.has_start);  // an input needs a start value
      CHECK((v.variability == "continuous" || v.variability == "discrete"));
      CHECK(v.initial.empty());  // initial is not allowed on inputs
    } else if (v.causality == "parameter") {
      CHECK((v.variability == "fixed" || v.variability == "tunable"));
      CHECK((v.initial.empty() || v.initial == "exact"));
      CHECK(v.has_start);
    } else if (v.causality == "output") {
      CHECK((v.initial.empty() || v.initial == "calculated"));
      CHECK(!v.has_start);  // calculated: no start value
      CHECK(((v.type == "Real" && v.variability == "continuous") || v.variability == "discrete"));
      expected_outputs.push_back(static_cast<int>(i + 1));
      expected_initial.push_back(static_cast<int>(i + 1));
    } else {
      FAIL("unexpected causality " << v.causality);
    }
  }
  CHECK(d.outputs == expected_outputs);            // every output, in index order
  CHECK(d.initial_unknowns == expected_initial);   // outputs with initial calculated
  for (const auto& [index, deps] : d.output_dependencies) CHECK_MESSAGE(deps.empty(), index);
  CHECK(d.units.count("rad") == 1);
  CHECK(d.units.count("rad/s") == 1);
  CHECK(d.units.count("m/s") == 1);
}

const Variable& variable(const Description& d, const std::string& name) {
  for (const Variable& v : d.variables)
    if (v.name == name) return v;
  FAIL("no variable " << name);
  return d.variables.front();
}

// ---- the motion and `indicial predict` ------------------------------------------------------
struct Motion {
  std::vector<double> t_s, alpha_rad, q_radps;
};

// A pitch oscillation with a jittered time grid (variable communication steps) that dips
// below the envelope's lower end (clamped samples) at the trough.
Motion make_motion() {
  Motion m;
  double t = 0.0;
  for (int i = 0; i < 400; ++i) {
    const double w = 2.0 * M_PI * 1.3;
    m.t_s.push_back(t);
    m.alpha_rad.push_back(0.35 + 0.38 * std::sin(w * t));
    m.q_radps.push_back(0.38 * w * std::cos(w * t));
    t += 0.004 + 0.0015 * std::sin(0.7 * i) * std::sin(0.7 * i);
  }
  return m;
}

void write_motion_csv(const Motion& m, const fs::path& p) {
  std::ofstream f(p);
  f << "time_s,alpha_rad,q_radps\n";
  char line[128];
  for (std::size_t i = 0; i < m.t_s.size(); ++i) {
    std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g\n", m.t_s[i], m.alpha_rad[i], m.q_radps[i]);
    f << line;
  }
}

// Columns of a CSV written by predict (comment lines skipped).
std::map<std::string, std::vector<double>> read_csv(const fs::path& p) {
  std::ifstream f(p);
  std::string line;
  std::vector<std::string> header;
  std::map<std::string, std::vector<double>> cols;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> cells;
    std::size_t start = 0;
    for (std::size_t k = 0; k <= line.size(); ++k)
      if (k == line.size() || line[k] == ',') {
        cells.push_back(line.substr(start, k - start));
        start = k + 1;
      }
    if (header.empty()) {
      header = cells;
      continue;
    }
    for (std::size_t c = 0; c < cells.size(); ++c) cols[header[c]].push_back(std::stod(cells[c]));
  }
  return cols;
}

// ---- one unpacked FMU ------------------------------------------------------------------------
const std::string kModel = std::string(INDICIAL_SOURCE_DIR) + "/examples/synthetic-lift-moment.coef";
const double kAirspeed = 25.0;

struct Unpacked {
  fs::path root;
  Description d;
  Api api;
  std::string resources_uri() const { return "file://" + (root / "resources").string(); }
};

Unpacked unpack(const fs::path& fmu, const std::string& name) {
  Unpacked u;
  u.root = dir() / name;
  fs::remove_all(u.root);
  const std::string cmd = "unzip -q '" + fmu.string() + "' -d '" + u.root.string() + "'";
  REQUIRE(std::system(cmd.c_str()) == 0);
  u.d = parse_description(u.root / "modelDescription.xml");
  const fs::path so = u.root / "binaries" / "linux64" / (u.d.model_identifier + ".so");
  REQUIRE(fs::exists(so));
  u.api = load_api(so);
  return u;
}

Unpacked make_fmu(const std::string& model, const std::string& fmu_name, const std::string& name) {
  const auto r = run_indicial("fmu '" + model + "' --out '" + (dir() / fmu_name).string() + "'", dir());
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  return unpack(dir() / fmu_name, name);
}

const Unpacked& lift_fmu() {
  static const Unpacked u = make_fmu(kModel, "lift moment.fmu", "lift");
  return u;
}

fmi2Component instantiate(const Unpacked& u, const std::string& name = "test") {
  return u.api.fmi2Instantiate(name.c_str(), fmi2CoSimulation, u.d.guid.c_str(), u.resources_uri().c_str(),
                               &g_callbacks, fmi2False, fmi2False);
}

fmi2Status set_real(const Unpacked& u, fmi2Component c, unsigned vr, double v) {
  return u.api.fmi2SetReal(c, &vr, 1, &v);
}

// Instantiated, set up at t0, initialised at the motion's first sample; the outputs there.
fmi2Component start_at(const Unpacked& u, const Motion& m, double t0_s) {
  fmi2Component c = instantiate(u);
  REQUIRE(c != nullptr);
  const auto& a = u.api;
  REQUIRE(a.fmi2SetupExperiment(c, fmi2False, 0.0, t0_s, fmi2False, 0.0) == fmi2OK);
  REQUIRE(a.fmi2EnterInitializationMode(c) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "initial_alpha_rad").vr, m.alpha_rad[0]) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "initial_airspeed_mps").vr, kAirspeed) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "alpha_rad").vr, m.alpha_rad[0]) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "q_radps").vr, m.q_radps[0]) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "airspeed_mps").vr, kAirspeed) == fmi2OK);
  REQUIRE(a.fmi2ExitInitializationMode(c) == fmi2OK);
  return c;
}

// Outputs at every sample: row i holds CL, Cm, step_status.
std::vector<std::vector<double>> simulate(const Unpacked& u, fmi2Component c, const Motion& m, double t0_s) {
  const auto& a = u.api;
  const unsigned out_vr[2] = {variable(u.d, "CL").vr, variable(u.d, "Cm").vr};
  const unsigned in_vr[2] = {variable(u.d, "alpha_rad").vr, variable(u.d, "q_radps").vr};
  const unsigned status_vr = variable(u.d, "step_status").vr;
  std::vector<std::vector<double>> rows;
  for (std::size_t i = 0; i < m.t_s.size(); ++i) {
    if (i > 0) {
      const double in[2] = {m.alpha_rad[i], m.q_radps[i]};
      REQUIRE(a.fmi2SetReal(c, in_vr, 2, in) == fmi2OK);
      // The master's time t0 + t[i-1] and step t[i] - t[i-1]: the FMU must accept the rounding.
      REQUIRE(a.fmi2DoStep(c, t0_s + m.t_s[i - 1], m.t_s[i] - m.t_s[i - 1], fmi2True) == fmi2OK);
    }
    double out[2];
    int status = -99;
    REQUIRE(a.fmi2GetReal(c, out_vr, 2, out) == fmi2OK);
    REQUIRE(a.fmi2GetInteger(c, &status_vr, 1, &status) == fmi2OK);
    rows.push_back({out[0], out[1], static_cast<double>(status)});
  }
  return rows;
}

}  // namespace

TEST_CASE("fmu: the package holds the description, the linux64 binary and the model byte for byte") {
  const Unpacked& u = lift_fmu();
  CHECK(u.d.model_identifier == "lift_moment");
  CHECK(slurp(u.root / "resources" / "model.coef") == slurp(kModel));
  check_description_rules(u.d);
  CHECK(variable(u.d, "airspeed_mps").start == doctest::Approx(17.667762).epsilon(1e-15));
  CHECK(variable(u.d, "CL").vr == indicial::fmu::vr_first_coefficient);
  CHECK(std::string(u.api.fmi2GetVersion()) == "2.0");
  CHECK(std::string(u.api.fmi2GetTypesPlatform()) == "default");
}

// `indicial predict` on the motion, at kAirspeed, as columns.
std::map<std::string, std::vector<double>> predict(const std::string& model, const Motion& m) {
  write_motion_csv(m, dir() / "motion.csv");
  const auto r = run_indicial("predict '" + model + "' '" + (dir() / "motion.csv").string() + "' --out '" +
                                  (dir() / "predicted.csv").string() +
                                  "' --time-grid nonuniform --airspeed-mps 25 --force",
                              dir());
  REQUIRE_MESSAGE(r.exit_code == 0, r.err);
  return read_csv(dir() / "predicted.csv");
}

TEST_CASE("fmu: outputs match indicial predict to 1e-12 with variable communication steps, and after reset") {
  const Unpacked& u = lift_fmu();
  const Motion m = make_motion();
  auto predicted = predict(kModel, m);
  REQUIRE(predicted["CL_pred"].size() == m.t_s.size());
  // A start time that is not 0 and not exactly representable: t0 + t[i] rounds.
  const double t0_s = 1234.567;
  fmi2Component c = start_at(u, m, t0_s);
  const auto rows = simulate(u, c, m, t0_s);
  double worst = 0.0;
  int clamped = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    worst = std::max({worst, std::fabs(rows[i][0] - predicted["CL_pred"][i]),
                      std::fabs(rows[i][1] - predicted["Cm_pred"][i])});
    clamped += rows[i][2] == 1.0;
    CHECK(rows[i][2] >= 0.0);
  }
  CHECK(worst <= 1e-12);
  CHECK(clamped > 0);  // the motion leaves the envelope: step_status says so
  MESSAGE("largest |FMU - predict| over " << rows.size() << " samples: " << worst);
  // Terminate, reset, run again: the same numbers bit for bit.
  CHECK(u.api.fmi2Terminate(c) == fmi2OK);
  CHECK(u.api.fmi2Reset(c) == fmi2OK);
  const auto& a = u.api;
  REQUIRE(a.fmi2SetupExperiment(c, fmi2False, 0.0, t0_s, fmi2False, 0.0) == fmi2OK);
  REQUIRE(a.fmi2EnterInitializationMode(c) == fmi2OK);
  // After fmi2Reset the parameters are back at their start values: set them again.
  double v = 0.0;
  const unsigned airspeed_vr = variable(u.d, "airspeed_mps").vr;
  REQUIRE(a.fmi2GetReal(c, &airspeed_vr, 1, &v) == fmi2OK);
  CHECK(v == variable(u.d, "airspeed_mps").start);
  REQUIRE(set_real(u, c, variable(u.d, "initial_alpha_rad").vr, m.alpha_rad[0]) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "initial_airspeed_mps").vr, kAirspeed) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "alpha_rad").vr, m.alpha_rad[0]) == fmi2OK);
  REQUIRE(set_real(u, c, variable(u.d, "q_radps").vr, m.q_radps[0]) == fmi2OK);
  REQUIRE(set_real(u, c, airspeed_vr, kAirspeed) == fmi2OK);
  REQUIRE(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(simulate(u, c, m, t0_s) == rows);
  u.api.fmi2FreeInstance(c);
  CHECK(g_live_allocations == 0);
}

TEST_CASE("fmu: a dynamic-stall model (separation and vortex families) matches indicial predict too") {
  const std::string model = std::string(INDICIAL_SOURCE_DIR) + "/examples/dynamic-stall-lift-moment.coef";
  const Unpacked u = make_fmu(model, "stall.fmu", "stall");
  check_description_rules(u.d);
  const Motion m = make_motion();
  auto predicted = predict(model, m);
  fmi2Component c = start_at(u, m, 0.0);
  const auto rows = simulate(u, c, m, 0.0);
  double worst = 0.0;
  for (std::size_t i = 0; i < rows.size(); ++i)
    worst = std::max({worst, std::fabs(rows[i][0] - predicted["CL_pred"][i]),
                      std::fabs(rows[i][1] - predicted["Cm_pred"][i])});
  CHECK(worst <= 1e-12);
  MESSAGE("dynamic stall: largest |FMU - predict| over " << rows.size() << " samples: " << worst);
  u.api.fmi2FreeInstance(c);
  CHECK(g_live_allocations == 0);
}

TEST_CASE("fmu: a step longer than the runtime's 1 s is equal sub-steps with the inputs held") {
  const Unpacked& u = lift_fmu();
  Motion m;
  m.t_s = {0.0};
  m.alpha_rad = {0.2};
  m.q_radps = {0.0};
  fmi2Component c = start_at(u, m, 0.0);
  const unsigned alpha_vr = variable(u.d, "alpha_rad").vr;
  REQUIRE(set_real(u, c, alpha_vr, 0.5) == fmi2OK);
  REQUIRE(u.api.fmi2DoStep(c, 0.0, 2.5, fmi2True) == fmi2OK);
  double fmu_out[2];
  const unsigned out_vr[2] = {variable(u.d, "CL").vr, variable(u.d, "Cm").vr};
  REQUIRE(u.api.fmi2GetReal(c, out_vr, 2, fmu_out) == fmi2OK);
  // The same through the C interface: three steps of 2.5 / 3 s.
  const std::string text = slurp(kModel);
  std::vector<double> model(indicial_model_bytes() / sizeof(double) + 1);
  REQUIRE(indicial_model_load(model.data(), text.data(), text.size(), nullptr, 0) == 0);
  std::vector<double> state(indicial_state_bytes(model.data()) / sizeof(double) + 1);
  REQUIRE(indicial_reset(model.data(), state.data(), 0.2, kAirspeed) == 0);
  double out[2];
  for (int k = 0; k < 3; ++k) REQUIRE(indicial_step(model.data(), state.data(), 0.5, 0.0, kAirspeed, 2.5 / 3, out) == 0);
  CHECK(fmu_out[0] == out[0]);
  CHECK(fmu_out[1] == out[1]);
  double last = 0.0;
  CHECK(u.api.fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &last) == fmi2OK);
  CHECK(last == 2.5);
  u.api.fmi2FreeInstance(c);
}

TEST_CASE("fmu: a step above the documented bound (1e6 s) is refused at once, with a reason") {
  const Unpacked& u = lift_fmu();
  Motion m;
  m.t_s = {0.0};
  m.alpha_rad = {0.2};
  m.q_radps = {0.0};
  for (const double h_s : {1e17, 1e6 * (1.0 + 1e-12), 1e300}) {
    g_log.clear();
    fmi2Component c = start_at(u, m, 0.0);
    CHECK(u.api.fmi2DoStep(c, 0.0, h_s, fmi2True) == fmi2Error);  // before the fix: never returned
    CHECK(logged("above the largest accepted step"));
    int status = 5;
    const unsigned status_vr = variable(u.d, "step_status").vr;
    CHECK(u.api.fmi2GetInteger(c, &status_vr, 1, &status) == fmi2OK);
    CHECK(status == 0);  // an argument refusal changes nothing, step_status included
    u.api.fmi2FreeInstance(c);
  }
  CHECK(g_live_allocations == 0);
}

TEST_CASE("fmu: a step the runtime refuses midway rolls back: outputs kept, step_status says why") {
  const Unpacked& u = lift_fmu();
  const auto& a = u.api;
  Motion m;
  m.t_s = {0.0};
  m.alpha_rad = {0.2};
  m.q_radps = {0.0};
  fmi2Component c = start_at(u, m, 0.0);
  const unsigned alpha_vr = variable(u.d, "alpha_rad").vr;
  const unsigned q_vr = variable(u.d, "q_radps").vr;
  const unsigned airspeed_vr = variable(u.d, "airspeed_mps").vr;
  const unsigned status_vr = variable(u.d, "step_status").vr;
  const unsigned out_vr[2] = {variable(u.d, "CL").vr, variable(u.d, "Cm").vr};
  REQUIRE(set_real(u, c, alpha_vr, 0.3) == fmi2OK);
  REQUIRE(a.fmi2DoStep(c, 0.0, 0.01, fmi2True) == fmi2OK);
  double before[2];
  REQUIRE(a.fmi2GetReal(c, out_vr, 2, before) == fmi2OK);
  // Finite inputs that pass every argument check, but (l / V) C_Lq q overflows inside the
  // runtime: the first of the three sub-steps is refused and the state restored.
  g_log.clear();
  REQUIRE(set_real(u, c, q_vr, 1e300) == fmi2OK);
  REQUIRE(set_real(u, c, airspeed_vr, 1e-300) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.01, 2.5, fmi2True) == fmi2Error);
  CHECK(logged("the runtime refused the step"));
  double after[2] = {0.0, 0.0};
  CHECK(a.fmi2GetReal(c, out_vr, 2, after) == fmi2OK);
  CHECK(after[0] == before[0]);
  CHECK(after[1] == before[1]);
  int status = 0;
  CHECK(a.fmi2GetInteger(c, &status_vr, 1, &status) == fmi2OK);
  CHECK(status == INDICIAL_ERROR_NON_FINITE_RESULT);
  double last = -1.0;
  CHECK(a.fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &last) == fmi2OK);
  CHECK(last == 0.01);  // time did not advance
  a.fmi2FreeInstance(c);
  CHECK(g_live_allocations == 0);
}

TEST_CASE("fmu: calls out of order give fmi2Error, then only reset or free are accepted") {
  const Unpacked& u = lift_fmu();
  const auto& a = u.api;
  g_log.clear();
  fmi2Component c = instantiate(u, "order");
  REQUIRE(c != nullptr);
  CHECK(a.fmi2DoStep(c, 0.0, 0.01, fmi2True) == fmi2Error);  // before initialization
  CHECK(logged("fmi2DoStep: not allowed in phase instantiated"));
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2Error);  // the error state holds
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2Error);  // not in initialization mode
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2Terminate(c) == fmi2Error);
  CHECK(a.fmi2Reset(c) == fmi2OK);
  double v = 0.0;
  const unsigned vr0 = 0;
  CHECK(a.fmi2GetReal(c, &vr0, 1, &v) == fmi2Error);  // no gets before initialization mode
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2Error);  // too late
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.0, 0.01, fmi2True) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.0, 0.01, fmi2True) == fmi2Error);  // the same step again
  CHECK(logged("is not the FMU's time"));
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.02, 0.01, fmi2True) == fmi2Error);  // a step skipped
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, 0.05) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.0, 0.06, fmi2True) == fmi2Error);  // past stopTime
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2Terminate(c) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.0, 0.01, fmi2True) == fmi2Error);  // after terminate
  CHECK(a.fmi2CancelStep(c) == fmi2Error);
  fmi2FMUstate s = nullptr;
  CHECK(a.fmi2GetFMUstate(c, &s) == fmi2Error);
  a.fmi2FreeInstance(c);
  // A freed, NULL or foreign component is refused without being dereferenced.
  CHECK(a.fmi2DoStep(c, 0.0, 0.01, fmi2True) == fmi2Error);
  CHECK(a.fmi2Reset(c) == fmi2Error);
  a.fmi2FreeInstance(c);  // a second free is ignored
  CHECK(a.fmi2Reset(nullptr) == fmi2Error);
  int not_an_instance[4] = {};
  CHECK(a.fmi2Terminate(not_an_instance) == fmi2Error);
  CHECK(g_live_allocations == 0);
}

TEST_CASE("fmu: bad values give fmi2Error and change nothing") {
  const Unpacked& u = lift_fmu();
  const auto& a = u.api;
  g_log.clear();
  fmi2Component c = instantiate(u, "values");
  REQUIRE(c != nullptr);
  const unsigned airspeed_vr = variable(u.d, "airspeed_mps").vr;
  const unsigned alpha_vr = variable(u.d, "alpha_rad").vr;
  const unsigned cl_vr = variable(u.d, "CL").vr;
  const unsigned status_vr = variable(u.d, "step_status").vr;
  CHECK(set_real(u, c, airspeed_vr, 0.0) == fmi2Error);
  CHECK(logged("airspeed 0 m/s must be > 0"));
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(set_real(u, c, alpha_vr, std::nan("")) == fmi2Error);
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(set_real(u, c, alpha_vr, HUGE_VAL) == fmi2Error);
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(set_real(u, c, cl_vr, 1.0) == fmi2Error);  // an output
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(set_real(u, c, 77, 1.0) == fmi2Error);  // no such variable
  CHECK(a.fmi2Reset(c) == fmi2OK);
  // A call with one bad value among good ones writes none of them.
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  const unsigned both[2] = {alpha_vr, airspeed_vr};
  const double values[2] = {0.3, -1.0};
  CHECK(a.fmi2SetReal(c, both, 2, values) == fmi2Error);
  double alpha = -1.0;
  CHECK(a.fmi2GetReal(c, &alpha_vr, 1, &alpha) == fmi2OK);  // gets are allowed in the error state
  CHECK(alpha == 0.0);
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(set_real(u, c, variable(u.d, "initial_alpha_rad").vr, 0.1) == fmi2Error);  // fixed after init
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.0, 0.0, fmi2True) == fmi2Error);
  CHECK(a.fmi2Reset(c) == fmi2OK);
  CHECK(a.fmi2EnterInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2ExitInitializationMode(c) == fmi2OK);
  CHECK(a.fmi2DoStep(c, 0.0, std::nan(""), fmi2True) == fmi2Error);
  int status = 5;
  CHECK(a.fmi2GetInteger(c, &status_vr, 1, &status) == fmi2OK);
  CHECK(status == 0);
  const int one = 1;
  CHECK(a.fmi2SetInteger(c, &status_vr, 1, &one) == fmi2Error);
  CHECK(a.fmi2GetReal(c, nullptr, 1, &alpha) == fmi2Error);
  CHECK(a.fmi2GetInteger(c, &alpha_vr, 1, &status) == fmi2Error);
  fmi2Boolean b = 0;
  CHECK(a.fmi2GetBoolean(c, &alpha_vr, 1, &b) == fmi2Error);
  const char* categories[1] = {"logNoSuchThing"};
  CHECK(a.fmi2SetDebugLogging(c, fmi2True, 1, categories) == fmi2Error);
  a.fmi2FreeInstance(c);
  CHECK(g_live_allocations == 0);
}

TEST_CASE("fmu: instantiation refuses a wrong kind, GUID or location and a damaged model, with a reason") {
  const Unpacked& u = lift_fmu();
  const auto& a = u.api;
  g_log.clear();
  const std::string uri = u.resources_uri();
  CHECK(a.fmi2Instantiate("x", fmi2ModelExchange, u.d.guid.c_str(), uri.c_str(), &g_callbacks, 0, 0) == nullptr);
  CHECK(logged("co-simulation only"));
  CHECK(a.fmi2Instantiate("x", fmi2CoSimulation, "{wrong}", uri.c_str(), &g_callbacks, 0, 0) == nullptr);
  CHECK(logged("is not the model this FMU was made for"));
  CHECK(a.fmi2Instantiate("x", fmi2CoSimulation, u.d.guid.c_str(), "http://example.com/r", &g_callbacks, 0, 0) ==
        nullptr);
  CHECK(a.fmi2Instantiate("x", fmi2CoSimulation, u.d.guid.c_str(), nullptr, &g_callbacks, 0, 0) == nullptr);
  CHECK(a.fmi2Instantiate("x", fmi2CoSimulation, u.d.guid.c_str(), "file:///no/such/dir", &g_callbacks, 0, 0) ==
        nullptr);
  CHECK(logged("cannot open /no/such/dir/model.coef"));
  CHECK(a.fmi2Instantiate("x", fmi2CoSimulation, u.d.guid.c_str(), uri.c_str(), nullptr, 0, 0) == nullptr);
  CHECK(a.fmi2Instantiate(nullptr, fmi2CoSimulation, u.d.guid.c_str(), uri.c_str(), &g_callbacks, 0, 0) == nullptr);
  // file:/path and percent-escapes are local file URIs too.
  fmi2Component c = a.fmi2Instantiate("x", fmi2CoSimulation, u.d.guid.c_str(),
                                      ("file:" + (u.root / "resources").string() + "/").c_str(), &g_callbacks, 0, 0);
  CHECK(c != nullptr);
  a.fmi2FreeInstance(c);

  // A damaged model: one byte changed (the GUID no longer matches) ...
  const fs::path damaged = dir() / "damaged";
  fs::remove_all(damaged);
  fs::create_directories(damaged);
  std::string text = slurp(u.root / "resources" / "model.coef");
  text[text.find("rotary_poly 3.1") + 12] = '4';
  std::ofstream(damaged / "model.coef", std::ios::binary) << text;
  const std::string damaged_uri = "file://" + damaged.string();
  CHECK(a.fmi2Instantiate("x", fmi2CoSimulation, u.d.guid.c_str(), damaged_uri.c_str(), &g_callbacks, 0, 0) ==
        nullptr);
  // ... and one whose GUID was forged to match: the parser's own checks refuse it, naming the line.
  char forged[indicial::fmu::kGuidChars];
  text = "indicial-coef 1\naxis pitch\nreference_length_m -1\n";
  std::ofstream(damaged / "model.coef", std::ios::binary | std::ios::trunc) << text;
  indicial::fmu::model_guid(text.data(), text.size(), forged);
  g_log.clear();
  CHECK(a.fmi2Instantiate("x", fmi2CoSimulation, forged, damaged_uri.c_str(), &g_callbacks, 0, 0) == nullptr);
  CHECK(logged("model.coef: line"));
  CHECK(g_live_allocations == 0);
}

TEST_CASE("fmu: the command refuses bad models and names, and never overwrites without --force") {
  const fs::path out = dir() / "cmd.fmu";
  auto r = run_indicial("fmu '" + kModel + "' --out '" + out.string() + "'", dir());
  REQUIRE(r.exit_code == 0);
  r = run_indicial("fmu '" + kModel + "' --out '" + out.string() + "'", dir());
  CHECK(r.exit_code == 1);
  CHECK(r.err.find("output file exists (use --force to replace it)") != std::string::npos);
  CHECK(run_indicial("fmu '" + kModel + "' --out '" + out.string() + "' --force", dir()).exit_code == 0);
  const fs::path bad = dir() / "bad.coef";
  std::ofstream(bad) << "indicial-coef 1\naxis pitch\nreference_length_m -1\n";
  r = run_indicial("fmu '" + bad.string() + "' --out '" + (dir() / "bad.fmu").string() + "'", dir());
  CHECK(r.exit_code == 1);
  CHECK(r.err.find("bad.coef") != std::string::npos);
  CHECK(!fs::exists(dir() / "bad.fmu"));
  r = run_indicial("fmu '" + kModel + "' --out '" + (dir() / "x.zip").string() + "'", dir());
  CHECK(r.exit_code == 1);
  r = run_indicial("fmu '" + kModel + "' --out '" + (dir() / "y.fmu").string() + "' --model-identifier 9x", dir());
  CHECK(r.exit_code == 1);
  CHECK(!fs::exists(dir() / "y.fmu"));
}
