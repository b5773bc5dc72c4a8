/// @file VdbFile.h
/// @brief Checks that a file is a complete OpenVDB file before OpenVDB reads it.
///
/// Debian's OpenVDB 10 asserts (aborts) on some truncated files instead of
/// throwing, so every Cascade reader calls this first: it reads the header and
/// walks the grid descriptors, and checks each grid's end offset lies inside
/// the file. Throws InputError naming the file for a missing, foreign or
/// truncated file. Include only in .cpp files that already use OpenVDB.
#pragma once

#include <filesystem>

namespace cascade {

/// openvdb::initialize(), once per process, from any thread.
void initializeOpenVdb();

/// Throws InputError("<path>: ...") unless `path` is a whole OpenVDB file.
void validateVdbFile(const std::filesystem::path& path);

} // namespace cascade
