/// @file Commands.h
/// @brief The `cascade` subcommands (docs/cli.md). Each is registered by its
///        own file; errors propagate as the exceptions of libsph/Errors.h and
///        main() turns them into one stderr line and an exit status.
#pragma once

#include <CLI/CLI.hpp>

namespace cascade::cli {

/// `cascade --version`: ours and the libraries' versions (version.cpp).
std::string versionText();

void addBakeCommand(CLI::App& app);
void addSurfaceCommand(CLI::App& app);
void addWhitewaterCommand(CLI::App& app);
void addRenderCommand(CLI::App& app);
void addRunCommand(CLI::App& app);
void addBenchCommand(CLI::App& app);
void addInspectCommand(CLI::App& app);
void addSchemaCommand(CLI::App& app);
void addFarmCommand(CLI::App& app);

} // namespace cascade::cli
