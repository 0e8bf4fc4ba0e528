// The one gnuplot runner (indicial/fitter/gnuplot.hpp, io/gnuplot.cpp): run_gnuplot tells "not
// installed" from "failed"; write_gnuplot_png writes a PNG atomically and leaves nothing behind
// (no PNG, no staged script, no log) when gnuplot cannot run or fails.
#include <doctest/doctest.h>

#include <filesystem>
#include <string>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/gnuplot.hpp"
#include "indicial/fitter/output.hpp"
#include "test_support.hpp"

TEST_SUITE_BEGIN("unit");  // the ctest label (tests/CMakeLists.txt)

namespace fs = std::filesystem;
using indicial::InputError;
using indicial::Overwrite;
using indicial::testing::TempDir;

namespace {
std::string sine_plot(const std::string& output) {
  return "set terminal pngcairo size 320,240\nset output " + indicial::gnuplot_quote(output) +
         "\nplot sin(x) title 'it''s a sine'\nset output\n";
}
}  // namespace

TEST_CASE("gnuplot_quote doubles a quote inside single quotes") {
  CHECK(indicial::gnuplot_quote("a'b") == "'a''b'");
  CHECK(indicial::gnuplot_quote("") == "''");
}

TEST_CASE("run_gnuplot: a missing executable is not_found, a failing script failed, a good one ran") {
  TempDir d;
  indicial::write_text(d.path / "ok.gp", sine_plot("ok.png"));
  indicial::write_text(d.path / "bad.gp", "this is not gnuplot\n");
  const indicial::GnuplotRun missing = indicial::run_gnuplot("/nonexistent/gnuplot", d.path, "ok.gp", "log.txt");
  CHECK(missing.outcome == indicial::GnuplotOutcome::not_found);
  CHECK(missing.exit_code == 127);
  const indicial::GnuplotRun bad = indicial::run_gnuplot("gnuplot", d.path, "bad.gp", "log.txt");
  CHECK(bad.outcome == indicial::GnuplotOutcome::failed);
  CHECK(fs::file_size(d.path / "log.txt") > 0);  // gnuplot's complaint
  const indicial::GnuplotRun ok = indicial::run_gnuplot("gnuplot", d.path, "ok.gp", "log.txt");
  CHECK(ok.outcome == indicial::GnuplotOutcome::ran);
  CHECK(fs::file_size(d.path / "ok.png") > 100);
}

TEST_CASE("write_gnuplot_png: atomic, refuses an existing PNG, leaves nothing behind on failure") {
  TempDir d;
  const fs::path png = d.path / "a b.png";  // a space: the shell command quotes its words
  indicial::write_gnuplot_png(png, sine_plot, "gnuplot", Overwrite::refuse);
  CHECK(fs::file_size(png) > 100);
  CHECK(indicial::testing::directory_entries(d.path) == 1);  // the staged script and log are gone
  const auto size = fs::file_size(png);
  CHECK_THROWS_WITH_AS(indicial::write_gnuplot_png(png, sine_plot, "gnuplot", Overwrite::refuse),
                       doctest::Contains("use --force"), InputError);

  // gnuplot not installed: the error names the PNG, the old PNG stays, nothing else is left.
  CHECK_THROWS_WITH_AS(indicial::write_gnuplot_png(png, sine_plot, "/nonexistent/gnuplot", Overwrite::replace),
                       doctest::Contains("a b.png: gnuplot (/nonexistent/gnuplot) could not be run"), InputError);
  CHECK(fs::file_size(png) == size);
  CHECK(indicial::testing::directory_entries(d.path) == 1);
  // gnuplot fails on the script.
  CHECK_THROWS_WITH_AS(
      indicial::write_gnuplot_png(d.path / "b.png", [](const std::string&) { return std::string("plot nonsense(\n"); },
                                  "gnuplot", Overwrite::refuse),
      doctest::Contains("b.png: gnuplot failed"), InputError);
  CHECK_FALSE(fs::exists(d.path / "b.png"));
  CHECK(indicial::testing::directory_entries(d.path) == 1);
}
