// test_support.hpp -- the small helpers every test may need, defined once: pi and a scratch
// directory that removes itself.
//
//   indicial::testing::TempDir dir("golden");          // /tmp/indicial-golden-XXXXXX
//   std::ofstream(dir.path / "x.csv") << ...;
//   write_text(dir.path / "runs" / "r1.csv", "t,alpha_deg\n...");  // makes runs/, returns the path
//   CHECK_HAS(message, "line 3");                        // shows the message when it fails
//
// Warnings
// 1. TempDir removes its whole tree in the destructor: never point `path` elsewhere.
// 2. The directory is made by mkdtemp, so parallel ctest processes never share one.
#pragma once

#include <stdlib.h>

#include <cstddef>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <system_error>

namespace indicial::testing {

inline constexpr double kPi = 3.14159265358979323846;

struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& tag = "test") {
    std::string tmpl =
        (std::filesystem::temp_directory_path() / ("indicial-" + tag + "-XXXXXX")).string();
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed: " + tmpl);
    path = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

// Writes text to path (binary, so the bytes are exactly the test's), making its directories;
// returns the path as a string, as the readers take it.
inline std::string write_text(const std::filesystem::path& path, const std::string& text) {
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
  return path.string();
}

// The number of entries of a directory (a failed write must leave none of its own).
inline std::size_t directory_entries(const std::filesystem::path& dir) {
  std::size_t n = 0;
  for (auto it = std::filesystem::directory_iterator(dir); it != std::filesystem::directory_iterator(); ++it) ++n;
  return n;
}

}  // namespace indicial::testing

// Checks that message m contains s, showing m when it does not. m is evaluated ONCE: INFO is
// lazy, and an m that fails the test itself (error_of's FAIL when nothing was thrown) was
// evaluated again while doctest reported that failure, and the test hung (test_io, 2026-11-27).
#ifndef CHECK_HAS
#define CHECK_HAS(m, s)                                          \
  do {                                                           \
    const std::string check_has_message_ = (m);                  \
    INFO("message: " << check_has_message_);                     \
    CHECK(check_has_message_.find(s) != std::string::npos);      \
  } while (0)
#endif
