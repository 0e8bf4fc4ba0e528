// `indicial codegen MODEL.coef --out FILE.hpp [--force] [--name IDENT] [--namespace NS]
// [--scalar double|float] [--capacity default|tight]`: turns a coefficient file into a C++17
// header holding the model as
// a constexpr indicial::RuntimeModel<double, DefaultCapacity> NS::IDENT (NS defaults to
// indicial_generated; --scalar float gives RuntimeModel<float, DefaultCapacity>, the model
// Predictor<float> and State<float> step, e.g. on a Cortex-M4F), so that an embedded target
// steps it in place (it lives in read-only memory; the header includes runtime.hpp and no
// parser) and never parses text. The header also declares `using IDENT_capacity = ...;`: the
// Capacity of the model (DefaultCapacity, or with --capacity tight the smallest that holds this
// model: fewer bytes of flash for the model and of RAM per State<Scalar, IDENT_capacity>).
//
// The file is parsed by the runtime's own parser (runtime/include/indicial/coef_file.hpp) and
// validated like Predictor::load does; every number is written in its shortest round-trip
// form, so the generated model is bit-identical to the parsed one (tests/test_codegen.cpp).
// A float model is the one make_runtime_model<float> builds from the parsed file (every
// Scalar value converted by static_cast<float>, a static table's second derivatives
// recomputed in float), written as shortest round-trip float literals: bit-identical to
// Predictor<float>::load of the same text.
// The model is built by a constexpr function (assignments into a default-constructed
// ModelSet) rather than one aggregate initialiser, which keeps the header readable and
// independent of the order of ModelSet's members.
#include <algorithm>
#include <charconv>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <type_traits>

#include "command.hpp"
#include "indicial/coef_file.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/runtime.hpp"

namespace {

using Cap = indicial::DefaultCapacity;
using Set = indicial::ModelSet<double, Cap>;

struct CodegenOptions {
  std::string model_path;
  std::string out;
  std::string name;
  std::string name_space = "indicial_generated";
  std::string scalar = "double";
  std::string capacity = "default";
  bool force = false;
};

// A double (or float) as a C++ literal that converts back to exactly the same value: the
// shortest round-trip digits, with ".0" appended where they would otherwise read as an int
// (which would also lose the sign of -0), and the f suffix for a float.
template <class T>
std::string shortest_digits(T v) {
  char buf[40];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, v);
  std::string s(buf, r.ptr);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}
std::string literal(double v) { return shortest_digits(v); }
std::string literal(float v) { return shortest_digits(v) + "f"; }

bool is_identifier(const std::string& s) {
  if (s.empty() || (s[0] >= '0' && s[0] <= '9')) return false;
  for (char ch : s) {
    const bool ok = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9') ||
                    ch == '_';
    if (!ok) return false;
  }
  return true;
}

// C++ keywords and alternative tokens (C++20, which includes C++17's): a generated
// `inline constexpr ... default = ...` would not compile.
bool is_keyword(const std::string& s) {
  static const char* const keywords[] = {
      "alignas", "alignof", "and", "and_eq", "asm", "auto", "bitand", "bitor", "bool", "break",
      "case", "catch", "char", "char8_t", "char16_t", "char32_t", "class", "compl", "concept",
      "const", "consteval", "constexpr", "constinit", "const_cast", "continue", "co_await",
      "co_return", "co_yield", "decltype", "default", "delete", "do", "double", "dynamic_cast",
      "else", "enum", "explicit", "export", "extern", "false", "float", "for", "friend", "goto",
      "if", "inline", "int", "long", "mutable", "namespace", "new", "noexcept", "not", "not_eq",
      "nullptr", "operator", "or", "or_eq", "private", "protected", "public", "register",
      "reinterpret_cast", "requires", "return", "short", "signed", "sizeof", "static",
      "static_assert", "static_cast", "struct", "switch", "template", "this", "thread_local",
      "throw", "true", "try", "typedef", "typeid", "typename", "union", "unsigned", "using",
      "virtual", "void", "volatile", "wchar_t", "while", "xor", "xor_eq"};
  for (const char* k : keywords)
    if (s == k) return true;
  return false;
}

// Letters, digits and _, not starting with a digit, not a keyword, not reserved to the
// implementation (a leading _ followed by a capital, or a double underscore anywhere).
std::string identifier_problem(const std::string& s) {
  if (!is_identifier(s)) return "is not a C++ identifier (letters, digits, _; no leading digit)";
  if (is_keyword(s)) return "is a C++ keyword";
  if (s.find("__") != std::string::npos || (s.size() > 1 && s[0] == '_' && s[1] >= 'A' && s[1] <= 'Z'))
    return "is reserved to the C++ implementation (__ or _ and a capital)";
  return "";
}


// A namespace: one identifier, or several joined by :: (a C++17 nested namespace definition,
// `namespace sim::aero {`: simulator code bases nest theirs).
std::string namespace_problem(const std::string& s) {
  std::size_t from = 0;
  while (true) {
    const std::size_t at = s.find("::", from);
    const std::string part = s.substr(from, at == std::string::npos ? std::string::npos : at - from);
    const std::string problem = identifier_problem(part);
    if (!problem.empty())
      return part == s ? problem : "has a part '" + part + "' that " + problem;
    if (at == std::string::npos) return "";
    from = at + 2;
  }
}

// tailless-model-2.coef -> tailless_model_2
std::string identifier_from_path(const std::string& path) {
  std::string stem = std::filesystem::path(path).stem().string();
  for (char& ch : stem) {
    const bool ok = (ch >= 'A' && ch <= 'Z') || (ch >= 'a' && ch <= 'z') || (ch >= '0' && ch <= '9');
    if (!ok) ch = '_';
  }
  if (stem.empty() || (stem[0] >= '0' && stem[0] <= '9')) stem = "model_" + stem;
  return stem;
}

template <class Scalar, int P, int K>
void emit_spline(std::string& o, const std::string& lhs, const indicial::Spline<Scalar, P, K>& s) {
  if (s.n_powers == 0 && s.n_knots == 0) return;
  o += "  " + lhs + ".n_powers = " + std::to_string(s.n_powers) + ";\n";
  for (int i = 0; i < s.n_powers; ++i)
    o += "  " + lhs + ".power_coef[" + std::to_string(i) + "] = " + literal(s.power_coef[i]) + ";\n";
  o += "  " + lhs + ".n_knots = " + std::to_string(s.n_knots) + ";\n";
  for (int j = 0; j < s.n_knots; ++j) {
    const std::string at = "[" + std::to_string(j) + "]";
    o += "  " + lhs + ".knot_rad" + at + " = " + literal(s.knot_rad[j]) + ";\n";
    o += "  " + lhs + ".knot_power" + at + " = " + std::to_string(s.knot_power[j]) + ";\n";
    o += "  " + lhs + ".knot_coef" + at + " = " + literal(s.knot_coef[j]) + ";\n";
  }
}

// The step constants of the RuntimeModel (derive_step_constants' values, computed by the
// tool with the same function the runtime uses to check them).
template <class Scalar>
void emit_step_constants(std::string& o, const indicial::RuntimeModel<Scalar, Cap>& r) {
  o += "  r.x_min_rad = " + literal(r.x_min_rad) + ";\n";
  o += "  r.x_max_rad = " + literal(r.x_max_rad) + ";\n";
  o += "  r.angle_factor = " + literal(r.angle_factor) + ";\n";
  o += "  r.reference_length_m = " + literal(r.reference_length_m) + ";\n";
  o += "  r.airspeed_mps = " + literal(r.airspeed_mps) + ";\n";
  o += std::string("  r.delay = indicial::DelayUse::") +
       (r.delay == indicial::DelayUse::delayed ? "delayed" : "none") + ";\n";
  o += std::string("  r.stall = indicial::StallUse::") +
       (r.stall == indicial::StallUse::families ? "families" : "none") + ";\n";
  for (int c = 0; c < Cap::max_coefficients; ++c) {
    const indicial::StallSharing& sh = r.stall_sharing[c];
    const std::string at = "  r.stall_sharing[" + std::to_string(c) + "].";
    if (sh.table != indicial::StallSharing::no_sharing) o += at + "table = " + std::to_string(sh.table) + ";\n";
    if (sh.forcing != indicial::StallSharing::no_sharing) o += at + "forcing = " + std::to_string(sh.forcing) + ";\n";
    if (sh.decay != indicial::StallSharing::no_sharing) o += at + "decay = " + std::to_string(sh.decay) + ";\n";
    if (sh.separation != indicial::StallSharing::no_sharing)
      o += at + "separation = " + std::to_string(sh.separation) + ";\n";
  }
}

// The dynamic-stall families of a coefficient (only a used family: the defaults stand for the
// rest, as in the coefficient file).
template <class Scalar>
void emit_stall(std::string& o, const std::string& p, const indicial::StallModel<Scalar, Cap>& st) {
  if (st.families == indicial::StallFamilies::none) return;
  o += "  " + p + ".families = indicial::StallFamilies::" + indicial::stall_families_name(st.families) + ";\n";
  const std::string sp = p + ".separation";
  const auto& sep = st.separation;
  o += "  " + sp + ".normal_force_slope_per_rad = " + literal(sep.normal_force_slope_per_rad) + ";\n";
  o += "  " + sp + ".zero_lift_angle_rad = " + literal(sep.zero_lift_angle_rad) + ";\n";
  o += "  " + sp + ".n_f0 = " + std::to_string(sep.n_f0) + ";\n";
  for (int i = 0; i < sep.n_f0; ++i) {
    const std::string at = "[" + std::to_string(i) + "]";
    o += "  " + sp + ".f0_x_rad" + at + " = " + literal(sep.f0_x_rad[i]) + ";\n";
    o += "  " + sp + ".f0_value" + at + " = " + literal(sep.f0_value[i]) + ";\n";
  }
  emit_spline(o, sp + ".f0_correction", sep.f0_correction);
  o += "  " + sp + ".tau1_semichords = " + literal(sep.tau1_semichords) + ";\n";
  o += "  " + sp + ".tau2_semichords = " + literal(sep.tau2_semichords) + ";\n";
  if (sep.forcing_lag != indicial::ForcingLag::delay)
    o += "  " + sp + ".forcing_lag = indicial::ForcingLag::" + indicial::forcing_lag_name(sep.forcing_lag) + ";\n";
  if (sep.tau1_reattach_semichords > 0.0)
    o += "  " + sp + ".tau1_reattach_semichords = " + literal(sep.tau1_reattach_semichords) + ";\n";
  if (sep.reattach_shift_rad > 0.0)
    o += "  " + sp + ".reattach_shift_rad = " + literal(sep.reattach_shift_rad) + ";\n";
  if (sep.lag_limit_rad > 0.0) o += "  " + sp + ".lag_limit_rad = " + literal(sep.lag_limit_rad) + ";\n";
  o += "  " + sp + ".cp_k0 = " + literal(sep.cp_k0) + ";\n";
  o += "  " + sp + ".cp_k1 = " + literal(sep.cp_k1) + ";\n";
  o += "  " + sp + ".cp_k2 = " + literal(sep.cp_k2) + ";\n";
  if (st.families != indicial::StallFamilies::separation_and_vortex) return;
  const std::string vp = p + ".vortex";
  const auto& v = st.vortex;
  o += "  " + vp + ".shedding_threshold = " + literal(v.shedding_threshold) + ";\n";
  o += "  " + vp + ".shedding_width = " + literal(v.shedding_width) + ";\n";
  o += "  " + vp + ".decay_semichords = " + literal(v.decay_semichords) + ";\n";
  o += "  " + vp + ".travel_semichords = " + literal(v.travel_semichords) + ";\n";
  o += "  " + vp + ".clock_width_semichords = " + literal(v.clock_width_semichords) + ";\n";
  o += "  " + vp + ".clock_reset_semichords = " + literal(v.clock_reset_semichords) + ";\n";
  o += "  " + vp + ".lift_gain = " + literal(v.lift_gain) + ";\n";
  o += "  " + vp + ".cp_travel = " + literal(v.cp_travel) + ";\n";
}

template <class Scalar>
void emit_coefficient(std::string& o, const std::string& p,
                      const indicial::CoefficientModel<Scalar, Cap>& cm) {
  o += "  // " + std::string(cm.name) + "\n";
  for (int i = 0; cm.name[i] != '\0'; ++i)
    o += "  " + p + ".name[" + std::to_string(i) + "] = '" + cm.name[i] + "';\n";
  const auto& sc = cm.static_curve;
  if (sc.kind == indicial::StaticKind::table) {
    o += "  " + p + ".static_curve.kind = indicial::StaticKind::table;\n";
    o += "  " + p + ".static_curve.n_table = " + std::to_string(sc.n_table) + ";\n";
    for (int i = 0; i < sc.n_table; ++i) {
      const std::string at = "[" + std::to_string(i) + "]";
      o += "  " + p + ".static_curve.table_x_rad" + at + " = " + literal(sc.table_x_rad[i]) + ";\n";
      o += "  " + p + ".static_curve.table_value" + at + " = " + literal(sc.table_value[i]) + ";\n";
      o += "  " + p + ".static_curve.table_second_derivative" + at + " = " +
           literal(sc.table_second_derivative[i]) + ";\n";
    }
  } else {
    emit_spline(o, p + ".static_curve.polynomial", sc.polynomial);
  }
  emit_spline(o, p + ".static_correction", cm.static_correction);
  emit_spline(o, p + ".rotary", cm.rotary);
  emit_spline(o, p + ".a", cm.a);
  o += "  " + p + ".n_lags = " + std::to_string(cm.n_lags) + ";\n";
  for (int j = 0; j < cm.n_lags; ++j) {
    const std::string lag = p + ".lags[" + std::to_string(j) + "]";
    emit_spline(o, lag + ".b", cm.lags[j].b);
    o += "  " + lag + ".gain = " + literal(cm.lags[j].gain) + ";\n";
  }
  o += "  " + p + ".con = " + literal(cm.con) + ";\n";
  o += "  " + p + ".delay_s = " + literal(cm.delay_s) + ";\n";
  emit_stall(o, p + ".stall", cm.stall);
}

// The smallest Capacity that holds m (--capacity tight): the largest count of powers, knots,
// lags and table rows over its splines, static tables and separation tables (at least
// Capacity's minimums), its
// coefficient count, and the default delay ring if a coefficient has a delay (2 samples, the
// minimum, if none). The emitted assignments are the same text for any capacity that holds m.
std::string tight_capacity(const Set& m) {
  int powers = 1, knots = 0, lags = 1, table = 2, delay_samples = 2;
  const auto spline = [&](const indicial::Spline<double, Cap::max_powers, Cap::max_knots>& sp) {
    powers = std::max(powers, sp.n_powers);
    knots = std::max(knots, sp.n_knots);
  };
  for (int c = 0; c < m.n_coefficients; ++c) {
    const auto& cm = m.coefficients[c];
    spline(cm.static_curve.polynomial);
    spline(cm.static_correction);
    spline(cm.rotary);
    spline(cm.a);
    for (int j = 0; j < cm.n_lags; ++j) spline(cm.lags[j].b);
    lags = std::max(lags, cm.n_lags);
    table = std::max(table, cm.static_curve.n_table);
    if (cm.delay_s != 0.0) delay_samples = Cap::max_delay_samples;
    if (cm.stall.families != indicial::StallFamilies::none) {
      spline(cm.stall.separation.f0_correction);
      table = std::max(table, cm.stall.separation.n_f0);
    }
  }
  return "indicial::Capacity<" + std::to_string(powers) + ", " + std::to_string(knots) + ", " +
         std::to_string(lags) + ", " + std::to_string(table) + ", " +
         std::to_string(m.n_coefficients) + ", " + std::to_string(delay_samples) + ">";
}

template <class Scalar>
std::string generate(const indicial::RuntimeModel<Scalar, Cap>& r, const std::string& ident,
                     const std::string& ns, const std::string& source_name, std::uint32_t crc,
                     const std::string& capacity, const std::string& include_name) {
  const indicial::ModelSet<Scalar, Cap>& m = r.set;
  char crc_hex[16];
  std::snprintf(crc_hex, sizeof crc_hex, "%08x", static_cast<unsigned>(crc));
  const std::string scalar = std::is_same<Scalar, float>::value ? "float" : "double";
  const std::string cap = ident + "_capacity";
  // The default capacity is spelled out in the types (as before --capacity existed).
  const std::string cap_type = capacity == "indicial::DefaultCapacity" ? capacity : cap;
  const std::string type = "indicial::RuntimeModel<" + scalar + ", " + cap_type + ">";
  // The state a step of this model needs (runtime.hpp: a delay needs the ring, families their
  // states).
  const std::string state_type = r.delay == indicial::DelayUse::delayed ? "DelayedState"
                                 : r.stall == indicial::StallUse::families ? "FamilyState"
                                                                           : "State";
  std::string o;
  o += "// Generated by `indicial codegen` from " + source_name + " (checksum " + crc_hex +
       "). Do not edit:\n"
       "// regenerate from the coefficient file instead.\n"
       "//\n"
       "//   #include \"" + include_name + "\"   // includes indicial/runtime.hpp, no parser\n"
       "//   const auto& model = " + ns + "::" + ident + ";   // in read-only memory, never copied\n"
       "//   indicial::check_runtime_model(model);            // once, at start: LoadStatus::ok\n"
       "//   indicial::" + state_type + "<" + scalar + ", " + ns + "::" + cap + "> state;  // per instance\n"
       "//   indicial::reset(model, state, angle_rad, airspeed_mps);  // then indicial::step(...)\n"
       "//   // or: indicial::Predictor<" + scalar + ", " + ns + "::" + cap + "> p; p.use(model);\n"
       "#pragma once\n\n"
       "#include \"indicial/runtime.hpp\"\n\n"
       "namespace " + ns + " {\n"
       "using " + cap + " = " + capacity + ";\n\n"
       "namespace codegen_detail {\n"
       "constexpr " + type + " make_" + ident + "() {\n"
       "  " + type + " r{};\n"
       "  indicial::ModelSet<" + scalar + ", " + cap_type + ">& m = r.set;\n";
  o += std::string("  m.axis = indicial::Axis::") + indicial::axis_name(m.axis) + ";\n";
  o += "  m.reference_length_m = " + literal(m.reference_length_m) + ";\n";
  o += "  m.airspeed_mps = " + literal(m.airspeed_mps) + ";\n";
  o += "  m.alpha0_rad = " + literal(m.alpha0_rad) + ";\n";
  o += "  m.x_min_rad = " + literal(m.x_min_rad) + ";\n";
  o += "  m.x_max_rad = " + literal(m.x_max_rad) + ";\n";
  o += "  m.n_coefficients = " + std::to_string(m.n_coefficients) + ";\n";
  for (int c = 0; c < m.n_coefficients; ++c)
    emit_coefficient(o, "m.coefficients[" + std::to_string(c) + "]", m.coefficients[c]);
  emit_step_constants(o, r);
  o += "  return r;\n"
       "}\n"
       "}  // namespace codegen_detail\n\n"
       "inline constexpr " + type + " " + ident + " =\n    codegen_detail::make_" + ident + "();\n"
       "}  // namespace " + ns + "\n";
  return o;
}

void run_codegen(const CodegenOptions& o) {
  using namespace indicial;
  const std::string ident = o.name.empty() ? identifier_from_path(o.model_path) : o.name;
  const std::string ident_problem = identifier_problem(ident);
  if (!ident_problem.empty())
    throw InputError("--name", 0,
                     "'" + ident + "' " + ident_problem +
                         (o.name.empty() ? " (taken from the file name; give --name IDENT)" : ""));
  const std::string ns_problem = namespace_problem(o.name_space);
  if (!ns_problem.empty())
    throw InputError("--namespace", 0, "'" + o.name_space + "' " + ns_problem);
  if (o.out.empty()) throw InputError("--out", 0, "an output header path is required");
  const std::string text = read_text(o.model_path);
  auto model = std::make_unique<RuntimeModel<double, Cap>>();
  ParseDiagnostic diag;
  const LoadStatus st = load_runtime_model(text.data(), text.size(), model.get(), &diag);
  if (st != LoadStatus::ok) {
    throw InputError(o.model_path, static_cast<long>(diag.line),
                     std::string(diag.reason) + " (" + to_string(st) + ")");
  }
  // The file's own checksum line (the parse above accepted it: 8 hex digits), not a CRC of its
  // bytes, which differs for a CRLF copy of an LF-signed file (coef_file.hpp's crc32_lf).
  const std::size_t at = text.rfind("checksum ");
  const std::uint32_t crc =
      at == std::string::npos ? 0u : static_cast<std::uint32_t>(std::strtoul(text.c_str() + at + 9, nullptr, 16));
  const std::string source = std::filesystem::path(o.model_path).filename().string();
  // The usage comment includes the header by the name it is written under (it said
  // `<identifier>.hpp` whatever --out named).
  const std::string include_name = std::filesystem::path(o.out).filename().string();
  const std::string capacity =
      o.capacity == "tight" ? tight_capacity(model->set) : std::string("indicial::DefaultCapacity");
  std::string header;
  if (o.scalar == "float") {
    // The float model exactly as Predictor<float>::load builds it from the same text.
    auto model_f = std::make_unique<RuntimeModel<float, Cap>>();
    const LoadStatus sf = make_runtime_model(model->set, model_f.get(), &diag);
    if (sf != LoadStatus::ok)
      throw InputError(o.model_path, 0, std::string(diag.reason) + " in float (" + to_string(sf) + ")");
    header = generate(*model_f, ident, o.name_space, source, crc, capacity, include_name);
  } else {
    header = generate(*model, ident, o.name_space, source, crc, capacity, include_name);
  }
  refuse_output_onto_input(o.out, {o.model_path});
  write_file_atomically(o.out, header, o.force ? Overwrite::replace : Overwrite::refuse);
  std::printf("codegen: wrote %s (%s::%s: %s, %d coefficient%s, %s)\n", o.out.c_str(),
              o.name_space.c_str(), ident.c_str(), axis_name(model->set.axis),
              model->set.n_coefficients, model->set.n_coefficients == 1 ? "" : "s",
              o.scalar.c_str());
}

const indicial::tools::RegisterCommand register_codegen([](CLI::App& app) {
  auto opt = std::make_shared<CodegenOptions>();
  CLI::App* sub = app.add_subcommand(
      "codegen",
      "Write a C++17 header holding MODEL.coef as `inline constexpr\n"
      "indicial::RuntimeModel<double, indicial::DefaultCapacity> NS::IDENT` (read-only memory,\n"
      "stepped in place: indicial::step(NS::IDENT, state, ...) or Predictor::use(NS::IDENT); no\n"
      "parsing, the header includes only indicial/runtime.hpp). The file is parsed and validated\n"
      "exactly as Predictor::load does; refusals are reported as FILE:LINE: reason (status).\n"
      "--scalar float writes RuntimeModel<float, ...> (Predictor<float>, State<float>; the model\n"
      "Predictor<float>::load builds from the same text, bit for bit); --capacity tight the\n"
      "smallest Capacity that holds the model (NS::IDENT_capacity).");
  sub->add_option("MODEL", opt->model_path, "coefficient file (.coef)")->required();
  sub->add_option("--out", opt->out, "header to write")->required();
  sub->add_option("--name", opt->name,
                  "C++ identifier of the model, not a keyword (default: the file stem, e.g.\n"
                  "tailless_model_2)");
  sub->add_option("--namespace", opt->name_space,
                  "namespace of the generated model (default: indicial_generated)");
  sub->add_option("--scalar", opt->scalar,
                  "double (default) or float: the Scalar of the generated RuntimeModel")
      ->check(CLI::IsMember({"double", "float"}));
  sub->add_option("--capacity", opt->capacity,
                  "default (DefaultCapacity) or tight (the smallest indicial::Capacity that holds\n"
                  "this model); declared as NS::IDENT_capacity in the header")
      ->check(CLI::IsMember({"default", "tight"}));
  sub->add_flag("--force", opt->force, "replace an existing header");
  sub->callback([opt]() { run_codegen(*opt); });
});

}  // namespace
