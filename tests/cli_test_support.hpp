// cli_test_support.hpp -- running the built `indicial` from a test and reading what it wrote.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <stdexcept>
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

// The number of '\n' in s (a one-line message has 1).
inline std::size_t count_lines(const std::string& s) {
  std::size_t n = 0;
  for (char c : s) n += (c == '\n');
  return n;
}

// A fresh directory /tmp/indicial-test-NAME-XXXXXX for this process, made on first use and
// removed at exit (kept when the environment variable INDICIAL_KEEP_TEST_FILES is set, for
// debugging). One per test executable: call it with the same NAME throughout.
inline const std::filesystem::path& scratch_directory(const std::string& name) {
  static std::filesystem::path holder;
  static const std::filesystem::path dir = [&name] {
    std::string tmpl = "/tmp/indicial-test-" + name + "-XXXXXX";
    const char* d = ::mkdtemp(tmpl.data());
    if (d == nullptr) throw std::runtime_error("mkdtemp failed for " + tmpl);
    holder = std::filesystem::path(d);
    if (std::getenv("INDICIAL_KEEP_TEST_FILES") == nullptr) {
      std::atexit([] {
        std::error_code ec;
        std::filesystem::remove_all(holder, ec);
      });
    }
    return holder;
  }();
  return dir;
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
