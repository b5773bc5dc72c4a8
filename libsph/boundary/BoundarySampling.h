/// @file BoundarySampling.h
/// @brief Helpers to place type I boundary particles (SEED section 2.2) on
///        flat pieces: a rectangle sampled on a grid with no gap above maxGap,
///        and removal of coincident samples where pieces share an edge.
#pragma once

#include "libsph/Types.h"

#include <vector>

namespace cascade {

/// Points on the rectangle center + s u + t v, |s| <= halfU, |t| <= halfV, on a
/// grid whose spacing along each axis is at most maxGap (edges included).
void sampleRectangle(const Vec3r& center, const Vec3r& axisU, const Vec3r& axisV, Real halfU,
                     Real halfV, Real maxGap, std::vector<Vec3r>& samples);

/// Removes samples closer than `tolerance` to an earlier one (keeps first occurrences, in order).
void removeDuplicateSamples(std::vector<Vec3r>& samples, Real tolerance);

} // namespace cascade
