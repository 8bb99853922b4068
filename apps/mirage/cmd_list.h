#pragma once
// Subcommands defined in their own cmd_*.cpp; registerCommands (commands.cpp) calls these.
#include <CLI/CLI.hpp>

namespace mirage::cli {

// mirage compare A B [--json]: PSNR / SSIM / MAE between two images.
void addCompareCommand(CLI::App& app);
// mirage gen city|terrain|blob -o OUT.glb [--seed N] [--size N]: write a procedural scene.
void addGenCommand(CLI::App& app);

} // namespace mirage::cli
