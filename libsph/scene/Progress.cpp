#include "libsph/scene/Progress.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>

namespace cascade::scene {

Progress::Progress(std::ostream* stream, int terminal, double interval)
    : mStream(stream),
      mTerminal(terminal < 0 ? ::isatty(STDERR_FILENO) != 0 : terminal != 0),
      mInterval(mTerminal ? 0.2 : interval),
      mStart(std::chrono::steady_clock::now()),
      mLastDraw(mStart) {}

std::string Progress::formatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long total = long(seconds + 0.5);
  char buffer[32];
  if (total >= 3600)
    std::snprintf(buffer, sizeof buffer, "%ld:%02ld:%02ld", total / 3600, (total / 60) % 60, total % 60);
  else
    std::snprintf(buffer, sizeof buffer, "%ld:%02ld", total / 60, total % 60);
  return buffer;
}

void Progress::update(int frame, int frameCount, double simTime, double endTime, std::uint64_t steps,
                      std::size_t particles, bool force) {
  if (!mStream) return;
  const auto now = std::chrono::steady_clock::now();
  if (mStartSimTime < 0) mStartSimTime = simTime, mStartSteps = steps;
  const double sinceDraw = std::chrono::duration<double>(now - mLastDraw).count();
  if (!force && mDrawn && sinceDraw < mInterval) return;
  if (!force && !mDrawn && sinceDraw < mInterval && !mTerminal) return;
  mLastDraw = now;
  mDrawn = true;
  const double elapsed = std::chrono::duration<double>(now - mStart).count();
  const double stepsPerSecond = elapsed > 0 ? double(steps - mStartSteps) / elapsed : 0;
  const double simulated = simTime - mStartSimTime;
  const double eta = simulated > 0 ? (endTime - simTime) * elapsed / simulated : NAN;
  char line[256];
  std::snprintf(line, sizeof line, "frame %d/%d  t=%.3f/%.3f s  %.*f steps/s  %zu particles  ETA %s",
                frame, frameCount, simTime, endTime, stepsPerSecond < 10 ? 2 : 0, stepsPerSecond, particles,
                formatDuration(eta).c_str());
  if (mTerminal) {
    *mStream << "\r" << line << "\x1b[K" << std::flush;
    mLineOpen = true;
  } else {
    *mStream << line << '\n' << std::flush;
  }
}

void Progress::message(const std::string& text) {
  if (!mStream) return;
  if (mLineOpen) *mStream << "\r\x1b[K";
  mLineOpen = false;
  *mStream << text << '\n' << std::flush;
}

void Progress::finish(const std::string& text) { message(text); }

} // namespace cascade::scene
