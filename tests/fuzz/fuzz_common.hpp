// tests/fuzz/fuzz_common.hpp -- helpers shared by the libFuzzer targets (tools/run-fuzz.sh).
//
// The run CSV reader and the experiment loader read files (fitter/io.hpp has no overload that
// parses from a string), so each target writes its input to a file in a private directory
// under /tmp, made once per process. A property violation is reported with fuzz_fail(), which
// prints what was violated and aborts: libFuzzer then saves the input as a crash-* file.
#pragma once

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

namespace indicial_fuzz {

[[noreturn]] inline void fuzz_fail(const char* what, const std::string& detail = "") {
  std::fprintf(stderr, "FUZZ PROPERTY VIOLATED: %s %s\n", what, detail.c_str());
  std::abort();
}

// A fresh directory /tmp/indicial-fuzz-<tag>-<pid>, created on first use, removed at exit.
inline const std::string& scratch_dir(const char* tag) {
  static std::string dir;
  if (dir.empty()) {
    dir = std::string("/tmp/indicial-fuzz-") + tag + "-" + std::to_string(::getpid());
    const std::string cmd = "rm -rf '" + dir + "' && mkdir -p '" + dir + "'";
    if (std::system(cmd.c_str()) != 0) fuzz_fail("cannot create", dir);
    std::atexit([] {
      const std::string rm = "rm -rf '" + dir + "'";
      if (std::system(rm.c_str()) != 0) std::fprintf(stderr, "cannot remove %s\n", dir.c_str());
    });
  }
  return dir;
}

inline void write_file(const std::string& path, const void* data, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) fuzz_fail("cannot open for writing", path);
  if (size > 0 && std::fwrite(data, 1, size, f) != size) fuzz_fail("short write", path);
  if (std::fclose(f) != 0) fuzz_fail("cannot close", path);
}

inline void write_file(const std::string& path, const std::string& text) {
  write_file(path, text.data(), text.size());
}

// "file:line: problem" or "file: problem", as indicial::InputError builds it.
inline bool names_file(const std::string& message, const std::string& file) {
  return message.size() > file.size() + 2 && message.compare(0, file.size(), file) == 0 &&
         message[file.size()] == ':';
}

}  // namespace indicial_fuzz
