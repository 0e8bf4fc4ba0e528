// The one atomic writer (indicial/fitter/output.hpp, io/output.cpp): write_file_atomically for
// text and for a file something else produces -- whole or not at all, no overwrite without
// Overwrite::replace, no temporary left behind on any failure.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/output.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
using indicial::InputError;
using indicial::Overwrite;
using indicial::OutputDir;
using indicial::testing::TempDir;
using indicial::kOutputManifest;

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST_CASE("write_file_atomically: text written whole, an existing file refused unless replace") {
  TempDir d;
  const fs::path f = d.path / "sub" / "out.txt";
  indicial::write_file_atomically(f, "one\n", Overwrite::refuse);  // makes sub/
  CHECK(indicial::read_text(f) == "one\n");
  CHECK_THROWS_WITH_AS(indicial::write_file_atomically(f, "two\n", Overwrite::refuse),
                       doctest::Contains("use --force"), InputError);
  CHECK(indicial::read_text(f) == "one\n");
  indicial::write_file_atomically(f, "two\n", Overwrite::replace);
  CHECK(indicial::read_text(f) == "two\n");
  CHECK(indicial::testing::directory_entries(f.parent_path()) == 1);
}

TEST_CASE("write_file_atomically with a producer: renamed into place only when it succeeds") {
  TempDir d;
  const fs::path f = d.path / "plot.png";
  fs::path seen;
  indicial::write_file_atomically(f, Overwrite::refuse, [&](const fs::path& tmp) {
    seen = tmp;
    CHECK(tmp.parent_path() == f.parent_path());  // a sibling: the rename stays on one file system
    indicial::write_text(tmp, "png bytes");
  });
  CHECK(indicial::read_text(f) == "png bytes");
  CHECK_FALSE(fs::exists(seen));
  CHECK(indicial::testing::directory_entries(d.path) == 1);

  // The producer fails after writing part of its output: its exception reaches the caller, the
  // temporary is removed and the previous file is untouched.
  CHECK_THROWS_AS(indicial::write_file_atomically(f, Overwrite::replace,
                                                  [&](const fs::path& tmp) {
                                                    indicial::write_text(tmp, "half");
                                                    throw std::runtime_error("producer failed");
                                                  }),
                  std::runtime_error);
  CHECK(indicial::read_text(f) == "png bytes");
  CHECK(indicial::testing::directory_entries(d.path) == 1);

  // The producer makes nothing: an InputError naming the output, nothing created.
  const fs::path g = d.path / "never.png";
  CHECK_THROWS_WITH_AS(indicial::write_file_atomically(g, Overwrite::refuse, [](const fs::path&) {}),
                       doctest::Contains("never.png: nothing was produced"), InputError);
  CHECK_FALSE(fs::exists(g));
  CHECK(indicial::testing::directory_entries(d.path) == 1);

  // An existing file is refused before the producer runs.
  bool ran = false;
  CHECK_THROWS_AS(indicial::write_file_atomically(f, Overwrite::refuse, [&](const fs::path&) { ran = true; }),
                  InputError);
  CHECK_FALSE(ran);
}

// --force replaces a directory's whole contents: never one holding an input of the command or
// the working directory (a user's trial: `fit exp.toml --out data --force` deleted the run
// files and the static table it had just fitted; `--out .` failed with "Device or resource
// busy"). The probe refuses before anything is written.
TEST_CASE("OutputDir with replace refuses a directory holding an input or the working directory") {
  TempDir tmp;
  const fs::path data = tmp.path / "data";
  fs::create_directories(data);
  const std::string input = (data / "run.csv").string();
  indicial::write_text(input, "time_s,alpha_deg,Cm\n");
  CHECK_THROWS_WITH_AS(OutputDir(data, Overwrite::replace, {input}),
                       doctest::Contains("holds an input of this command"), InputError);
  CHECK(fs::exists(input));
  // Named relatively, through "..": the same directory.
  CHECK_THROWS_AS(OutputDir(data / ".." / "data", Overwrite::replace, {input}), InputError);
  // An input elsewhere: a previous output directory is replaced as before.
  const fs::path other = tmp.path / "other";
  {
    OutputDir out(other, Overwrite::refuse, {input});
    out.write("old.txt", "old\n");
    out.commit();
  }
  {
    OutputDir out(other, Overwrite::replace, {input});
    out.write("new.txt", "new\n");
    out.commit();
  }
  CHECK(fs::exists(other / "new.txt"));
  CHECK(!fs::exists(other / "old.txt"));
  // The working directory (or a directory holding it) is never replaced.
  const fs::path cwd = fs::current_path();
  fs::current_path(other);
  CHECK_THROWS_WITH_AS(OutputDir(".", Overwrite::replace), doctest::Contains("the working directory"), InputError);
  CHECK_THROWS_AS(OutputDir(tmp.path, Overwrite::replace), InputError);
  fs::current_path(cwd);
  CHECK(fs::exists(other / "new.txt"));
}

TEST_CASE("OutputDir with replace refuses a directory holding files it did not write, naming them") {
  TempDir tmp;
  const fs::path dir = tmp.path / "out";
  {
    OutputDir out(dir, Overwrite::refuse);
    out.write("fit.json", "{}\n");
    out.write("plots/a.dat", "1 2\n");
    out.commit();
  }
  // The manifest lists what commit() wrote.
  const std::string manifest = slurp(dir / kOutputManifest);
  CHECK(manifest.find("\nfit.json\n") != std::string::npos);
  CHECK(manifest.find("\nplots/a.dat\n") != std::string::npos);
  // A file added afterwards (a user's notes) blocks --force; nothing is touched.
  indicial::write_text(dir / "notes.txt", "mine\n");
  CHECK_THROWS_WITH_AS(OutputDir(dir, Overwrite::replace),
                       doctest::Contains("files indicial did not write there (not in its .indicial-outputs): notes.txt"),
                       InputError);
  CHECK(slurp(dir / "notes.txt") == "mine\n");
  CHECK(fs::exists(dir / "fit.json"));
  // Without notes.txt the directory is indicial's again and is replaced.
  fs::remove(dir / "notes.txt");
  {
    OutputDir out(dir, Overwrite::replace);
    out.write("model.coef", "x\n");
    out.commit();
  }
  CHECK(fs::exists(dir / "model.coef"));
  CHECK_FALSE(fs::exists(dir / "fit.json"));
  // A directory indicial never wrote (no manifest) is refused whatever it holds; more than five
  // files are counted, not all listed.
  const fs::path data = tmp.path / "data";
  fs::create_directories(data);
  for (int i = 0; i < 7; ++i) indicial::write_text(data / ("run" + std::to_string(i) + ".csv"), "t\n");
  CHECK_THROWS_WITH_AS(OutputDir(data, Overwrite::replace),
                       doctest::Contains("(it has no .indicial-outputs): run0.csv, run1.csv, run2.csv, run3.csv, "
                                         "run4.csv and 2 more; move them, or choose another --out"),
                       InputError);
  CHECK(fs::exists(data / "run6.csv"));
}
