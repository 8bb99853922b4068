#pragma once
// Each subcommand lives in its own cmd_*.cpp and registers itself here.
#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "mirage/core/progress.h"
#include "mirage/core/result.h"

namespace mirage::cli {

void registerCommands(CLI::App& app);
// The one line printed for a command line CLI11 rejects, e.g. "unknown subcommand 'x' (expected
// one of: info, gen, ...; see mirage --help)"; every other error as CLI11 words it.
std::string parseErrorMessage(const CLI::App& app, const CLI::ParseError& error);
// Exit code set by the subcommand that ran (0 success, 2 bad input or failure).
int exitCode();
void setExitCode(int code);
// Print "mirage: error: <message>" on one line to stderr and set exit code 2.
void fail(const Error& error);
void fail(const std::string& message);

// --quiet (print nothing but errors) and --progress (plain progress lines on stderr, for logs) of a
// long-running subcommand; without either, progress shows as one self-updating line on a terminal.
struct OutputFlags {
  bool quiet = false;
  bool progressLines = false;
  ProgressMode progressMode() const { return mirage::progressMode(quiet, progressLines); }
};
void addOutputFlags(CLI::App* cmd, OutputFlags& flags);

// Wall seconds since t0 (the timings the subcommands print).
inline double secondsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
// The median of v (the upper middle one of an even count); 0 for none.
inline double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

} // namespace mirage::cli
