// `indicial fmu`: an FMI 2.0 co-simulation FMU (linux64) of a coefficient file.
//
//   indicial fmu MODEL.coef --out NAME.fmu [--model-identifier ID] [--step-s DT] [--force]
//
// The package (a zip, written with libzip):
//   modelDescription.xml                 written here for this model (FMI 2.0 schema)
//   binaries/linux64/<ID>.so             the prebuilt slave (runtime/src/fmu/fmu_slave.cpp),
//                                        embedded in this executable at build time
//   resources/model.coef                 the coefficient file, byte for byte
// The model is loaded with the runtime's parser first (the one the slave uses), so a file the
// FMU would refuse at fmi2Instantiate is refused here, naming file and line, and nothing is
// written. Variables, value references and semantics: docs/integrators.md and
// runtime/src/fmu/fmu_layout.hpp.
#include <zip.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "fmu_layout.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/fitter/provenance.hpp"

namespace indicial::tools {
// The slave library's bytes (generated at build time from the indicial_fmu_slave target).
extern const unsigned char fmu_slave_library[];
extern const std::size_t fmu_slave_library_bytes;
}  // namespace indicial::tools

namespace {

struct FmuOptions {
  std::string model_path;
  std::string out;
  std::string model_identifier;  // default: from the --out file name
  double step_s = 1e-3;          // DefaultExperiment stepSize
  bool force = false;
};

using FmuModel = indicial::RuntimeModel<double, indicial::DefaultCapacity>;

// A C identifier from a file stem: other characters become '_', a leading digit gets '_'.
std::string identifier_from(const std::string& stem) {
  std::string id;
  for (char ch : stem) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_';
    id += ok ? ch : '_';
  }
  if (!id.empty() && id[0] >= '0' && id[0] <= '9') id.insert(id.begin(), '_');
  return id;
}

bool is_c_identifier(const std::string& s) { return !s.empty() && identifier_from(s) == s; }

std::string xml_escape(const std::string& s) {
  std::string r;
  for (char ch : s) {
    switch (ch) {
      case '&': r += "&amp;"; break;
      case '<': r += "&lt;"; break;
      case '>': r += "&gt;"; break;
      case '"': r += "&quot;"; break;
      default: r += ch;
    }
  }
  return r;
}

// Shortest text that reads back as the same double.
std::string real_text(double v) {
  char buf[32];
  for (int digits = 1; digits <= 17; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  return buf;
}

struct MotionNames {
  const char* angle;
  const char* rate;
  const char* what;
};

MotionNames motion_names(indicial::Axis axis) {
  switch (axis) {
    case indicial::Axis::roll: return {"phi", "p", "roll angle phi"};
    case indicial::Axis::yaw: return {"psi", "r", "yaw angle psi"};
    default: return {"alpha", "q", "angle of attack alpha"};
  }
}

std::string real_variable(const std::string& name, unsigned vr, const std::string& causality,
                          const std::string& variability, const std::string& description,
                          const std::string& real_attributes) {
  return "    <ScalarVariable name=\"" + xml_escape(name) + "\" valueReference=\"" + std::to_string(vr) +
         "\" causality=\"" + causality + "\" variability=\"" + variability + "\" description=\"" +
         xml_escape(description) + "\">\n      <Real" + real_attributes + "/>\n    </ScalarVariable>\n";
}

// The ModelVariables block; *n_variables receives their count (indices run 1..n).
std::string model_variables(const FmuModel& m, int* n_variables) {
  namespace fmu = indicial::fmu;
  const MotionNames names = motion_names(m.set.axis);
  const std::string v_ref = real_text(m.set.airspeed_mps);
  const std::string angle = std::string(names.angle) + "_rad";
  std::string x = "  <ModelVariables>\n";
  x += real_variable(angle, fmu::vr_angle_rad, "input", "continuous",
                     std::string("motion: ") + names.what + " at the end of each step", " unit=\"rad\" start=\"0\"");
  x += real_variable(std::string(names.rate) + "_radps", fmu::vr_rate_radps, "input", "continuous",
                     "motion: its rate at the end of each step", " unit=\"rad/s\" start=\"0\"");
  x += real_variable("airspeed_mps", fmu::vr_airspeed_mps, "input", "continuous",
                     "airspeed (any > 0; the model was identified at " + v_ref + " m/s)",
                     " unit=\"m/s\" start=\"" + v_ref + "\"");  // no min: FMI's min is inclusive, the slave refuses 0
  x += real_variable("initial_" + angle, fmu::vr_initial_angle_rad, "parameter", "fixed",
                     "the instance starts at rest (steady state) at this angle", " unit=\"rad\" start=\"0\"");
  x += real_variable("initial_airspeed_mps", fmu::vr_initial_airspeed_mps, "parameter", "fixed",
                     "airspeed of the initial steady state (any > 0)", " unit=\"m/s\" start=\"" + v_ref + "\"");
  int n = 5;
  for (int c = 0; c < m.set.n_coefficients; ++c, ++n)
    x += real_variable(m.set.coefficients[c].name, fmu::vr_first_coefficient + static_cast<unsigned>(c), "output",
                       "continuous", std::string("aerodynamic coefficient ") + m.set.coefficients[c].name +
                                         " at the FMU's time (static + rotary + unsteady)", "");
  x += "    <ScalarVariable name=\"step_status\" valueReference=\"" + std::to_string(fmu::vr_step_status) +
       "\" causality=\"output\" variability=\"discrete\" description=\"indicial status of the last step or "
       "reset: 0 ok, 1 angle clamped to the envelope, negative: refused (indicial.h)\">\n"
       "      <Integer/>\n    </ScalarVariable>\n";
  *n_variables = n + 1;
  return x + "  </ModelVariables>\n";
}

std::string model_description(const FmuModel& m, const std::string& model_name, const std::string& identifier,
                              const std::string& guid, double step_s) {
  int n = 0;
  const std::string variables = model_variables(m, &n);
  std::string x = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  x += "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"" + xml_escape(model_name) + "\" guid=\"" + guid +
       "\" description=\"indicial nonlinear unsteady aerodynamic model (" + indicial::axis_name(m.set.axis) +
       " axis)\" generationTool=\"indicial " + indicial::tool_version() +
       "\" variableNamingConvention=\"flat\" numberOfEventIndicators=\"0\">\n";
  x += "  <CoSimulation modelIdentifier=\"" + identifier +
       "\" needsExecutionTool=\"false\" canHandleVariableCommunicationStepSize=\"true\" "
       "canInterpolateInputs=\"false\" maxOutputDerivativeOrder=\"0\" canRunAsynchronuously=\"false\" "
       "canBeInstantiatedOnlyOncePerProcess=\"false\" canNotUseMemoryManagementFunctions=\"false\" "
       "canGetAndSetFMUstate=\"false\" canSerializeFMUstate=\"false\" providesDirectionalDerivative=\"false\"/>\n";
  x += "  <UnitDefinitions>\n"
       "    <Unit name=\"rad\">\n      <BaseUnit rad=\"1\"/>\n      <DisplayUnit name=\"deg\" "
       "factor=\"57.295779513082323\"/>\n    </Unit>\n"
       "    <Unit name=\"rad/s\">\n      <BaseUnit s=\"-1\" rad=\"1\"/>\n      <DisplayUnit name=\"deg/s\" "
       "factor=\"57.295779513082323\"/>\n    </Unit>\n"
       "    <Unit name=\"m/s\">\n      <BaseUnit m=\"1\" s=\"-1\"/>\n    </Unit>\n  </UnitDefinitions>\n";
  x += "  <LogCategories>\n"
       "    <Category name=\"logStatusError\" description=\"refused calls and their reasons (always logged)\"/>\n"
       "    <Category name=\"logStatusWarning\" description=\"angles clamped to the envelope (debug logging)\"/>\n"
       "  </LogCategories>\n";
  x += "  <DefaultExperiment startTime=\"0\" stepSize=\"" + real_text(step_s) + "\"/>\n";
  x += variables;
  // Outputs: every output, without direct feedthrough (dependencies=""): a step's outputs
  // come from the inputs set before that step. InitialUnknowns: the same outputs, computed
  // from the parameters and inputs in initialization mode (no dependencies attribute: all).
  std::string outputs, initial;
  for (int i = 6; i <= n; ++i) {
    outputs += "      <Unknown index=\"" + std::to_string(i) + "\" dependencies=\"\"/>\n";
    initial += "      <Unknown index=\"" + std::to_string(i) + "\"/>\n";
  }
  x += "  <ModelStructure>\n    <Outputs>\n" + outputs + "    </Outputs>\n    <InitialUnknowns>\n" + initial +
       "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n";
  return x;
}

struct ZipEntry {
  std::string name;
  const void* data;
  std::size_t bytes;
  bool executable;
};

[[noreturn]] void zip_failure(const std::string& what, zip_error_t* error) {
  const std::string reason = zip_error_strerror(error);
  zip_error_fini(error);
  throw indicial::InputError("indicial fmu: cannot build the package (" + what + "): " + reason);
}

// The zip archive of the entries, in memory (libzip; deflated).
std::string zip_bytes(const std::vector<ZipEntry>& entries) {
  zip_error_t error;
  zip_error_init(&error);
  zip_source_t* buffer = zip_source_buffer_create(nullptr, 0, 0, &error);
  if (buffer == nullptr) zip_failure("buffer", &error);
  zip_source_keep(buffer);
  std::unique_ptr<zip_source_t, void (*)(zip_source_t*)> keep(buffer, zip_source_free);
  zip_t* archive = zip_open_from_source(buffer, ZIP_TRUNCATE, &error);
  if (archive == nullptr) zip_failure("open", &error);
  for (const ZipEntry& e : entries) {
    zip_source_t* s = zip_source_buffer(archive, e.data, e.bytes, 0);
    const zip_int64_t index = s == nullptr ? -1 : zip_file_add(archive, e.name.c_str(), s, ZIP_FL_ENC_UTF_8);
    if (index < 0) {
      if (s != nullptr) zip_source_free(s);
      zip_discard(archive);
      throw indicial::InputError("indicial fmu: cannot add " + e.name + " to the package");
    }
    const auto i = static_cast<zip_uint64_t>(index);
    zip_set_file_compression(archive, i, ZIP_CM_DEFLATE, 9);
    const zip_uint32_t mode = e.executable ? 0100755u : 0100644u;
    zip_file_set_external_attributes(archive, i, 0, ZIP_OPSYS_UNIX, mode << 16);
  }
  if (zip_close(archive) != 0) {
    const std::string reason = zip_strerror(archive);
    zip_discard(archive);
    throw indicial::InputError("indicial fmu: cannot build the package: " + reason);
  }
  if (zip_source_open(buffer) != 0) zip_failure("read back", zip_source_error(buffer));
  zip_source_seek(buffer, 0, SEEK_END);
  const zip_int64_t size = zip_source_tell(buffer);
  zip_source_seek(buffer, 0, SEEK_SET);
  std::string bytes(static_cast<std::size_t>(size < 0 ? 0 : size), '\0');
  const zip_int64_t got = zip_source_read(buffer, bytes.data(), bytes.size());
  zip_source_close(buffer);
  if (size <= 0 || got != size) throw indicial::InputError("indicial fmu: cannot read the package back");
  return bytes;
}

void run_fmu(const FmuOptions& o) {
  using indicial::InputError;
  const indicial::Overwrite overwrite = o.force ? indicial::Overwrite::replace : indicial::Overwrite::refuse;
  if (std::filesystem::is_directory(o.model_path))
    throw InputError(o.model_path + " is a directory, expected a coefficient file (.coef)");
  const std::string text = indicial::read_text(o.model_path);
  auto model = std::make_unique<FmuModel>();
  indicial::ParseDiagnostic diag;
  const indicial::LoadStatus s = indicial::load_runtime_model(text.data(), text.size(), model.get(), &diag);
  if (s != indicial::LoadStatus::ok)
    throw InputError(o.model_path, static_cast<long>(diag.line),
                     std::string("the runtime refuses the model: ") + diag.reason + " (" + indicial::to_string(s) + ")");
  const std::filesystem::path out(o.out);
  if (out.extension() != ".fmu") throw InputError("--out", 0, o.out + ": an FMU's file name ends in .fmu");
  const std::string identifier = o.model_identifier.empty() ? identifier_from(out.stem().string()) : o.model_identifier;
  if (!is_c_identifier(identifier))
    throw InputError("--model-identifier", 0, "'" + identifier + "' is not a C identifier ([A-Za-z_][A-Za-z0-9_]*)");
  if (!(std::isfinite(o.step_s) && o.step_s > 0.0 && o.step_s <= 1.0))
    throw InputError("--step-s", 0, "the default step must be in (0, 1] s");
  if (overwrite == indicial::Overwrite::refuse && std::filesystem::exists(out))
    throw InputError(o.out, 0, "output file exists (use --force to replace it)");

  char guid[indicial::fmu::kGuidChars];
  indicial::fmu::model_guid(text.data(), text.size(), guid);
  const std::string model_name = std::filesystem::path(o.model_path).stem().string();
  const std::string xml = model_description(*model, model_name, identifier, guid, o.step_s);
  const std::string package =
      zip_bytes({{"modelDescription.xml", xml.data(), xml.size(), false},
                 {"binaries/linux64/" + identifier + ".so", indicial::tools::fmu_slave_library,
                  indicial::tools::fmu_slave_library_bytes, true},
                 {std::string("resources/") + indicial::fmu::kModelResource, text.data(), text.size(), false}});
  indicial::refuse_output_onto_input(out, {o.model_path});
  indicial::write_file_atomically(out, package, overwrite);
  std::printf("fmu: %s (FMI 2.0 co-simulation, linux64, modelIdentifier %s, %d output(s) + step_status) -> %s\n",
              model_name.c_str(), identifier.c_str(), model->set.n_coefficients, o.out.c_str());
}

const indicial::tools::RegisterCommand register_fmu([](CLI::App& app) {
  auto opt = std::make_shared<FmuOptions>();
  CLI::App* sub = app.add_subcommand(
      "fmu",
      "Write an FMI 2.0 co-simulation FMU (linux64) of a model: inputs angle, rate and airspeed,\n"
      "parameters initial angle and airspeed, outputs every coefficient and step_status.\n"
      "Variables and semantics: docs/integrators.md.");
  sub->add_option("MODEL", opt->model_path, "coefficient file (.coef)")->required();
  sub->add_option("--out", opt->out, "the FMU to write (NAME.fmu)")->required();
  sub->add_option("--model-identifier", opt->model_identifier,
                  "the FMU's modelIdentifier (its library's name; default: NAME made a C identifier)");
  sub->add_option("--step-s", opt->step_s, "the DefaultExperiment stepSize suggested to importers (default 0.001)");
  sub->add_flag("--force", opt->force, "replace an existing FMU");
  sub->callback([opt]() { run_fmu(*opt); });
});

}  // namespace
