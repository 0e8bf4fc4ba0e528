// test_support.hpp -- the small helpers every test may need, defined once: pi and a scratch
// directory that removes itself.
//
//   indicial::testing::TempDir dir("golden");          // /tmp/indicial-golden-XXXXXX
//   std::ofstream(dir.path / "x.csv") << ...;
//
// Warnings
// 1. TempDir removes its whole tree in the destructor: never point `path` elsewhere.
// 2. The directory is made by mkdtemp, so parallel ctest processes never share one.
#pragma once

#include <stdlib.h>

#include <filesystem>
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

}  // namespace indicial::testing
