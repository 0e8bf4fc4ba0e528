// tools/command.hpp -- how each subcommand of `indicial` plugs into main().
//
// Each tools/cmd_<name>.cpp defines one static RegisterCommand whose function adds its
// subcommand (options, --help text and callback) to the CLI11 app. Callbacks report bad
// input by throwing indicial::InputError; main() prints the one-line message and exits 1.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <vector>

namespace indicial::tools {

using CommandSetup = std::function<void(CLI::App& app)>;

inline std::vector<CommandSetup>& command_registry() {
  static std::vector<CommandSetup> registry;
  return registry;
}

struct RegisterCommand {
  explicit RegisterCommand(CommandSetup setup) { command_registry().push_back(std::move(setup)); }
};

}  // namespace indicial::tools
