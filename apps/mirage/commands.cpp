#include "commands.h"

#include <cstdio>

#include "cmd_list.h"

namespace mirage::cli {

namespace {
int g_exit_code = 0;
}

int exitCode() { return g_exit_code; }
void setExitCode(int code) { g_exit_code = code; }

void fail(const std::string& message) {
  std::fprintf(stderr, "mirage: error: %s\n", message.c_str());
  g_exit_code = 2;
}
void fail(const Error& error) { fail(error.message); }

void addOutputFlags(CLI::App* cmd, OutputFlags& flags) {
  cmd->add_flag("--quiet", flags.quiet, "Print nothing but errors");
  cmd->add_flag("--progress", flags.progressLines, "Progress as plain lines on stderr (for logs)");
}

void registerCommands(CLI::App& app) {
  addInfoCommand(app);
  addGenCommand(app);
  addCompareCommand(app);
  addDemoCommand(app);
  addRenderCommand(app);
  addBuildCommand(app);
  addBenchCommand(app);
  addSurfelsCommand(app);
  addPvsCommands(app);
}

} // namespace mirage::cli
