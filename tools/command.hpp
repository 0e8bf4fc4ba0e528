// tools/command.hpp -- how each subcommand of `indicial` plugs into main(), and what they share.
//
// Each tools/cmd_<name>.cpp defines one static RegisterCommand whose function adds its
// subcommand (options, --help text and callback) to the CLI11 app. Callbacks report bad
// input by throwing indicial::InputError; main() prints the one-line message and exits 1.
// Usage errors (an unknown subcommand, a missing required option, an unexpected argument, a
// bad option value) are one line "indicial: error: ..." and exit 1 too; --help and --version
// exit 0.
//
// Shared by the subcommands:
//   invocation()         the whole command line as typed (shell-quoted), for provenance
//   build_commit()       the commit the executable was built from
//   provenance_of(e)     version, commit, command line and input digests for outputs of e
//   print_notes(v)       each entry on stderr as "indicial: note: ..." (none under --quiet)
//   print_warnings(v)    each entry on stderr as "indicial: warning: ..."
//   StageClock           progress lines on stderr for stages longer than ~2 s
//   formats_pointer      the sentence every --help text ends with
//
// Warnings
// 1. Keep helpers of the cmd_*.cpp files in anonymous namespaces with distinct names: the
//    tool is a unity build (tools/CMakeLists.txt).
// 2. StageClock prints from a watchdog thread while a stage runs; it writes nothing to stdout,
//    so scripted readers of stdout are undisturbed, and nothing at all under --quiet.
#pragma once

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "indicial/fitter/error.hpp"
#include "indicial/fitter/fit.hpp"
#include "indicial/fitter/experiment.hpp"
#include "indicial/fitter/provenance.hpp"

namespace indicial::tools {

using CommandSetup = std::function<void(CLI::App& app)>;

inline std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> registry;
  return registry;
}

struct RegisterCommand {
  explicit RegisterCommand(CommandSetup setup) { command_registry().push_back(std::move(setup)); }
};

// The command line of this process (set once by main()).
inline std::string& invocation() {
  static std::string line;
  return line;
}

// The git commit this executable was built from (tools/build_commit.cpp), or "unknown".
const char* build_commit();

// The provenance of outputs made from experiment e by this invocation.
inline Provenance provenance_of(const Experiment& e) {
  return experiment_provenance(e, invocation(), build_commit());
}

// Appended to every subcommand's description.
inline constexpr const char* formats_pointer =
    "\nFile formats (experiment keys with units and defaults, run CSV columns, outputs):\n"
    "docs/formats.md in the source tree; `indicial init FILE.toml` writes a commented template.\n";

// Whether progress lines and notes are printed (warnings and errors always are).
enum class Verbosity { progress, quiet };

// Prints each note (what a reader did: an ignored column, ...) as one line on stderr; nothing
// under Verbosity::quiet (report.md and fit.json / diagnosis.json still list them).
inline void print_notes(const std::vector<std::string>& notes, Verbosity verbosity = Verbosity::progress) {
  if (verbosity == Verbosity::quiet) return;
  for (const std::string& n : notes) std::fprintf(stderr, "indicial: note: %s\n", n.c_str());
  std::fflush(stderr);
}

// Prints each warning as one line on stderr.
inline void print_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::fprintf(stderr, "indicial: warning: %s\n", w.c_str());
  std::fflush(stderr);
}

// Progress of a long command on stderr, one line per stage once the command has run longer
// than `threshold` (2 s):
//   fit: fitting ...                                 when a stage passes the threshold
//   fit: fitting done (7.3 s)                        when a stage ends after the threshold
// A command that finishes within the threshold prints nothing. Usage:
//   StageClock clock("fit", verbosity);
//   clock.stage("loading the experiment", [&] { e = load_experiment(path); });
class StageClock {
 public:
  StageClock(std::string command, Verbosity v, std::chrono::milliseconds threshold = std::chrono::milliseconds(2000))
      : command_(std::move(command)), verbosity_(v), threshold_(threshold),
        command_start_(std::chrono::steady_clock::now()) {}

  Verbosity verbosity() const { return verbosity_; }

  // Runs fn as the stage `name`; exceptions pass through (the watchdog is stopped first).
  template <class Fn>
  void stage(const std::string& name, Fn&& fn) const {
    if (verbosity_ == Verbosity::quiet) {
      fn();
      return;
    }
    const auto start = std::chrono::steady_clock::now();
    bool announced = false;
    std::mutex m;
    std::condition_variable cv;
    bool finished = false;
    std::thread watchdog([&] {
      std::unique_lock<std::mutex> lock(m);
      const auto wait = std::max(std::chrono::steady_clock::duration::zero(),
                                 threshold_ - (start - command_start_));
      if (cv.wait_for(lock, wait, [&] { return finished; })) return;
      announced = true;
      std::fprintf(stderr, "%s: %s ...\n", command_.c_str(), name.c_str());
      std::fflush(stderr);
    });
    auto stop = [&] {
      {
        std::lock_guard<std::mutex> lock(m);
        finished = true;
      }
      cv.notify_all();
      watchdog.join();
    };
    try {
      fn();
    } catch (...) {
      stop();
      throw;
    }
    stop();
    if (announced || std::chrono::steady_clock::now() - command_start_ > threshold_) {
      std::fprintf(stderr, "%s: %s done (%.1f s)\n", command_.c_str(), name.c_str(), seconds_since(start));
      std::fflush(stderr);
    }
  }

 private:
  static double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  std::string command_;
  Verbosity verbosity_;
  std::chrono::milliseconds threshold_;
  std::chrono::steady_clock::time_point command_start_;
};

// The words of FitOptions::stall_start_search on the command line (fit's and diagnose's
// --stall-start-search): one map.
inline CLI::CheckedTransformer stall_start_search_words() {
  return CLI::CheckedTransformer(std::map<std::string, StallStartSearch>{{"grid", StallStartSearch::grid},
                                                                         {"configured", StallStartSearch::configured}});
}

// The words of FitOptions::stall_prior (fit's and diagnose's --stall-prior).
inline CLI::CheckedTransformer stall_prior_words() {
  return CLI::CheckedTransformer(
      std::map<std::string, StallPrior>{{"beddoes_leishman", StallPrior::beddoes_leishman}, {"none", StallPrior::none}});
}

}  // namespace indicial::tools
