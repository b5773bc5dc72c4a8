/// @file AtomicFile.h
/// @brief Whole-or-nothing file output (docs/cli.md: "Every file appears whole
///        or not at all"): write to a temporary name in the same directory,
///        flush it to disk, then rename over the final name.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace cascade {

/// Calls write(tempPath) to produce the file under a temporary name beside
/// `path`, fsyncs it and renames it to `path`. If write throws, the temporary
/// is removed and `path` is left as it was. Creates missing parent directories.
void writeFileAtomically(const std::filesystem::path& path,
                         const std::function<void(const std::filesystem::path& tempPath)>& write);

/// Writes a string as a whole file, atomically.
void writeTextAtomically(const std::filesystem::path& path, const std::string& text);

/// Reads a whole file; throws InputError naming the file if it cannot.
std::string readTextFile(const std::filesystem::path& path);

} // namespace cascade
