#include "commands.h"

#include <cstdio>
#include <string_view>
#include <vector>

#include "cmd_list.h"

namespace mirage::cli {

namespace {
int g_exit_code = 0;
}

int exitCode() { return g_exit_code; }
void setExitCode(int code) { g_exit_code = code; }

void fail(const std::string& message) {
  Progress::breakLine(); // the error on its own line, not after a progress bar
  std::fprintf(stderr, "mirage: error: %s\n", message.c_str());
  g_exit_code = 2;
}
void fail(const Error& error) { fail(error.message); }

void addOutputFlags(CLI::App* cmd, OutputFlags& flags) {
  cmd->add_flag("--quiet", flags.quiet, "Print nothing but errors");
  cmd->add_flag("--progress", flags.progressLines, "Progress as plain lines on stderr (for logs)");
}

namespace {

// A command-line word as it may be echoed: printable ASCII kept, other bytes as \xNN, long words cut.
std::string printable(std::string_view word) {
  std::string out;
  for (unsigned char c : word.substr(0, 64)) {
    if (c >= 0x20 && c < 0x7f) {
      out += char(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02x", c);
      out += buf;
    }
  }
  if (word.size() > 64) out += "...";
  return out;
}

// "mirage bench" for the bench subcommand (the names from the root down).
std::string commandPath(const CLI::App* app) {
  std::string path = app->get_name();
  for (const CLI::App* p = app->get_parent(); p; p = p->get_parent()) path = p->get_name() + " " + path;
  return path;
}

} // namespace

std::string parseErrorMessage(const CLI::App& app, const CLI::ParseError& error) {
  // The deepest subcommand the command line selected: where a missing subcommand was expected.
  const CLI::App* at = &app;
  while (!at->get_subcommands().empty()) at = at->get_subcommands().front();
  std::string help = "see " + commandPath(at) + " --help";
  if (dynamic_cast<const CLI::RequiredError*>(&error) && at->get_require_subcommand_min() > 0 &&
      at->get_subcommands().empty()) {
    std::string names;
    for (const CLI::App* sub : at->get_subcommands({})) names += (names.empty() ? "" : ", ") + sub->get_name();
    // A word that named no subcommand is left over: it was the subcommand the user meant.
    std::vector<std::string> rest = at->remaining();
    for (const std::string& word : rest)
      if (!word.empty() && word[0] != '-')
        return "unknown subcommand '" + printable(word) + "' (expected one of: " + names + "; " + help + ")";
    return "a subcommand is required (one of: " + names + "; " + help + ")";
  }
  return std::string(error.what()) + " (" + help + ")";
}

void registerCommands(CLI::App& app) {
  addInfoCommand(app);
  addGenCommand(app);
  addCompareCommand(app);
  addDemoCommand(app);
  addRenderCommand(app);
  addParticlesCommand(app);
  addBuildCommand(app);
  addBenchCommand(app);
  addSurfelsCommand(app);
  addPvsCommands(app);
  addViewCommand(app);
  addStreamCommands(app);
}

} // namespace mirage::cli
