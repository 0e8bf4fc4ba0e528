// diagnose's written experiment file (diagnose_output.cpp, diagnosed_experiment_toml) when the
// experiment's path is not an experiment file. A Python Experiment's path is its name
// ("experiment" by default), which may name any file where the user runs Python; before,
// diagnose read that file's [columns] and [csv], threw when it was not an experiment file,
// and wrote no experiment.toml. The file must be written, with the default [columns] and
// [csv], and be read back by the fitter's experiment reader (what `indicial fit` runs first).
// (A path naming a directory is not read now either; before, libstdc++ read a directory as
// empty text, i.e. the defaults, so that case has no test that could fail.)
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_test_support.hpp"
#include "indicial/fitter/diagnose.hpp"
#include "indicial/fitter/io.hpp"
#include "indicial/fitter/simulate.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
using namespace indicial;
using namespace indicial::testing;

namespace {

const fs::path& scratch() { return scratch_directory("diagnose-experiment-toml"); }

// Model I's experiment on files (its runs exist), as diagnosed with no step, its path `path`.
DiagnoseResult diagnosed_with_path(const fs::path& path) {
  const fs::path data = scratch() / "data";
  if (!fs::exists(data / "experiment.toml"))
    write_simulation_case(find_simulation_case("tailless-model-1"), data.string(), 40.0, 1, Overwrite::refuse);
  DiagnoseResult d;
  d.experiment = load_experiment((data / "experiment.toml").string());
  d.experiment.path = path.string();
  d.configs.push_back(d.experiment.model);
  d.fits.emplace_back();
  return d;
}

// The written text read back as DIR/experiment.toml by the fitter's reader.
Experiment read_back(const std::string& toml, const std::string& dir_name) {
  const fs::path dir = scratch() / dir_name;
  fs::create_directories(dir);
  std::ofstream(dir / "experiment.toml") << toml;
  return load_experiment((dir / "experiment.toml").string());
}

}  // namespace

TEST_CASE("diagnose experiment.toml: a path naming a non-TOML file gives the defaults, with a warning") {
  const fs::path other = scratch() / "experiment.csv";
  std::ofstream(other) << "time_s,alpha_deg\n0,1\n";
  const DiagnoseResult d = diagnosed_with_path(other);
  const std::string toml = diagnosed_experiment_toml(d);
  CHECK(toml.find("[columns]") == std::string::npos);
  // The warning is one of diagnose_warnings (diagnosis.json "warnings", stderr, Python).
  int said = 0;
  for (const std::string& w : diagnose_warnings(d))
    if (w.rfind(other.string() + ": [columns] and [csv] not read (", 0) == 0) ++said;
  CHECK(said == 1);
  const Experiment back = read_back(toml, "from-csv");
  CHECK(back.runs.size() == d.experiment.runs.size());
}
