// The `indicial` command line: one executable, one subcommand per tools/cmd_*.cpp file.
#include <cstdio>
#include <exception>

#include "command.hpp"
#include "indicial/fitter/error.hpp"

int main(int argc, char** argv) {
  CLI::App app{"indicial: identify nonlinear unsteady aerodynamic models from wind-tunnel data "
               "and run them in real time"};
  app.require_subcommand(1);
  for (auto& setup : indicial::tools::command_registry()) setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const indicial::InputError& e) {
    std::fprintf(stderr, "indicial: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "indicial: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
