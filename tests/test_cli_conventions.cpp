// The command line's conventions (tools/main.cpp): --version, usage errors as one line with
// exit 1 (never CLI11's 105-114), the nearest subcommand for a typo, predict on a directory;
// provenance, warnings, progress and init are added below as they land.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "cli_test_support.hpp"

namespace fs = std::filesystem;

namespace {

using indicial::testing::CliRun;
using indicial::testing::slurp;

const fs::path& scratch() { return indicial::testing::scratch_directory("cli-conventions"); }
CliRun run_cli(const std::string& args) { return indicial::testing::run_indicial(args, scratch()); }

std::size_t count_lines(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += (c == '\n');
  return n;
}

// Exit 1, nothing on stdout, exactly one line on stderr starting "indicial: error: " and
// containing every one of `needles`.
void check_usage_error(const CliRun& r, std::initializer_list<const char*> needles) {
  CHECK(r.exit_code == 1);
  CHECK(r.out.empty());
  CHECK(count_lines(r.err) == 1);
  CHECK(r.err.rfind("indicial: error: ", 0) == 0);
  for (const char* n : needles) {
    CAPTURE(n);
    CHECK(r.err.find(n) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("--version prints the version and exits 0") {
  const CliRun r = run_cli("--version");
  CHECK(r.exit_code == 0);
  CHECK(r.out.rfind("indicial 0.", 0) == 0);  // "indicial X.Y.Z[ (commit ...)]"
  CHECK(count_lines(r.out) == 1);
  CHECK(r.err.empty());
}

TEST_CASE("--help exits 0 and points to the formats documentation") {
  for (const char* args : {"--help", "fit --help", "predict --help"}) {
    CAPTURE(args);
    const CliRun r = run_cli(args);
    CHECK(r.exit_code == 0);
    CHECK(r.out.find("docs/formats.md") != std::string::npos);
  }
}

TEST_CASE("a mistyped subcommand names the nearest one, one line, exit 1") {
  const CliRun typo = run_cli("fitt some.toml");
  check_usage_error(typo, {"unknown subcommand 'fitt'", "did you mean 'fit'?"});
  check_usage_error(run_cli("dignose x.toml --out d"), {"'dignose'", "did you mean 'diagnose'?"});
  // Nothing near: the list of subcommands instead of a guess.
  check_usage_error(run_cli("zzzzzzzzzz"), {"unknown subcommand 'zzzzzzzzzz'", "subcommands:", "predict"});
}

TEST_CASE("no subcommand, a missing required option, an unexpected argument: one line, exit 1") {
  check_usage_error(run_cli(""), {"subcommand is required"});
  check_usage_error(run_cli("fit some.toml"), {"fit:", "--out is required", "indicial fit --help"});
  check_usage_error(run_cli("fit"), {"experiment is required"});
  check_usage_error(run_cli("fit a.toml --out d surplus"), {"not expected", "surplus"});
  check_usage_error(run_cli("predict m.coef d.csv --out p.csv --no-such-option"), {"--no-such-option"});
  check_usage_error(run_cli("fit a.toml --out d --stepwise-refinement sometimes"), {"--stepwise-refinement"});
  check_usage_error(run_cli("coef chek m.coef"), {"coef"});
}

TEST_CASE("predict on a directory says so") {
  const fs::path dir = scratch() / "a-directory";
  fs::create_directories(dir);
  const fs::path model = fs::path(INDICIAL_SOURCE_DIR) / "examples" / "tailless-model-1.coef";
  const CliRun r = run_cli("predict '" + model.string() + "' '" + dir.string() + "' --out '" +
                           (scratch() / "p.csv").string() + "'");
  check_usage_error(r, {"a-directory is a directory, expected a CSV file"});
  CHECK_FALSE(fs::exists(scratch() / "p.csv"));
  const CliRun m = run_cli("predict '" + dir.string() + "' '" + model.string() + "' --out '" +
                           (scratch() / "p.csv").string() + "'");
  check_usage_error(m, {"is a directory, expected a coefficient file"});
}
