/// @file Profile.h
/// @brief Sub-stage wall and CPU times on stderr when the environment variable
///        CASCADE_SURFACE_PROFILE is set (for profiling `cascade bench surface`);
///        silent and nearly free otherwise. Internal to surfacing.
#pragma once

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <time.h>

namespace cascade::surfacing::detail {

class ProfileClock {
public:
  ProfileClock() : mEnabled(std::getenv("CASCADE_SURFACE_PROFILE") != nullptr) { reset(); }
  /// Prints the time since the last lap (or construction) under `label`.
  void lap(const char* label) {
    if (!mEnabled) return;
    const double wall = wallNow(), cpu = cpuNow();
    std::fprintf(stderr, "  profile %-28s %8.1f ms wall %8.1f ms cpu\n", label, 1e3 * (wall - mWall),
                 1e3 * (cpu - mCpu));
    mWall = wall;
    mCpu = cpu;
  }
  void reset() {
    if (!mEnabled) return;
    mWall = wallNow();
    mCpu = cpuNow();
  }

private:
  static double wallNow() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  static double cpuNow() {
    timespec now{};
    ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
    return double(now.tv_sec) + 1e-9 * double(now.tv_nsec);
  }
  bool mEnabled;
  double mWall = 0, mCpu = 0;
};

} // namespace cascade::surfacing::detail
