// The `indicial` command line: one executable, one subcommand per tools/cmd_*.cpp file.
//
// Conventions (README "The command line", tests/test_cli_conventions.cpp):
//   * `indicial --version` prints "indicial X.Y.Z (commit ...)" and exits 0; --help exits 0.
//   * Every usage error -- unknown subcommand (with the nearest one suggested), missing
//     required option, unexpected argument, bad option value -- and every bad input is ONE
//     line "indicial: error: ..." on stderr and exit status 1. CLI11's own exit codes
//     (105-114) are never returned.
//   * A subcommand's callback may end with CLI::RuntimeError(code) to exit with its own
//     documented status (fit: 4, 5; example: 2) after writing its outputs.
#include <algorithm>
#include <cstdio>
#include <exception>
#include <string>

#include "command.hpp"
#include "indicial/fitter/did_you_mean.hpp"
#include "indicial/fitter/error.hpp"
#include "indicial/fitter/provenance.hpp"

namespace {

constexpr int kUsageError = 1;

// "unknown subcommand 'fitt' (did you mean 'fit'?)" when argv's first word names none.
std::string unknown_subcommand(const CLI::App& app, const std::string& word) {
  std::string best;
  std::size_t best_distance = std::string::npos;
  std::string all;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) {
    const std::string& name = sub->get_name();
    all += (all.empty() ? "" : ", ") + name;
    const std::size_t d = indicial::edit_distance(word, name, indicial::LetterCase::significant);
    if (d < best_distance) best_distance = d, best = name;
  }
  std::string message = "unknown subcommand '" + word + "'";
  // Why the bound: a suggestion three edits away from a short word is noise, not a typo.
  if (best_distance <= std::max<std::size_t>(2, word.size() / 3)) message += " (did you mean '" + best + "'?)";
  else message += " (subcommands: " + all + ")";
  return message;
}

bool names_subcommand(const CLI::App& app, const std::string& word) {
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    if (sub->check_name(word)) return true;
  return false;
}

// The whole invocation, shell-quoted where needed (for provenance).
std::string joined_command_line(int argc, char** argv) {
  std::string line = "indicial";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const bool plain = !a.empty() && a.find_first_not_of(
        "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_./=:,+@%") == std::string::npos;
    std::string q = "'";
    for (char c : a) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    line += " " + (plain ? a : q + "'");
  }
  return line;
}

// CLI11's message on one line, naming the subcommand it concerns.
std::string one_line_usage_error(const CLI::App& app, const CLI::ParseError& e) {
  std::string what = e.what();
  for (char& c : what)
    if (c == '\n' || c == '\r') c = ' ';
  while (!what.empty() && what.back() == ' ') what.pop_back();
  std::string subcommands;
  for (const CLI::App* sub : app.get_subcommands()) subcommands += (subcommands.empty() ? "" : " ") + sub->get_name();
  const std::string help = "indicial " + (subcommands.empty() ? "" : subcommands + " ") + "--help";
  return (subcommands.empty() ? "" : subcommands + ": ") + what + " (see `" + help + "`)";
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"indicial: identify nonlinear unsteady aerodynamic models from wind-tunnel data "
               "and run them in real time"};
  app.require_subcommand(1);
  app.set_version_flag("--version", indicial::version_line(indicial::tools::build_commit()),
                       "print the version and the commit, then exit");
  app.footer(indicial::tools::formats_pointer);
  for (auto& setup : indicial::tools::command_registry()) setup(app);
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) sub->footer(indicial::tools::formats_pointer);
  indicial::tools::invocation() = joined_command_line(argc, argv);
  if (argc > 1 && argv[1][0] != '-' && !names_subcommand(app, argv[1])) {
    std::fprintf(stderr, "indicial: error: %s\n", unknown_subcommand(app, argv[1]).c_str());
    return kUsageError;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);  // --help, --version: printed on stdout, exit 0
  } catch (const CLI::RuntimeError& e) {
    // A subcommand's own documented exit status after its outputs and warning lines were
    // written (the subcommand printed them; CLI11's "Runtime error" text is not shown).
    return e.get_exit_code();
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "indicial: error: %s\n", one_line_usage_error(app, e).c_str());
    return kUsageError;
  } catch (const indicial::InputError& e) {
    std::fprintf(stderr, "indicial: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "indicial: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
