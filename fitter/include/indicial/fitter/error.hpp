// indicial/fitter/error.hpp -- the one exception type the offline tools throw for bad input.
//
// Every input problem the fitter or the command line detects is reported as an InputError
// whose message names the file, the line (when there is one) and the problem, in the form
//
//   run_f0.25.csv:14: time_s is not strictly increasing (0.13 after 0.13)
//
// The command line prints it on one line and exits with status 1. The runtime never throws;
// it returns status enums instead (runtime/include/indicial/runtime.hpp).
#pragma once

#include <stdexcept>
#include <string>

namespace indicial {

class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
  // file:line: problem (line 0 means the problem is not on one line: file: problem)
  InputError(const std::string& file, long line, const std::string& problem)
      : std::runtime_error(line > 0 ? file + ":" + std::to_string(line) + ": " + problem
                                    : file + ": " + problem) {}
};

}  // namespace indicial
