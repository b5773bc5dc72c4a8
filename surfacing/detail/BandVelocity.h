/// @file BandVelocity.h
/// @brief The fluid velocity over a level set's narrow band, for motion blur
///        (the "v" grid of surface.NNNN.vdb, Houdini's convention: world space,
///        m/s).
///
/// A level-set method gathers v(x) = sum_j W_j(x) v_j / sum_j W_j(x) with its own
/// kernel weights W_j into leaves (VelocityLeaves: a voxel is known where the
/// weights do not vanish). velocityOverBand() then gives every active voxel of the
/// band a value: the known one, else the mean of its known face neighbours, sweep
/// after sweep (each sweep reads the previous one's values, so the result does not
/// depend on the order of the voxels), which carries the velocity at the surface out
/// to the band's edge along the grid, as a velocity extension does along the normal
/// (Adalsteinsson & Sethian 1999, "The Fast Construction of Extension Velocities in
/// Level Set Methods", to first order on the grid). isotropicKernelVelocities()
/// gathers v with Zhu & Bridson's k(s) = max(0, 1 - s^2)^3 for the methods that
/// have no kernels of their own to reuse (union and smooth spheres).
/// Internal to surfacing (includes OpenVDB).
#pragma once

#include "libsph/Types.h"

#include <openvdb/openvdb.h>
#include <tbb/enumerable_thread_specific.h>

#include <cstdint>
#include <vector>

namespace cascade::surfacing::detail {

/// Velocity leaves made in parallel (one per rasterized leaf), gathered into a tree.
class VelocityLeaves {
public:
  using LeafT = openvdb::Vec3STree::LeafNodeType;
  VelocityLeaves() = default;
  VelocityLeaves(const VelocityLeaves&) = delete;
  VelocityLeaves& operator=(const VelocityLeaves&) = delete;
  ~VelocityLeaves();
  /// The leaf at `origin` from weighted sums over its 512 voxels (VDB order):
  /// v = (sumX, sumY, sumZ) / weight, active where weight > minWeight. Thread safe;
  /// a leaf with no such voxel is not kept.
  void add(const openvdb::Coord& origin, const float* weight, const float* sumX, const float* sumY,
           const float* sumZ, float minWeight);
  /// The leaves as a tree (they move into it).
  openvdb::Vec3STree::Ptr release();

private:
  tbb::enumerable_thread_specific<std::vector<LeafT*>> mLeaves;
};

/// The velocity grid "v" over the active voxels of `levelSet`, from the known
/// voxels of `known` (consumed: its leaves become the grid's): at most `sweeps`
/// extension sweeps; voxels still unknown after them (far from any particle's
/// support) get the mean of the known values.
openvdb::Vec3SGrid::Ptr velocityOverBand(const openvdb::FloatGrid& levelSet, openvdb::Vec3STree::Ptr known,
                                         int sweeps);

/// Known velocities from the kernel k(|x - c_j| / R) around `center` (velocity
/// `velocity[j]`, same order), R = `supportRadius`, voxel size `voxelSize`
/// (the world-aligned lattice). Kernels flagged in `interior` (may be empty)
/// contribute but make no leaf of their own.
openvdb::Vec3STree::Ptr isotropicKernelVelocities(const std::vector<Vec3r>& center, const std::vector<Vec3r>& velocity,
                                                  double supportRadius, double voxelSize,
                                                  const std::vector<std::uint8_t>& interior);

/// Sweeps that reach across a band of `halfWidth` voxels each side from either edge.
inline int velocitySweeps(int halfWidth) { return 2 * halfWidth + 2; }

/// `values` in the order of ParticleGrid sorted slots (`sortedIndex`).
std::vector<Vec3r> inSortedOrder(const std::vector<Vec3r>& values, const std::vector<std::uint32_t>& sortedIndex);

} // namespace cascade::surfacing::detail
