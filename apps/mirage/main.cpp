// mirage: one CLI for the whole pipeline (import -> bake -> .mrg -> render / stream).
// Errors go to stderr as one line and exit 2; results go to stdout.
#include <cstdio>

#include <CLI/CLI.hpp>

#include "commands.h"

int main(int argc, char** argv) {
  CLI::App app{"Mirage: huge 3D scenes, fast on weak clients", "mirage"};
  app.require_subcommand(1);
  app.set_help_all_flag("--help-all", "Help for every subcommand");
  mirage::cli::registerCommands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e); // --help
    std::fprintf(stderr, "mirage: error: %s\n", mirage::cli::parseErrorMessage(app, e).c_str());
    return 2;
  }
  return mirage::cli::exitCode();
}
