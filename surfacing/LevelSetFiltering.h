/// @file LevelSetFiltering.h
/// @brief Smoothing passes on a narrow-band level set, each followed by one
///        renormalisation step of the band (Osher & Fedkiw 2003 ch. 7):
///
/// - mean curvature flow (the default filter), written here leaf by leaf:
///   phi += dt kappa |grad phi| with dt = dx^2 / 3 and the 19-point central
///   difference curvature of OpenVDB's CurvatureStencil (Osher & Fedkiw eq. 1.8),
///   then one explicit Euler step of the Eikonal renormalisation
///   phi_t = -S(phi) (|grad phi| - 1), S(phi) = phi / sqrt(phi^2 + dx^2 |grad phi|^2),
///   Godunov upwind first-order gradients, step 0.3 dx (Sussman, Smereka & Osher
///   1994; the scheme of OpenVDB's LevelSetTracker with FIRST_BIAS, TVD_RK1, one
///   iteration). Each step reads a padded copy of the leaf and its 26 neighbours
///   and writes a new buffer, so the result does not depend on thread timing. The
///   band is dilated by one voxel (face neighbours) inside the existing leaves
///   before the renormalisation and trimmed to |phi| < half width after it.
/// - Gaussian and Laplacian passes: OpenVDB tools::LevelSetFilter (same
///   renormalisation settings).
/// Internal to surfacing (includes OpenVDB).
#pragma once

#include "surfacing/SurfaceStage.h"

#include <openvdb/openvdb.h>

namespace cascade::surfacing {

/// Applies `passes` passes of `filter` to the level set in place. Zero passes,
/// or SurfaceFilter::None, still renormalise the band once (so that the grid is
/// a signed distance field with a full band).
void filterLevelSet(openvdb::FloatGrid& grid, SurfaceFilter filter, int passes);

/// The same passes with OpenVDB's LevelSetFilter for every filter (the previous
/// implementation of mean curvature; slower, kept for comparison).
void filterLevelSetOpenVdb(openvdb::FloatGrid& grid, SurfaceFilter filter, int passes);

} // namespace cascade::surfacing
