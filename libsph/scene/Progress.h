/// @file Progress.h
/// @brief Progress of long work on stderr (docs/cli.md): on a terminal one
///        line redrawn in place (frame, simulated time, steps/s, particles,
///        ETA); otherwise a plain line at most every `interval` seconds.
#pragma once

#include <chrono>
#include <cstdint>
#include <ostream>
#include <string>

namespace cascade::scene {

class Progress {
public:
  /// `stream` null: silent. `terminal` -1: detect (isatty on stderr).
  Progress(std::ostream* stream, int terminal = -1, double interval = 5.0);

  /// Reports the state; draws if enough wall time passed (or `force`).
  void update(int frame, int frameCount, double simTime, double endTime, std::uint64_t steps,
              std::size_t particles, bool force = false);
  /// Ends the in-place line (terminal) and prints `message` on its own line.
  void finish(const std::string& message);
  /// Prints a message on its own line (clearing the in-place line first).
  void message(const std::string& text);

  static std::string formatDuration(double seconds);

private:
  std::ostream* mStream;
  bool mTerminal;
  double mInterval;
  bool mLineOpen = false;
  std::chrono::steady_clock::time_point mStart, mLastDraw;
  double mStartSimTime = -1;
  std::uint64_t mStartSteps = 0;
  bool mDrawn = false;
};

} // namespace cascade::scene
