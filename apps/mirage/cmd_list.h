#pragma once
// The subcommands, one function each, registered by commands.cpp.
#include <string>

#include <CLI/CLI.hpp>

namespace mirage::cli {

void addInfoCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addDemoCommand(CLI::App& app);
void addCompareCommand(CLI::App& app);
void addGenCommand(CLI::App& app);

// mirage info FILE (scene summary); lives beside the importers' users.
void infoFile(const std::string& path, bool json);

} // namespace mirage::cli
