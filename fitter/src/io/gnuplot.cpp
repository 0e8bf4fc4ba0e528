// The gnuplot runner. See indicial/fitter/gnuplot.hpp.
#include "indicial/fitter/gnuplot.hpp"

#include <sys/wait.h>

#include <cstdlib>

#include "indicial/fitter/error.hpp"

namespace fs = std::filesystem;

namespace indicial {
namespace {

// A POSIX shell word in single quotes.
std::string sh_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "'\\''";
    else q += c;
  }
  return q + "'";
}

// Removes a file when it goes out of scope (the staged script and its log).
struct RemoveOnExit {
  fs::path path;
  ~RemoveOnExit() {
    std::error_code ec;
    fs::remove(path, ec);
  }
};

}  // namespace

std::string gnuplot_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) {
    if (c == '\'') q += "''";
    else q += c;
  }
  return q + "'";
}

GnuplotRun run_gnuplot(const std::string& executable, const fs::path& directory,
                       const std::string& script_file, const std::string& log_file) {
  const std::string cmdline = "cd " + sh_quote(directory.string()) + " && " + sh_quote(executable) + " " +
                              sh_quote(script_file) + " > " + sh_quote(log_file) + " 2>&1";
  const int rc = std::system(cmdline.c_str());
  GnuplotRun g;
  g.exit_code = (rc != -1 && WIFEXITED(rc)) ? WEXITSTATUS(rc) : -1;
  // Why 126/127: the shell's codes for "not executable" and "command not found".
  g.outcome = g.exit_code == 0                              ? GnuplotOutcome::ran
              : (g.exit_code == 126 || g.exit_code == 127) ? GnuplotOutcome::not_found
                                                           : GnuplotOutcome::failed;
  return g;
}

void write_gnuplot_png(const fs::path& png_path, const std::function<std::string(const std::string&)>& script,
                       const std::string& executable, Overwrite overwrite) {
  write_file_atomically(png_path, overwrite, [&](const fs::path& tmp) {
    const fs::path dir = tmp.has_parent_path() ? tmp.parent_path() : fs::path(".");
    const RemoveOnExit gp{fs::path(tmp.string() + ".gp")};
    const RemoveOnExit log{fs::path(tmp.string() + ".log")};
    write_text(gp.path, script(tmp.filename().string()));
    const GnuplotRun g = run_gnuplot(executable, dir, gp.path.filename().string(), log.path.filename().string());
    if (g.outcome == GnuplotOutcome::not_found)
      throw InputError(png_path.string(), 0, "gnuplot (" + executable + ") could not be run; no plot was made");
    std::error_code ec;
    if (g.outcome != GnuplotOutcome::ran || !fs::exists(tmp, ec) || fs::file_size(tmp, ec) == 0)
      throw InputError(png_path.string(), 0,
                       "gnuplot failed (exit status " + std::to_string(g.exit_code) +
                           "; is gnuplot with the pngcairo terminal installed?)");
  });
}

}  // namespace indicial
