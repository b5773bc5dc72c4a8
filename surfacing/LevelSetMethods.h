/// @file LevelSetMethods.h
/// @brief Particles to a narrow-band OpenVDB level set (negative inside, world
///        aligned voxels, class GRID_LEVEL_SET), by three methods:
///
/// - unionOfSpheresLevelSet: the union of spheres of the particle radius,
///   OpenVDB tools::ParticlesToLevelSet (Museth et al., OpenVDB; as vdb_tool
///   -points2ls). Bumpy: every particle shows.
/// - smoothSpheresLevelSet: Zhu & Bridson 2005, "Animating Sand as a Fluid"
///   (SIGGRAPH), section 3: phi(x) = |x - xbar(x)| - rbar(x) with xbar the
///   average of the particles within R weighted by k(s) = max(0, 1 - s^2)^3,
///   s = |x - x_i| / R, and rbar the radius (all particles have one). Written
///   here (not OpenVDB 10's rasterizeSmoothSpheres, whose surface bugs were
///   fixed only in OpenVDB 12.1). phi is a distance only near the surface; it is
///   turned into a narrow band by detail/ImplicitToLevelSet.h.
/// - anisotropicLevelSet: Yu & Turk 2013 anisotropic kernels
///   (surfacing/AnisotropicKernels.h): the iso-surface of the density field of
///   smoothed, stretched kernels; flat where the fluid is calm, thin sheets thin.
///
/// Each takes positions and the particle spacing and returns the level set grid
/// (named "surface"); given particle velocities, also the velocity grid "v" over
/// the level set's narrow band (detail/BandVelocity.h), gathered with the
/// method's own kernel weights (anisotropic: Yu & Turk's kernels, in the same
/// pass as the density; smooth and union of spheres: Zhu & Bridson's k(s) with
/// R = 2 spacings). Internal to surfacing (includes OpenVDB).
#pragma once

#include "libsph/Types.h"
#include "surfacing/SurfaceStage.h"

#include <openvdb/openvdb.h>

#include <vector>

namespace cascade::surfacing {

struct LevelSetSettings {
  double voxelSize = 0;      ///< m
  double spacing = 0;        ///< particle spacing, m
  double radius = 0;         ///< particle radius, m (0: the method's default)
  int halfWidth = 3;         ///< narrow band half width, voxels
  bool skipInterior = true;  ///< leave the inside of large bodies to signedFloodFill
  /// Particle velocities (m/s, in the order of the positions), or null: no "v" grid.
  const std::vector<Vec3r>* velocities = nullptr;
};

/// A level set and, if velocities were given, the velocity where the kernels reach.
struct ParticleLevelSet {
  openvdb::FloatGrid::Ptr surface;
  /// Kernel-weighted velocities (m/s) at the voxels the kernels reach (active
  /// there); null without velocities. velocityOverBand() makes "v" from it once
  /// the level set is final (filtering moves the band).
  openvdb::Vec3STree::Ptr velocity;
};

/// The velocity grid "v" over the active voxels of the final `levelSet`
/// (detail/BandVelocity.h), from a method's kernel-weighted velocities (consumed:
/// their leaves become the grid's).
openvdb::Vec3SGrid::Ptr velocityOverBand(const openvdb::FloatGrid& levelSet, openvdb::Vec3STree::Ptr velocity,
                                         int halfWidth);

/// Dispatches to the method below.
ParticleLevelSet particlesToLevelSet(SurfaceMethod method, const std::vector<Vec3r>& positions,
                                     const LevelSetSettings& settings);

/// Union of spheres; default radius 1.0 spacing (2 voxels at the default voxel size).
ParticleLevelSet unionOfSpheresLevelSet(const std::vector<Vec3r>& positions,
                                        const LevelSetSettings& settings);

/// Zhu & Bridson smooth spheres; R = 2 spacings, default radius kSmoothSpheresRadius spacings.
ParticleLevelSet smoothSpheresLevelSet(const std::vector<Vec3r>& positions,
                                       const LevelSetSettings& settings);

/// Yu & Turk anisotropic kernels, iso-value kAnisotropicIso of the normalised density.
/// `radius`, if set, scales the kernel support (default 2 spacings) by radius / (0.5 spacing).
ParticleLevelSet anisotropicLevelSet(const std::vector<Vec3r>& positions,
                                     const LevelSetSettings& settings);

/// Trilinear samples of a velocity grid at world points (mesh vertices), over each
/// cell's active corners (renormalised; zero where none is active).
std::vector<Eigen::Vector3f> sampleVelocity(const openvdb::Vec3SGrid& velocity,
                                            const std::vector<Eigen::Vector3f>& points);

/// Calibrated so that the top of a flat block of particles on a lattice lies half
/// a spacing above the top layer (the block keeps its volume); tests check it.
extern const double kSmoothSpheresRadius;
extern const double kAnisotropicIso;

} // namespace cascade::surfacing
