// cli_test_support.hpp -- running the built `indicial` from a test and reading what it wrote.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace indicial::testing {

// A whole file as a string ("" when it cannot be read).
inline std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct CliRun {
  int exit_code = -1;  // -1: the shell could not run it or it did not exit normally
  std::string out;
  std::string err;
};

// Runs `indicial ARGS` (INDICIAL_EXE, set by tests/CMakeLists.txt) through the shell; its
// stdout and stderr are captured in numbered files under capture_dir. ARGS is shell text:
// quote paths that may hold spaces.
inline CliRun run_indicial(const std::string& args, const std::filesystem::path& capture_dir) {
  static int counter = 0;
  const std::filesystem::path o = capture_dir / ("stdout-" + std::to_string(++counter));
  const std::filesystem::path e = capture_dir / ("stderr-" + std::to_string(counter));
  const std::string cmd = std::string("'") + INDICIAL_EXE + "' " + args + " > '" + o.string() +
                          "' 2> '" + e.string() + "'";
  const int rc = std::system(cmd.c_str());
  CliRun r;
  r.exit_code = (rc != -1 && WIFEXITED(rc)) ? WEXITSTATUS(rc) : -1;
  r.out = slurp(o);
  r.err = slurp(e);
  return r;
}

}  // namespace indicial::testing
