/// @file LevelSetFiltering.h
/// @brief Smoothing passes on a narrow-band level set with OpenVDB's
///        tools::LevelSetFilter (mean-curvature flow, Gaussian or Laplacian
///        passes, each followed by renormalisation of the band, Osher & Fedkiw
///        2003 ch. 7): first-order upwind gradients, one Euler step and one renormalisation
///        iteration per pass.
///        Internal to surfacing (includes OpenVDB).
#pragma once

#include "surfacing/SurfaceStage.h"

#include <openvdb/openvdb.h>

namespace cascade::surfacing {

/// Applies `passes` passes of `filter` to the level set in place. Zero passes,
/// or SurfaceFilter::None, still renormalise the band once (so that the grid is
/// a signed distance field with a full band).
void filterLevelSet(openvdb::FloatGrid& grid, SurfaceFilter filter, int passes);

} // namespace cascade::surfacing
