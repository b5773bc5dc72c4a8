/// @file Errors.h
/// @brief The error kinds that map to `cascade` exit statuses (docs/cli.md):
///        2 bad input, 3 unstable simulation, 1 anything else.
#pragma once

#include <stdexcept>
#include <string>

namespace cascade {

enum ExitStatus : int {
  kExitSuccess = 0,
  kExitFailure = 1,
  kExitBadInput = 2,
  kExitUnstable = 3,
};

/// Bad input: a scene, argument or file that is wrong. The message is the
/// whole one-line error, starting with the file (and JSON path) it concerns:
/// "scene.json: fluid.spacing: must be > 0 (got -1)".
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The simulation became unstable. The message names particle, position and time.
struct InstabilityError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// A subcommand or feature whose issue has not landed yet.
struct NotImplementedError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

} // namespace cascade
