// indicial/fitter/gnuplot.hpp -- the one way the fitter runs gnuplot.
//
// What it is for
// --------------
// Every plot the product makes is drawn by gnuplot (pngcairo) run as a subprocess: the fit and
// diagnose reports (a script plots.gp beside its data files in DIR/plots/, kept so a user can
// restyle and rerun it), `indicial predict --plot` and `indicial freqresp --plot` (one PNG,
// data inline as datablocks). All of them go through run_gnuplot, so the executable the user
// names (`--gnuplot EXE`) is the one that runs, and "not installed" is told apart from "failed"
// the same way everywhere.
//
// Usage
// -----
//   // a staged plots/ directory that already holds plots.gp:
//   indicial::GnuplotRun g = indicial::run_gnuplot("gnuplot", dir, "plots.gp", "gnuplot.log");
//   // one PNG, atomically (write_file_atomically, output.hpp):
//   indicial::write_gnuplot_png("ramp.png", [](const std::string& out) {
//     return "set terminal pngcairo\nset output '" + out + "'\nplot sin(x)\n"; },
//     "gnuplot", indicial::Overwrite::refuse);
//
// Warnings
// --------
// 1. run_gnuplot runs `cd DIR && EXE SCRIPT > LOG 2>&1` through the shell (std::system): exit
//    codes 126 and 127 (the shell's "not executable" / "command not found") are not_found.
// 2. write_gnuplot_png stages the script beside the PNG (PNG.tmp-*.gp, removed afterwards,
//    with its log) and throws InputError naming the PNG when gnuplot cannot be run, fails, or
//    makes no image; nothing is left behind and an existing PNG is untouched.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include "indicial/fitter/output.hpp"

namespace indicial {

enum class GnuplotOutcome {
  ran,        // exit status 0 (whether the images exist is for the caller to check)
  not_found,  // the executable could not be run (shell status 126 or 127)
  failed      // it ran and exited non-zero (or was killed)
};

struct GnuplotRun {
  GnuplotOutcome outcome = GnuplotOutcome::failed;
  int exit_code = -1;  // the process's exit status; -1 when it did not exit normally
};

// Runs `executable script_file` with `directory` as the working directory, stdout and stderr
// into log_file (both file names relative to directory).
GnuplotRun run_gnuplot(const std::string& executable, const std::filesystem::path& directory,
                       const std::string& script_file, const std::string& log_file);

// Writes one PNG atomically: script(output) must return a gnuplot script that draws into the
// file name `output` (relative to the PNG's directory, already quoted-safe: no quotes in it).
// Refuses an existing png_path unless overwrite == Overwrite::replace (warning 2).
void write_gnuplot_png(const std::filesystem::path& png_path,
                       const std::function<std::string(const std::string& output)>& script,
                       const std::string& executable, Overwrite overwrite);

// A gnuplot string literal in single quotes (a quote inside is doubled).
std::string gnuplot_quote(const std::string& s);

}  // namespace indicial
