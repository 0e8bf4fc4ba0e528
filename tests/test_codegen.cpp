// `indicial codegen`: the generated constexpr headers (made at build time from the committed
// examples by the built executable, see tests/CMakeLists.txt) compile, are constant
// expressions, and run bit for bit like loading the same files as text. Also the command's
// refusals.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <type_traits>
#include <unistd.h>

#include "indicial/coef_file.hpp"
#include "indicial/fitter/output.hpp"
#include "indicial/runtime.hpp"
#include "dynamic_stall_lift_moment.hpp"
#include "synthetic_lift_moment.hpp"
#include "synthetic_lift_moment_float.hpp"
#include "tailless_model_1.hpp"
#include "tailless_model_2.hpp"
#include "tailless_model_2_float.hpp"
#include "codegen_only_tu.hpp"
#include "runtime_test_models.hpp"
#include "cli_test_support.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

using indicial_generated::dynamic_stall_lift_moment;
using indicial_generated::synthetic_lift_moment;
using indicial_generated::tailless_model_1;
using indicial_generated::tailless_model_2;

// The generated models are constant expressions: usable where only constants are allowed.
static_assert(tailless_model_1.set.n_coefficients == 1, "Model I has one coefficient (Cm)");
static_assert(tailless_model_2.set.coefficients[0].lags[0].b.n_knots == 4, "Model II's b1 has 4 knots");
static_assert(synthetic_lift_moment.set.coefficients[0].static_curve.kind == indicial::StaticKind::table,
              "CL is a table");
static_assert(synthetic_lift_moment.set.coefficients[0].lags[1].gain == -0.35, "exact literal");
static_assert(tailless_model_2.delay == indicial::DelayUse::none, "no delay in Model II");
static_assert(dynamic_stall_lift_moment.stall == indicial::StallUse::families, "families in the stall example");
static_assert(dynamic_stall_lift_moment.set.coefficients[1].stall.families ==
                  indicial::StallFamilies::separation_and_vortex,
              "both families on Cm");

namespace {

using Set = indicial::ModelSet<double, indicial::DefaultCapacity>;
using P = indicial::Predictor<double>;
using indicial::testing::kPi;

std::string example(const std::string& name) {
  return indicial::read_text(std::string(INDICIAL_SOURCE_DIR) + "/examples/" + name + ".coef");
}

std::string write(const Set& m) {
  char buffer[16384];
  std::size_t n = 0;
  REQUIRE(indicial::write_coef_file(m, buffer, sizeof buffer, &n) == indicial::WriteStatus::ok);
  return std::string(buffer, n);
}

template <class Scalar>
void compare_runs(const std::string& text, const indicial::RuntimeModel<Scalar, indicial::DefaultCapacity>& generated) {
  using Pred = indicial::Predictor<Scalar>;
  Pred from_text;
  Pred from_header;
  indicial::ParseDiagnostic diag;
  REQUIRE(from_text.load(text.data(), text.size(), &diag) == indicial::LoadStatus::ok);
  REQUIRE(from_header.use(generated) == indicial::LoadStatus::ok);  // in place, no copy
  CHECK(&from_header.runtime() == &generated);
  REQUIRE(from_text.reset(0.61, 17.667762) == indicial::StepStatus::ok);
  REQUIRE(from_header.reset(0.61, 17.667762) == indicial::StepStatus::ok);
  int steps = 0;
  for (int k = 1; k <= 1500; ++k) {
    const double t = 0.002 * k;
    const double w = 2 * kPi * 1.0;
    const indicial::MotionInput in{0.61 + 0.61 * std::sin(w * t), 0.61 * w * std::cos(w * t), 20.0};
    typename Pred::Outputs a;
    typename Pred::Outputs b;
    REQUIRE(from_text.step(in, 0.002, &a) == indicial::StepStatus::ok);
    REQUIRE(from_header.step(in, 0.002, &b) == indicial::StepStatus::ok);
    REQUIRE(a.count == b.count);
    for (int c = 0; c < a.count; ++c) {
      CHECK(std::memcmp(&a.value[c], &b.value[c], sizeof(Scalar)) == 0);
      CHECK(std::strcmp(a.name[c], b.name[c]) == 0);
    }
    ++steps;
  }
  CHECK(steps == 1500);
  const typename Pred::Snapshot sa = from_text.snapshot();
  const typename Pred::Snapshot sb = from_header.snapshot();
  CHECK(std::memcmp(&sa, &sb, sizeof sa) == 0);
}

// Runs the built CLI; returns its exit status and (via *output) stdout + stderr.
int run(const std::string& args, std::string* output) {
  const indicial::testing::CliRun r =
      indicial::testing::run_indicial(args, indicial::testing::scratch_directory("codegen"));
  *output = r.out + r.err;
  return r.exit_code;
}

}  // namespace

TEST_CASE("generated models equal the parsed files exactly") {
  const char* names[4] = {"tailless-model-1", "tailless-model-2", "synthetic-lift-moment",
                          "dynamic-stall-lift-moment"};
  const Set* generated[4] = {&tailless_model_1.set, &tailless_model_2.set, &synthetic_lift_moment.set,
                             &dynamic_stall_lift_moment.set};
  for (int i = 0; i < 4; ++i) {
    const std::string text = example(names[i]);
    // Writing the constexpr model gives back the committed file byte for byte.
    CHECK(write(*generated[i]) == text);
    // And the table's second derivatives in the header are the parser's.
    Set parsed{};
    REQUIRE(indicial::parse_coef_file(text.data(), text.size(), &parsed, nullptr) ==
            indicial::LoadStatus::ok);
    for (int c = 0; c < parsed.n_coefficients; ++c) {
      const auto& x = parsed.coefficients[c].static_curve;
      const auto& y = generated[i]->coefficients[c].static_curve;
      for (int r = 0; r < x.n_table; ++r)
        CHECK(std::memcmp(&x.table_second_derivative[r], &y.table_second_derivative[r], sizeof(double)) == 0);
    }
  }
}

TEST_CASE("the generated header runs bit for bit like the text file") {
  compare_runs(example("tailless-model-1"), tailless_model_1);
  compare_runs(example("tailless-model-2"), tailless_model_2);
  compare_runs(example("synthetic-lift-moment"), synthetic_lift_moment);
}

// --scalar float: the model Predictor<float>::load builds from the text, bit for bit (the
// float spline keeps its knots as float, a table's second derivatives are float's), checked by
// check_runtime_model in use() and stepped bit for bit like the loaded one.
static_assert(std::is_same<decltype(indicial_generated::tailless_model_2_float),
                           const indicial::RuntimeModel<float, indicial::DefaultCapacity>>::value,
              "--scalar float generates a RuntimeModel<float, ...>");
static_assert(indicial_generated::synthetic_lift_moment_float.set.coefficients[0].lags[1].gain == -0.35f,
              "float literals");

TEST_CASE("codegen --scalar float runs bit for bit like the text file in Predictor<float>") {
  compare_runs(example("tailless-model-2"), indicial_generated::tailless_model_2_float);
  compare_runs(example("synthetic-lift-moment"), indicial_generated::synthetic_lift_moment_float);
}

TEST_CASE("the generated dynamic-stall header runs bit for bit like the text file, FamilyState too") {
  const std::string text = example("dynamic-stall-lift-moment");
  P from_text;
  REQUIRE(from_text.load(text.data(), text.size()) == indicial::LoadStatus::ok);
  REQUIRE(indicial::check_runtime_model(dynamic_stall_lift_moment) == indicial::LoadStatus::ok);
  indicial::FamilyState<double, indicial::DefaultCapacity> state;
  REQUIRE(from_text.reset(0.2, 30.0) == indicial::StepStatus::ok);
  REQUIRE(indicial::reset(dynamic_stall_lift_moment, state, 0.2, 30.0) == indicial::StepStatus::ok);
  for (int k = 1; k <= 1500; ++k) {
    const double w = 2 * kPi * 3.0;
    const indicial::MotionInput in{0.24 + 0.17 * std::sin(w * 0.001 * k), 0.17 * w * std::cos(w * 0.001 * k), 30.0};
    P::Outputs a;
    double b[indicial::DefaultCapacity::max_coefficients];
    REQUIRE(from_text.step(in, 0.001, &a) == indicial::StepStatus::ok);
    REQUIRE(indicial::step(dynamic_stall_lift_moment, state, in, 0.001, b) == indicial::StepStatus::ok);
    CHECK(std::memcmp(a.value, b, 2 * sizeof(double)) == 0);
  }
  const P::Snapshot snap = from_text.snapshot();
  CHECK(std::memcmp(&snap.stall, &state.stall, sizeof state.stall) == 0);
  // `coef check` names the families.
  std::string out;
  CHECK(run("coef check \"" + std::string(INDICIAL_SOURCE_DIR) + "/examples/dynamic-stall-lift-moment.coef\"",
            &out) == 0);
  CHECK(out.find("dynamic stall: separation_and_vortex; f0 table of 27 rows") != std::string::npos);
  // A reattachment time constant of its own (sep_reattachment) is emitted, and named by
  // `coef check`; the example has none, so its header has no such line.
  {
    indicial::ModelSet<double, indicial::DefaultCapacity> set{};
    indicial::ParseDiagnostic diag;
    REQUIRE(indicial::parse_coef_file(text.data(), text.size(), &set, &diag) == indicial::LoadStatus::ok);
    set.coefficients[1].stall.separation.tau1_reattach_semichords = 9.5;
    set.coefficients[1].stall.separation.reattach_shift_rad = 0.0625;
    set.coefficients[1].stall.separation.lag_limit_rad = 0.046875;
    static char buffer[65536];
    std::size_t n = 0;
    REQUIRE(indicial::write_coef_file(set, buffer, sizeof buffer, &n) == indicial::WriteStatus::ok);
    const indicial::testing::TempDir scratch("codegen-reattachment");
    const std::string coef = (scratch.path / "r.coef").string(), header = (scratch.path / "r.hpp").string();
    indicial::write_file_atomically(coef, std::string(buffer, n), indicial::Overwrite::refuse);
    CHECK(run("codegen \"" + coef + "\" --out \"" + header + "\"", &out) == 0);
    std::ifstream h(header);
    std::stringstream generated;
    generated << h.rdbuf();
    CHECK(generated.str().find(".separation.tau1_reattach_semichords = 9.5") != std::string::npos);
    CHECK(generated.str().find(".separation.reattach_shift_rad = 0.0625") != std::string::npos);
    CHECK(generated.str().find(".separation.lag_limit_rad = 0.046875") != std::string::npos);
    CHECK(run("coef check \"" + coef + "\"", &out) == 0);
    CHECK(out.find("T1r 9.5 (reattaching)") != std::string::npos);
    CHECK(out.find("static hysteresis dxr 3.58099 deg") != std::string::npos);
    CHECK(out.find("T2's lag limited to 2.68574 deg") != std::string::npos);
  }
  // A changed family parameter is caught by the check (the step constants say families).
  auto changed = dynamic_stall_lift_moment;
  changed.stall = indicial::StallUse::none;
  CHECK(indicial::check_runtime_model(changed) == indicial::LoadStatus::invalid_value);
  // So is a wrong lookup sharing (C_m repeats C_L's table, T2 and T1 in this example).
  CHECK(dynamic_stall_lift_moment.stall_sharing[1].forcing == 0);
  auto unshared = dynamic_stall_lift_moment;
  unshared.stall_sharing[1].forcing = indicial::StallSharing::no_sharing;
  CHECK(indicial::check_runtime_model(unshared) == indicial::LoadStatus::invalid_value);
}

TEST_CASE("codegen refuses damaged files with file:line: reason, and existing output") {
  const indicial::testing::TempDir scratch("codegen-refusals");
  const std::filesystem::path& dir = scratch.path;
  std::string text = example("tailless-model-2");
  const std::string bad = (dir / "bad.coef").string();
  text[text.find("2.5")] = '3';  // corrupt lag_poly 1 2.5 -> 3.5
  indicial::write_file_atomically(bad, text, indicial::Overwrite::refuse);
  std::string out;
  CHECK(run("codegen \"" + bad + "\" --out \"" + (dir / "bad.hpp").string() + "\"", &out) == 1);
  CHECK(out.find("bad.coef:19: checksum mismatch") != std::string::npos);
  CHECK(out.find("checksum_mismatch") != std::string::npos);
  CHECK(!std::filesystem::exists(dir / "bad.hpp"));

  const std::string good = std::string(INDICIAL_SOURCE_DIR) + "/examples/tailless-model-1.coef";
  const std::string hpp = (dir / "m1.hpp").string();
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\"", &out) == 0);
  CHECK(indicial::read_text(hpp).find("inline constexpr indicial::RuntimeModel<double, "
                                      "indicial::DefaultCapacity> tailless_model_1 =") != std::string::npos);
  CHECK(indicial::read_text(hpp).find("namespace indicial_generated {") != std::string::npos);
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name other", &out) == 1);  // exists
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name other --force", &out) == 0);
  CHECK(indicial::read_text(hpp).find(" other =") != std::string::npos);
  // The usage comment includes the header by the name it was written under, not `other.hpp`.
  CHECK(indicial::read_text(hpp).find("//   #include \"m1.hpp\"") != std::string::npos);
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name 9lives --force", &out) == 1);
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name x --namespace my_models --force", &out) == 0);
  CHECK(indicial::read_text(hpp).find("namespace my_models {") != std::string::npos);
  // A keyword is refused naming --name: from the file name (default.coef) or given.
  const std::string keyword_file = (dir / "default.coef").string();
  indicial::write_file_atomically(keyword_file, indicial::read_text(good), indicial::Overwrite::refuse);
  CHECK(run("codegen \"" + keyword_file + "\" --out \"" + (dir / "k.hpp").string() + "\"", &out) == 1);
  CHECK(out.find("--name") != std::string::npos);
  CHECK(out.find("'default' is a C++ keyword") != std::string::npos);
  CHECK(!std::filesystem::exists(dir / "k.hpp"));
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name class --force", &out) == 1);
  CHECK(out.find("'class' is a C++ keyword") != std::string::npos);
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name ok --namespace namespace --force", &out) == 1);
  CHECK(out.find("--namespace") != std::string::npos);
  // A nested namespace (C++17 `namespace a::b {`), each part an identifier.
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name x --namespace sim::aero --force", &out) == 0);
  CHECK(indicial::read_text(hpp).find("namespace sim::aero {") != std::string::npos);
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name x --namespace sim::class --force", &out) == 1);
  CHECK_HAS(out, "has a part 'class' that is a C++ keyword");
  CHECK(run("codegen \"" + good + "\" --out \"" + hpp + "\" --name x --namespace ::sim --force", &out) == 1);
  CHECK_HAS(out, "--namespace");
  // A CRLF copy of the file (git autocrlf) generates from the same model and names the file's
  // own checksum, not the CRC of its CRLF bytes.
  {
    const std::string lf = indicial::read_text(good);
    std::string crlf;
    for (char ch : lf) crlf += ch == '\n' ? std::string("\r\n") : std::string(1, ch);
    const std::string crlf_file = (dir / "crlf.coef").string();
    indicial::write_file_atomically(crlf_file, crlf, indicial::Overwrite::refuse);
    CHECK(run("codegen \"" + crlf_file + "\" --out \"" + (dir / "crlf.hpp").string() + "\"", &out) == 0);
    const std::string sum = lf.substr(lf.rfind("checksum ") + 9, 8);
    CHECK_HAS(indicial::read_text((dir / "crlf.hpp").string()), "crlf.coef (checksum " + sum + ")");
  }
  CHECK(run("codegen \"" + keyword_file + "\" --out \"" + (dir / "k.hpp").string() + "\" --name default_model", &out) == 0);

  // An unstable model (b1 < 0 somewhere) is refused like Predictor::load refuses it.
  Set unstable = indicial::test_models::table_one_model_two();
  unstable.coefficients[0].lags[0].b.knot_coef[0] = -30.0;
  indicial::write_file_atomically((dir / "unstable.coef").string(), write(unstable), indicial::Overwrite::refuse);
  CHECK(run("codegen \"" + (dir / "unstable.coef").string() + "\" --out \"" + (dir / "u.hpp").string() + "\"",
            &out) == 1);
  CHECK(out.find("unstable_lag") != std::string::npos);

  // coef check agrees.
  CHECK(run("coef check \"" + good + "\"", &out) == 0);
  CHECK(out.find("ok") != std::string::npos);
  CHECK(run("coef check \"" + bad + "\"", &out) == 1);
  CHECK(out.find("checksum_mismatch") != std::string::npos);
  // A directory is named as one (it read as "empty input").
  CHECK(run("coef check \"" + dir.string() + "\"", &out) == 1);
  CHECK_HAS(out, "is a directory, expected a file");
}

TEST_CASE("a translation unit with only the generated header and runtime.hpp steps bit for bit") {
  // tests/codegen_only_tu.cpp has #error guards against the parser header and <charconv>;
  // that it compiled is half the test. Here its free-function steps are compared with a
  // Predictor that loaded the same file as text.
  const codegen_only::GeneratedModel which[2] = {codegen_only::GeneratedModel::tailless_model_2,
                                                 codegen_only::GeneratedModel::synthetic_lift_moment};
  const char* names[2] = {"tailless-model-2", "synthetic-lift-moment"};
  const int n = 800;
  static double angle[n];
  static double rate[n];
  static double out[n * 3];
  for (int k = 0; k < n; ++k) {
    const double t = 0.002 * k;
    angle[k] = 0.61 + 0.5 * std::sin(2 * kPi * 1.3 * t);
    rate[k] = 0.5 * 2 * kPi * 1.3 * std::cos(2 * kPi * 1.3 * t);
  }
  for (int i = 0; i < 2; ++i) {
    REQUIRE(codegen_only::step_generated(which[i], angle, rate, n, 0.002, 19.0, out) == n - 1);
    const std::string text = example(names[i]);
    P p;
    REQUIRE(p.load(text.data(), text.size()) == indicial::LoadStatus::ok);
    REQUIRE(p.reset(angle[0], 19.0) == indicial::StepStatus::ok);
    int same = 0;
    for (int k = 1; k < n; ++k) {
      P::Outputs o;
      REQUIRE(p.step({angle[k], rate[k], 19.0}, 0.002, &o) == indicial::StepStatus::ok);
      for (int c = 0; c < o.count; ++c)
        same += std::memcmp(&o.value[c], &out[o.count * k + c], sizeof(double)) == 0;
    }
    CHECK(same == (n - 1) * p.coefficient_count());
  }
}
