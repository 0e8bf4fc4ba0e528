// The checks an Options struct with IsValid(std::string*) (Ceres' Solver::Options shape:
// FitOptions, DiagnoseOptions) gets in its test: every bad option, one at a time, refused with
// its own one-line message, and a library entry point that throws that line before it looks at
// its input. Used by test_fit_options.cpp and test_diagnose_options.cpp.
#pragma once

#include <doctest/doctest.h>

#include <exception>
#include <functional>
#include <string>
#include <vector>

#include "indicial/fitter/error.hpp"

namespace indicial::testing {

template <class Options>
struct BadOption {
  const char* option;  // the start of the message: the field and its flag
  std::function<void(Options&)> set;
  const char* found;   // the value the message quotes
};

// The line IsValid gives for one bad option.
template <class Options>
std::string is_valid_line(const BadOption<Options>& b) {
  Options o;
  b.set(o);
  std::string error;
  o.IsValid(&error);
  return error;
}

// Each bad option refused by IsValid: one line that starts with its field and quotes the value;
// refused without a message asked for too.
template <class Options>
void check_each_refused(const std::vector<BadOption<Options>>& bad) {
  for (const BadOption<Options>& b : bad) {
    Options o;
    b.set(o);
    std::string error;
    INFO(b.option, " ", b.found);
    CHECK(!o.IsValid(&error));
    CHECK(error.rfind(b.option, 0) == 0);
    CHECK(error.find(b.found) != std::string::npos);
    CHECK(error.find('\n') == std::string::npos);
    CHECK(!o.IsValid(nullptr));
  }
}

// `entry` (a library entry point on an input it refuses for another reason when the options
// are valid, with that reason containing `valid_complaint`) throws each bad option's IsValid
// line instead, as an InputError: the options are checked first.
template <class Options, class Entry>
void check_entry_throws_first(const std::vector<BadOption<Options>>& bad, const Entry& entry,
                              const char* valid_complaint) {
  std::string complaint;
  try {
    entry(Options{});
  } catch (const std::exception& ex) {
    complaint = ex.what();
  }
  CHECK(complaint.find(valid_complaint) != std::string::npos);
  for (const BadOption<Options>& b : bad) {
    Options o;
    b.set(o);
    const std::string error = is_valid_line(b);
    INFO(b.option, " ", b.found);
    CHECK(error != complaint);
    CHECK_THROWS_WITH_AS(entry(o), error.c_str(), InputError);
  }
}

}  // namespace indicial::testing
