/// @file Version.h
/// @brief The version of Cascade that wrote a file: the project version and the
///        git revision of the source tree when it was built (CMake writes it).
#pragma once

#include <string>

namespace cascade {

/// "0.1 (git 067c65b)", or "0.1" outside a git checkout.
std::string cascadeVersion();

/// One line naming the writer, for file headers: "written by cascade 0.1 (git 067c65b)".
std::string writtenBy();

} // namespace cascade
