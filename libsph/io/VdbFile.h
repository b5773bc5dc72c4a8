/// @file VdbFile.h
/// @brief Checks that a file is a complete OpenVDB file before OpenVDB reads it.
///
/// Debian's OpenVDB 10 asserts (aborts) on some truncated files instead of
/// throwing, and allocates whatever length a corrupt file claims, so every Cascade
/// reader calls this first: it reads the header and walks the file's and each
/// grid's metadata and the grid descriptors, checking every length and offset
/// against the file's size. Throws InputError naming the file for a missing, foreign or
/// truncated file. Include only in .cpp files that already use OpenVDB.
#pragma once

#include <filesystem>

namespace cascade {

/// openvdb::initialize(), once per process, from any thread.
void initializeOpenVdb();

/// Throws InputError("<path>: ...") unless `path` is a whole OpenVDB file.
void validateVdbFile(const std::filesystem::path& path);

/// Debian's OpenVDB 10 is built with assertions, and some corrupt data deep in a
/// grid (a point attribute page of size 0) makes it abort instead of throw; on other
/// corrupt data its compressed-value reader overruns a buffer and the process faults.
/// While a VdbReadScope is alive on a thread, an abort or a fault (SIGABRT, SIGSEGV,
/// SIGBUS, SIGFPE) on that thread, once installVdbAbortGuard() has run, prints
/// "<path>: corrupt OpenVDB file (OpenVDB failed reading it)" and exits at once with
/// status 2 (bad input); any other still ends the process as it would.
class VdbReadScope {
public:
  explicit VdbReadScope(const std::filesystem::path& path);
  ~VdbReadScope();
  VdbReadScope(const VdbReadScope&) = delete;
  VdbReadScope& operator=(const VdbReadScope&) = delete;
};

/// Installs the SIGABRT handler that VdbReadScope relies on (the `cascade` program
/// calls it at start).
void installVdbAbortGuard();

} // namespace cascade
