/// @file BenchSplash.h
/// @brief The splash the surface and whitewater benchmarks share: about 0.9 M
///        particles at spacing kSplashSpacing (a pool with a ring wave, a
///        collapsing column, a crown sheet and 150 k airborne droplets), each with
///        the velocity of its part's motion. Deterministic.
#pragma once

#include "libsph/Types.h"

#include <vector>

namespace cascade::cli {

constexpr double kSplashSpacing = 0.006;

struct Splash {
  std::vector<Vec3r> points, velocities;
};

/// The splash with its particles `spacing` apart (the droplets stay 150 k):
/// about 0.9 M particles at kSplashSpacing, 1.0 M at 5.75 mm.
Splash splashParticles(double spacing = kSplashSpacing);

} // namespace cascade::cli
