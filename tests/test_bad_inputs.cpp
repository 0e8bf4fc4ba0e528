// tests/test_bad_inputs.cpp -- the bad-input catalogue (docs/bad-inputs.md), run through the
// command line: each bad input makes `indicial` exit 1 with exactly one line on stderr,
// "indicial: error: FILE:LINE: problem", and writes nothing. The exact lines are compared in
// full (the temporary directory substituted), so the catalogue's messages are the real ones.
// Library-level tests of the same checks: tests/test_io.cpp (CSV, TOML), tests/test_coef_file.cpp
// (coefficient file statuses), tests/test_fit_bad_inputs.cpp (fitter refusals).
//
// Disk write failure is made honestly even as root (who ignores permissions): the CLI runs in a
// child process with RLIMIT_FSIZE set to a few KB and SIGXFSZ ignored, so the kernel refuses
// every write past the limit with EFBIG exactly as a full disk refuses with ENOSPC; the test
// then checks that the previous results are intact byte for byte and no temporary is left.
#include <doctest/doctest.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "indicial/coef_file.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("cli");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;

namespace {

using indicial::testing::kPi;

// The shared scratch directory, with paths as strings (what the argument lists take).
struct TempDir : indicial::testing::TempDir {
  TempDir() : indicial::testing::TempDir("bad-inputs") {}
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

void write(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  REQUIRE(out.good());
}

struct Result {
  int status = -1;
  std::string err;
};

// Runs `indicial args...` in a child; fsize_limit_bytes > 0 sets RLIMIT_FSIZE there first.
// Why not cli_test_support.hpp's run_indicial: the limit must be set in the child between
// fork and exec, which a shell command line cannot do.
Result run_cli(const TempDir& dir, const std::vector<std::string>& args, long fsize_limit_bytes = 0) {
  const std::string err_path = dir / ".stderr";
  std::fflush(nullptr);  // or the child would write the parent's buffered output again
  const pid_t pid = ::fork();
  REQUIRE(pid >= 0);
  if (pid == 0) {
    // Only async-signal-safe calls until execv (no stdio): plain descriptors, dup2.
    const int e = ::open(err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int o = ::open("/dev/null", O_WRONLY);
    if (e < 0 || o < 0 || ::dup2(e, 2) < 0 || ::dup2(o, 1) < 0) ::_exit(120);
    if (fsize_limit_bytes > 0) {
      // Ignored, SIGXFSZ no longer kills the process: write() fails with EFBIG instead.
      std::signal(SIGXFSZ, SIG_IGN);
      const rlimit lim{static_cast<rlim_t>(fsize_limit_bytes), static_cast<rlim_t>(fsize_limit_bytes)};
      if (::setrlimit(RLIMIT_FSIZE, &lim) != 0) ::_exit(121);
    }
    std::vector<char*> argv;
    std::string exe = INDICIAL_EXE;
    argv.push_back(exe.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(exe.c_str(), argv.data());
    ::_exit(122);
  }
  int wstatus = 0;
  REQUIRE(::waitpid(pid, &wstatus, 0) == pid);
  Result r;
  r.status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 128 + WTERMSIG(wstatus);
  r.err = indicial::testing::slurp(err_path);
  fs::remove(err_path);
  return r;
}

// A good pitch run: 64 samples at 64 Hz (times exact in binary), alpha = 20 + 15 sin(2 pi t)
// deg (5..35 deg), with q and Cm.
std::string good_run_csv(int rows = 64) {
  std::string s = "time_s,alpha_deg,q_degps,Cm\n";
  for (int i = 0; i < rows; ++i) {
    const double t = i / 64.0, w = 2.0 * kPi;
    char line[160];
    std::snprintf(line, sizeof line, "%.17g,%.17g,%.17g,%.17g\n", t, 20.0 + 15.0 * std::sin(w * t),
                  15.0 * w * std::cos(w * t), -0.01 * std::sin(w * t));
    s += line;
  }
  return s;
}

// [rotary] and [model] are stated after `extra` (without them fit warns that they were
// defaulted, a second stderr line these single-line checks do not expect).
std::string experiment_toml(const std::string& run = "run.csv", const std::string& extra = "") {
  return "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.3765\n"
         "airspeed_mps = 17.667762\nruns = [\"" + run + "\"]\n\n[static]\n"
         "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]\n" + extra + "\n[rotary]\npolynomial = [0.0]\n" +
         (extra.find("[model]") == std::string::npos ? "\n[model]\n" : "");
}

// Writes the experiment and the run, runs `fit`, and checks exit 1, the exact line, and that
// the output directory was not created.
void expect_fit_refusal(const std::string& run_csv, const std::string& toml,
                        const std::string& expected_after_dir) {
  TempDir dir;
  write(dir / "run.csv", run_csv);
  write(dir / "experiment.toml", toml);
  const Result r = run_cli(dir, {"fit", dir / "experiment.toml", "--out", dir / "out", "--no-plots"});
  std::string expected = "indicial: error: " + dir.path.string() + "/" + expected_after_dir + "\n";
  // "{DIR}" inside the message stands for the temporary directory too.
  for (std::size_t at = expected.find("{DIR}"); at != std::string::npos; at = expected.find("{DIR}"))
    expected.replace(at, 5, dir.path.string());
  MESSAGE("message: " << r.err);
  CHECK(r.status == 1);
  CHECK(r.err == expected);
  CHECK(!fs::exists(dir / "out"));
}

std::string replace_once(std::string s, const std::string& from, const std::string& to) {
  const std::size_t at = s.find(from);
  REQUIRE(at != std::string::npos);
  return s.replace(at, from.size(), to);
}

// The row with its time field replaced.
std::string with_time(const std::string& row, const std::string& time) { return time + row.substr(row.find(',')); }

std::string line_of(const std::string& csv, int line_1based) {
  std::istringstream in(csv);
  std::string line;
  for (int i = 0; i < line_1based; ++i) std::getline(in, line);
  return line;
}

}  // namespace

// ---- run CSV (through `indicial fit`) -----------------------------------------------------

TEST_CASE("CSV: empty file") {
  expect_fit_refusal("", experiment_toml(), "run.csv: file is empty");
}
TEST_CASE("CSV: header only") {
  expect_fit_refusal("# comment\ntime_s,alpha_deg,Cm\n", experiment_toml(),
                     "run.csv:2: header only: no data rows");
}
TEST_CASE("CSV: missing column") {
  std::string csv = good_run_csv();
  csv = replace_once(csv, "time_s,alpha_deg,q_degps,Cm", "time_s,alpha_deg,q_degps,CL");
  expect_fit_refusal(csv, experiment_toml(), "run.csv:1: missing column 'Cm' (columns found: time_s, alpha_deg, q_degps, "
                                             "CL); did you mean 'CL'? (rename it, or map it in the experiment: "
                                             "[columns] Cm = \"CL\")");
}
TEST_CASE("CSV: duplicate column") {
  std::string csv = replace_once(good_run_csv(), "time_s,alpha_deg,q_degps,Cm", "time_s,alpha_deg,q_degps,q_degps");
  expect_fit_refusal(csv, experiment_toml(), "run.csv:1: duplicate column 'q_degps'");
}
TEST_CASE("CSV: NaN and Inf values") {
  const std::string good = good_run_csv();
  const std::string row5 = line_of(good, 5);
  const std::string cm5 = row5.substr(row5.rfind(',') + 1);
  expect_fit_refusal(replace_once(good, row5, row5.substr(0, row5.rfind(',') + 1) + "nan"),
                     experiment_toml(), "run.csv:5: column 'Cm': NaN or Inf value 'nan'");
  expect_fit_refusal(replace_once(good, row5, row5.substr(0, row5.rfind(',') + 1) + "-inf"),
                     experiment_toml(), "run.csv:5: column 'Cm': NaN or Inf value '-inf'");
  expect_fit_refusal(replace_once(good, row5, row5.substr(0, row5.rfind(',') + 1) + "1e999"),
                     experiment_toml(), "run.csv:5: column 'Cm': number out of range '1e999'");
  (void)cm5;
}
TEST_CASE("CSV: non-numeric value and wrong field count") {
  const std::string good = good_run_csv();
  const std::string row7 = line_of(good, 7);
  expect_fit_refusal(replace_once(good, row7, "0.09375,twenty,1,2"), experiment_toml(),
                     "run.csv:7: column 'alpha_deg': non-numeric value 'twenty'");
  expect_fit_refusal(replace_once(good, row7, row7 + ",9"), experiment_toml(),
                     "run.csv:7: expected 4 comma-separated fields as in the header, found 5");
}
TEST_CASE("CSV: non-monotonic and duplicate time") {
  const std::string good = good_run_csv();
  const std::string row8 = line_of(good, 8);  // time 0.09375, after 0.078125
  expect_fit_refusal(replace_once(good, row8, with_time(row8, "0.07")), experiment_toml(),
                     "run.csv:8: time_s is not strictly increasing (0.07 after 0.078125)");
  expect_fit_refusal(replace_once(good, row8, with_time(row8, "0.078125")), experiment_toml(),
                     "run.csv:8: duplicate time: time_s is not strictly increasing (0.078125 after 0.078125)");
}
TEST_CASE("CSV: non-uniform step") {
  const std::string good = good_run_csv();
  const std::string row8 = line_of(good, 8);
  expect_fit_refusal(replace_once(good, row8, with_time(row8, "0.09")), experiment_toml(),
                     "run.csv:8: non-uniform time step: 0.011875 s after 0.078125, the run's "
                     "step is 0.015625 s (allowed deviation 1e-6 relative or the printed digits; declare "
                     "time_grid = \"nonuniform\" in the run's entry if the log is not uniform)");
}
TEST_CASE("CSV: unit suffix missing or unknown") {
  const std::string good = good_run_csv();
  expect_fit_refusal(replace_once(good, "alpha_deg", "alpha"), experiment_toml(),
                     "run.csv:1: column 'alpha' has no unit suffix (use alpha_deg or alpha_rad)");
  expect_fit_refusal(replace_once(good, "alpha_deg", "alpha_grad"), experiment_toml(),
                     "run.csv:1: column 'alpha_grad' has unknown unit suffix '_grad' (use alpha_deg or alpha_rad)");
  expect_fit_refusal(replace_once(good, "q_degps", "q_dps"), experiment_toml(),
                     "run.csv:1: column 'q_dps' has unknown unit suffix '_dps' (use q_degps or q_radps)");
}
TEST_CASE("CSV: fewer rows than one smoothing window") {
  expect_fit_refusal(good_run_csv(10), experiment_toml(),
                     "run.csv:11: only 10 data rows; a run needs at least 11");
}

// ---- experiment TOML ------------------------------------------------------------------------

TEST_CASE("TOML: unknown (misspelt) key") {
  expect_fit_refusal(good_run_csv(), experiment_toml("run.csv", "\n[model]\na_degre = 2\n"),
                     "experiment.toml:11: unknown key 'model.a_degre' (allowed here: a_degree, "
                     "a_knots_deg, a_powers, b1_degree, b1_knots_deg, b1_powers, b2_degree, b2_knots_deg, "
                     "b2_powers, b3_degree, b3_knots_deg, b3_powers, bias, delay, "
                     "delay_start_s, further_lag_start, lags, rotary_correction_degree, "
                     "rotary_correction_knots_deg, rotary_correction_powers, stall, stall_CN1_start, "
                     "stall_T1_start, stall_T1r_start, stall_T2_start, stall_Tv_start, stall_Tvl_start, "
                     "stall_attached_max_deg, stall_dxl_start, stall_dxr_start, stall_f0_correction_degree, "
                     "stall_f0_correction_knots_deg, stall_f0_correction_powers, stall_forcing_lag, "
                     "stall_hysteresis, stall_known, stall_lag_limit, stall_polar, "
                     "stall_polar_column, stall_reattachment, "
                     "static_correction_degree, "
                     "static_correction_knots_deg, static_correction_powers, structure)");
}
TEST_CASE("TOML: mistyped value") {
  expect_fit_refusal(good_run_csv(),
                     replace_once(experiment_toml(), "airspeed_mps = 17.667762", "airspeed_mps = \"17.7\""),
                     "experiment.toml:4: wrong type: 'airspeed_mps' must be a number, found a string");
}
TEST_CASE("TOML: syntax error") {
  expect_fit_refusal(good_run_csv(), replace_once(experiment_toml(), "runs = [\"run.csv\"]", "runs = [\"run.csv\""),
                     "experiment.toml:7: TOML syntax error: Error while parsing array: expected "
                     "comma or closing ']', saw '['");
}
TEST_CASE("TOML: knot outside the data's angle range") {
  expect_fit_refusal(good_run_csv(), experiment_toml("run.csv", "\n[model]\na_knots_deg = [40.0]\n"),
                     "experiment.toml:11: 'model.a_knots_deg': knot 40 deg is outside the data's "
                     "alpha range [5, 35] deg");
}
TEST_CASE("angle outside the static table") {
  TempDir dir;
  write(dir / "run.csv", good_run_csv());
  write(dir / "static.csv", "alpha_deg,Cm\n0,0\n10,0.1\n20,0.15\n30,0.1\n");
  write(dir / "experiment.toml",
        replace_once(experiment_toml(), "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]", "table = \"static.csv\""));
  const Result r = run_cli(dir, {"fit", dir / "experiment.toml", "--out", dir / "out", "--no-plots"});
  MESSAGE("message: " << r.err);
  CHECK(r.status == 1);
  CHECK(r.err == "indicial: error: " + (dir / "experiment.toml") + ":8: the static table '" + (dir / "static.csv") +
                     "' covers alpha [0, 30] deg but the runs reach [5, 35] deg\n");
  CHECK(!fs::exists(dir / "out"));
}

// ---- fitter refusals (the data cannot determine the model) ----------------------------------

TEST_CASE("more parameters than samples") {
  expect_fit_refusal(good_run_csv(12),
                     experiment_toml("run.csv", "\n[model]\na_degree = 7\nb1_degree = 4\n"),
                     "experiment.toml: 12 samples for 13 parameters: need more samples than parameters");
}
TEST_CASE("rank-deficient regressors: a ramp at constant rate with a bias") {
  // On a ramp x' is constant, so the a0 term (a0 x') and the bias (con) are the same column.
  std::string csv = "time_s,alpha_deg,q_degps,Cm\n";
  for (int i = 0; i < 60; ++i) {
    char line[120];
    std::snprintf(line, sizeof line, "%.17g,%.17g,32,%.17g\n", i / 64.0, 5.0 + 0.5 * i, 0.001 * i * i);
    csv += line;
  }
  expect_fit_refusal(csv, experiment_toml("run.csv", "\n[model]\na_degree = 0\nbias = true\n"),
                     "experiment.toml: regressors are linearly dependent (rank 2 of 3): terms a0, con "
                     "cannot be told apart on these data; remove one");
}

// ---- coefficient files (`indicial coef check`, as the runtime loads them) --------------------

namespace {
std::string model_one_text() {
  return indicial::testing::slurp(std::string(INDICIAL_SOURCE_DIR) + "/examples/tailless-model-1.coef");
}
std::string with_checksum(std::string body) {
  char line[32];
  std::snprintf(line, sizeof line, "checksum %08x\n", static_cast<unsigned>(indicial::crc32(body.data(), body.size())));
  return body + line;
}
std::string body_of(const std::string& text) { return text.substr(0, text.rfind("checksum ")); }

void expect_coef_refusal(const std::string& text, const std::string& expected_after_file) {
  TempDir dir;
  write(dir / "m.coef", text);
  const Result r = run_cli(dir, {"coef", "check", dir / "m.coef"});
  MESSAGE("message: " << r.err);
  CHECK(r.status == 1);
  CHECK(r.err == "indicial: error: " + (dir / "m.coef") + expected_after_file + "\n");
}
}  // namespace

TEST_CASE("coefficient file: truncated") {
  const std::string good = model_one_text();
  expect_coef_refusal(good.substr(0, good.size() / 2), ":8: no checksum line (file truncated?) (truncated)");
}
TEST_CASE("coefficient file: corrupted (one digit changed)") {
  expect_coef_refusal(replace_once(model_one_text(), "lag_poly 1 2.5", "lag_poly 1 2.6"),
                      ":15: checksum mismatch: the file is corrupted (checksum_mismatch; the "
                      "bytes before it give " +
                          [] {
                            const std::string b = body_of(replace_once(model_one_text(), "lag_poly 1 2.5", "lag_poly 1 2.6"));
                            char hex[16];
                            std::snprintf(hex, sizeof hex, "%08x", static_cast<unsigned>(indicial::crc32(b.data(), b.size())));
                            return std::string(hex);
                          }() + ")");
}
TEST_CASE("coefficient file: wrong version") {
  expect_coef_refusal(with_checksum(replace_once(body_of(model_one_text()), "indicial-coef 1", "indicial-coef 3")),
                      ":1: unsupported file version (this runtime reads versions 1 and 2) (wrong_version)");
}
TEST_CASE("coefficient file: over capacity") {
  std::string knots;
  for (int i = 0; i < 40; ++i) knots += "a_knot " + std::to_string(0.01 * (i + 1)) + " 2 1\n";
  expect_coef_refusal(with_checksum(replace_once(body_of(model_one_text()), "lag_poly 1 2.5\n", knots + "lag_poly 1 2.5\n")),
                      ":19: more knots than the capacity allows (over_capacity)");
}

// ---- outputs: whole or not at all -------------------------------------------------------------

TEST_CASE("output directory not empty: refused, contents untouched") {
  TempDir dir;
  fs::create_directories(dir / "out");
  write(dir / "out/previous.txt", "previous results\n");
  const Result r = run_cli(dir, {"simulate", "--case", "tailless-model-1", "--out", dir / "out"});
  MESSAGE("message: " << r.err);
  CHECK(r.status == 1);
  CHECK(r.err == "indicial: error: " + (dir / "out") +
                     ": output directory is not empty (use --force to replace its contents)\n");
  CHECK(indicial::testing::slurp(dir / "out/previous.txt") == "previous results\n");
  CHECK(std::distance(fs::directory_iterator(dir / "out"), fs::directory_iterator{}) == 1);
}

namespace {
// Every file under `root`, relative path -> contents.
std::map<std::string, std::string> tree(const fs::path& root) {
  std::map<std::string, std::string> t;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) t[fs::relative(e.path(), root).string()] = indicial::testing::slurp(e.path().string());
  return t;
}
std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> n;
  for (const auto& e : fs::directory_iterator(dir)) n.push_back(e.path().filename().string());
  std::sort(n.begin(), n.end());
  return n;
}
}  // namespace

TEST_CASE("disk write failure with --force: the previous results stay whole, no temporary left") {
  TempDir dir;
  // Previous results: a complete simulate output.
  Result r = run_cli(dir, {"simulate", "--case", "tailless-model-1", "--out", dir / "out"});
  REQUIRE(r.status == 0);
  const auto before = tree(dir / "out");
  REQUIRE(before.size() >= 3);
  const auto names_before = names_in(dir.path);
  // The run CSVs are tens of KB: with a 4 KB file size limit the first one fails half-written.
  r = run_cli(dir, {"simulate", "--case", "tailless-model-1", "--out", dir / "out", "--force"}, 4096);
  MESSAGE("message: " << r.err);
  CHECK(r.status == 1);
  // The message names the output asked for (DIR/out/<file>), not the staging directory.
  CHECK(r.err.rfind("indicial: error: " + (dir / "out") + "/", 0) == 0);
  CHECK(r.err.find("staging") == std::string::npos);
  CHECK(ends_with(r.err, ": write failed: File too large; " + (dir / "out") + " left as it was\n"));
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
  CHECK(tree(dir / "out") == before);          // byte for byte
  CHECK(names_in(dir.path) == names_before);   // no staging or .old directory left behind
}

TEST_CASE("disk write failure of a single file with --force: the previous file stays whole") {
  TempDir dir;
  const std::string coef = std::string(INDICIAL_SOURCE_DIR) + "/examples/tailless-model-1.coef";
  const std::string motion = "sine:alpha0_deg=35,amp_deg=35,freq_hz=0.5,cycles=3,dt_s=0.01";
  Result r = run_cli(dir, {"simulate", "--model", coef, "--motion", motion, "--out", dir / "sim.csv"});
  REQUIRE(r.status == 0);
  const std::string before = indicial::testing::slurp(dir / "sim.csv");
  REQUIRE(before.size() > 8192);
  r = run_cli(dir, {"simulate", "--model", coef, "--motion", motion, "--out", dir / "sim.csv", "--force"}, 4096);
  MESSAGE("message: " << r.err);
  CHECK(r.status == 1);
  CHECK(r.err == "indicial: error: " + (dir / "sim.csv") + ": write failed: File too large; " +
                     (dir / "sim.csv") + " left as it was\n");
  CHECK(indicial::testing::slurp(dir / "sim.csv") == before);
  CHECK(names_in(dir.path) == std::vector<std::string>{"sim.csv"});
}

// ---- tolerant input, phase cycles, run conditions, warnings, capacities (issues 12, 14) -----

namespace {

// A phase-averaged cycle of 64 samples (phase rounded to 0.01 rad), alpha 5..35 deg.
std::string cycle_csv(double jitter_rad = 0.0) {
  std::string s = "phase_rad,alpha_deg,Cm\n";
  for (int k = 0; k < 64; ++k) {
    const double ph = 2.0 * kPi * k / 64 + (k == 32 ? jitter_rad : 0.0);
    char line[96];
    std::snprintf(line, sizeof line, "%.2f,%.17g,%.17g\n", ph, 20.0 - 15.0 * std::cos(ph), -0.01 * std::sin(ph));
    s += line;
  }
  return s;
}

std::string with_runs(const std::string& runs_value, const std::string& extra = "") {
  return replace_once(experiment_toml("run.csv", extra), "runs = [\"run.csv\"]", "runs = [" + runs_value + "]");
}

}  // namespace

// (A frequency for a time column is accepted since the noise from a record's cycles needs it:
// test_csv_reader "periodic = true on a record of several cycles ...".)
TEST_CASE("runs: a phase column without its frequency, or with periodic = false") {
  expect_fit_refusal(cycle_csv(), experiment_toml(),
                     "run.csv:1: column 'phase_rad' needs the cycle's frequency: give frequency_hz or "
                     "reduced_frequency in the experiment's runs entry");
  expect_fit_refusal(cycle_csv(), with_runs(R"({file = "run.csv", frequency_hz = 1.0, periodic = false})"),
                     "experiment.toml:5: run 'run.csv' has a phase column, so it is one periodic cycle: remove "
                     "'periodic = false'");
}

// A phase-averaged cycle with its spread column Cm_std (docs/formats.md "Phase-averaged cycles
// with a spread column"): `bad` replaces the spread of row `bad_row` (line bad_row + 2).
std::string spread_cycle_csv(const std::string& bad = "", int bad_row = -1) {
  std::string s = "phase_rad,alpha_deg,Cm,Cm_std\n";
  for (int k = 0; k < 64; ++k) {
    const double ph = 2.0 * kPi * k / 64;
    char line[128];
    std::snprintf(line, sizeof line, "%.2f,%.17g,%.17g,", ph, 20.0 - 15.0 * std::cos(ph), -0.01 * std::sin(ph));
    s += line + (k == bad_row ? bad : std::string("0.002")) + "\n";
  }
  return s;
}

TEST_CASE("runs: a spread column that is negative, without cycles_averaged, or with fewer than 2 cycles") {
  expect_fit_refusal(spread_cycle_csv("-0.001", 10), with_runs(R"({file = "run.csv", frequency_hz = 1.0, cycles_averaged = 8})"),
                     "run.csv:12: column 'Cm_std': spread -0.001 is negative (a standard deviation across the "
                     "averaged cycles is >= 0)");
  expect_fit_refusal(spread_cycle_csv(), with_runs(R"({file = "run.csv", frequency_hz = 1.0})"),
                     "experiment.toml:5: run 'run.csv' has a spread column 'Cm_std' but its entry gives no "
                     "'cycles_averaged': give the number of cycles averaged (the noise of the average is Cm_std / "
                     "sqrt(cycles_averaged))");
  expect_fit_refusal(spread_cycle_csv(), with_runs(R"({file = "run.csv", frequency_hz = 1.0, cycles_averaged = 1})"),
                     "experiment.toml:5: 'runs.cycles_averaged' must be an integer 2..1000000 (the number of cycles "
                     "the file's average and spread column were taken over; one cycle has no spread)");
}

TEST_CASE("runs: an empty group, or a run without one beside runs with one") {
  expect_fit_refusal(good_run_csv(), with_runs(R"({file = "run.csv", group = ""})"),
                     "experiment.toml:5: 'runs.group' is empty: name the tunnel entry, campaign or session the run "
                     "belongs to");
  expect_fit_refusal(good_run_csv(), with_runs(R"({file = "run.csv", group = "entry 5"}, "run.csv")"),
                     "experiment.toml:5: run 'run.csv' has no 'group' while run 'run.csv' has group 'entry 5': give "
                     "every run a group (diagnose --cv-unit group leaves whole groups out) or none");
}

TEST_CASE("a missing run file names the experiment's line") {
  expect_fit_refusal(good_run_csv(), with_runs(R"("run.csv", "nope.csv")"),
                     "experiment.toml:5: run file 'nope.csv' not found (looked for {DIR}/nope.csv)");
}

TEST_CASE("runtime limits are checked at input: static-table rows, knots, lags") {
  TempDir dir;
  std::string table = "alpha_deg,Cm\n";
  for (int i = 0; i < 80; ++i) table += std::to_string(i * 0.5) + ",0\n";
  write(dir / "static.csv", table);
  write(dir / "run.csv", good_run_csv());
  write(dir / "experiment.toml", replace_once(experiment_toml(), "polynomial = [0.0, 0.42, 0.34, -1.0, 0.40]",
                                              "table = \"static.csv\""));
  const Result r = run_cli(dir, {"fit", dir / "experiment.toml", "--out", dir / "out", "--no-plots"});
  CHECK(r.status == 1);
  CHECK(r.err == "indicial: error: " + (dir / "experiment.toml") + ":8: 'static.table' needs 80 rows ('" +
                     (dir / "static.csv") + "'); the runtime (indicial::DefaultCapacity) holds at most 64 (thin the table to at most 64 rows: keep "
                     "those where the curve bends, drop rows where it is straight)\n");
  expect_fit_refusal(good_run_csv(), experiment_toml("run.csv", "\n[model]\nb1_knots_deg = [6, 8, 10, 12, 14, 16, 18, 20, 22]\n"),
                     "experiment.toml:11: 'model.b1_knots_deg' needs 9 knots; the runtime "
                     "(indicial::DefaultCapacity) holds at most 8");
  expect_fit_refusal(good_run_csv(), experiment_toml("run.csv", "\n[model]\nlags = 3\n"),
                     "experiment.toml:11: 'model.lags' needs 3 lags; the runtime (indicial::DefaultCapacity) holds "
                     "at most 2");
}

TEST_CASE("no run moves: refused, one still run among moving ones: a warning") {
  std::string still = "time_s,alpha_deg,Cm\n";
  for (int i = 0; i < 64; ++i) still += std::to_string(i / 64.0) + ",20,0.01\n";
  expect_fit_refusal(still, experiment_toml(),
                     "experiment.toml:5: no run moves: the motion angle is constant in every run, so a(x) and b1(x) "
                     "cannot be identified");
}

TEST_CASE("warnings on plausible mistakes go to stderr, the fit goes on") {
  TempDir dir;
  // Radians in the degree column (0.09..0.61 "deg"), no [rotary] and no [model] sections, an
  // unknown column and a still run beside the moving one.
  std::string rad = "time_s,alpha_deg,q_pa,Cm\n";
  std::string still = "time_s,alpha_deg,Cm\n";
  for (int i = 0; i < 64; ++i) {
    const double t = i / 64.0;
    rad += std::to_string(t) + "," + std::to_string(0.35 + 0.26 * std::sin(2 * kPi * t)) + ",101325," +
           std::to_string(-0.01 * std::sin(2 * kPi * t)) + "\n";
    still += std::to_string(t) + ",0.35,0\n";
  }
  write(dir / "run.csv", rad);
  write(dir / "still.csv", still);
  write(dir / "experiment.toml", "axis = \"pitch\"\ncoefficient = \"Cm\"\nreference_length_m = 0.3765\n"
                                 "airspeed_mps = 17.667762\nruns = [\"run.csv\", \"still.csv\"]\n\n[static]\n"
                                 "polynomial = [0.0, 0.42]\n");
  const Result r = run_cli(dir, {"fit", dir / "experiment.toml", "--out", dir / "out", "--no-plots"});
  MESSAGE(r.err);
  const std::string d = dir.path.string();
  for (const std::string& line :
       {"indicial: note: " + d + "/run.csv: ignored column(s) 'q_pa' (not a column indicial reads)\n",
        "indicial: warning: " + d + "/run.csv: 'alpha_deg' never exceeds 0.61 in magnitude: it looks like "
                                    "radians in a degree column (name it alpha_rad if so)\n",
        "indicial: warning: " + d + "/still.csv: the motion angle never moves (constant 0.35 deg): the run has no "
                                    "unsteady response to fit\n",
        "indicial: warning: " + d + "/experiment.toml: no [rotary] section: C_aq(x) = 0 assumed (the rate term is "
                                    "left out)\n",
        "indicial: warning: " + d + "/experiment.toml: no [model] section: the default a(x) = a0 + a1 x + a2 x^2, "
                                    "b1(x) = b1_0, fixed structure\n"}) {
    CHECK(r.err.find(line) != std::string::npos);
  }
}
