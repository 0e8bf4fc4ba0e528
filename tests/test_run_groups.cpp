// A runs entry's `group` (Run::group: the tunnel entry, campaign or session a run belongs to;
// docs/formats.md): read, written back, and refused at its file and line when empty or when some
// runs have one and others not. What diagnose does with it is test_diagnose_crossval.cpp's.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/experiment_toml.hpp"
#include "fit_test_data.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

using namespace indicial;
using namespace indicial::testing;

namespace {

// 200 samples at 100 Hz: alpha = 5 + 4 sin(2 pi t) deg, CL a line in alpha.
std::string run_csv() {
  std::string s = "time_s,alpha_deg,CL\n";
  for (int k = 0; k < 200; ++k) {
    const double t = 0.01 * k;
    const double a = 5.0 + 4.0 * std::sin(2.0 * 3.141592653589793 * t);
    char row[96];
    std::snprintf(row, sizeof row, "%.17g,%.17g,%.17g\n", t, a, 0.1 * a);
    s += row;
  }
  return s;
}

std::string experiment(const std::string& runs) {
  return "axis = \"pitch\"\ncoefficient = \"CL\"\nreference_length_m = 0.275\nairspeed_mps = 40.0\n"
         "runs = [\n" + runs + "]\n[static]\npolynomial = [0.0, 5.7]\n";
}

std::string load_error(const TempDir& dir, const std::string& text) {
  return load_experiment_error(testing::write_text(dir.path / "experiment.toml", text));
}

}  // namespace

TEST_CASE("run groups: read from the runs entries and written back") {
  TempDir dir("groups");
  for (const char* name : {"r1.csv", "r2.csv", "r3.csv"}) testing::write_text(dir.path / name, run_csv());
  const Experiment e = load_experiment(testing::write_text(
      dir.path / "experiment.toml",
      experiment("  {file = \"r1.csv\", group = \"entry 5\"},\n  {file = \"r2.csv\", group = \"entry 6\"},\n"
                 "  {file = \"r3.csv\", group = \"entry 5\"},\n")));
  REQUIRE(e.runs.size() == 3);
  CHECK(e.runs[0].group == "entry 5");
  CHECK(e.runs[1].group == "entry 6");
  CHECK(e.runs[2].group == "entry 5");
  // Written back (fit's and diagnose's experiment.toml) and read again: the same groups.
  const Experiment again = load_experiment(testing::write_text(dir.path / "again.toml", write_experiment_toml(e, {})));
  REQUIRE(again.runs.size() == 3);
  for (std::size_t r = 0; r < 3; ++r) CHECK(again.runs[r].group == e.runs[r].group);
  // Without groups nothing is written.
  const Experiment none = load_experiment(
      testing::write_text(dir.path / "none.toml", experiment("  \"r1.csv\",\n  \"r2.csv\",\n")));
  CHECK(write_experiment_toml(none, {}).find("group =") == std::string::npos);
}

TEST_CASE("run groups: an empty group, or a run without one beside runs with one, names the file and line") {
  TempDir dir("groups-bad");
  for (const char* name : {"r1.csv", "r2.csv"}) testing::write_text(dir.path / name, run_csv());
  const std::string empty =
      load_error(dir, experiment("  {file = \"r1.csv\", group = \" \"},\n  {file = \"r2.csv\", group = \"b\"},\n"));
  CHECK(empty.find("experiment.toml:6") != std::string::npos);
  CHECK(empty.find("'runs.group' is empty") != std::string::npos);
  const std::string mixed = load_error(dir, experiment("  {file = \"r1.csv\", group = \"a\"},\n  \"r2.csv\",\n"));
  CHECK(mixed.find("experiment.toml:7") != std::string::npos);
  CHECK(mixed.find("r2.csv' has no 'group'") != std::string::npos);
  const std::string wrong_type = load_error(dir, experiment("  {file = \"r1.csv\", group = 5},\n"));
  CHECK(wrong_type.find("runs.group") != std::string::npos);
}
