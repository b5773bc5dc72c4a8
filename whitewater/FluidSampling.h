/// @file FluidSampling.h
/// @brief The fluid around each diffuse particle (Ihmsen, Akinci, Akinci &
///        Teschner 2012): its number of fluid neighbours within h, which gives
///        its type (sec. 5), and the W-weighted mean fluid velocity
///        v_f = sum_j v_j W(x - x_j) / sum_j W(x - x_j) it is carried by (eq. 10),
///        with W(r) = 1 - r / h (the kernel of the potentials).
///
/// The sums run over the candidate cells of a UniformGridSearch built over the
/// fluid with radius h (forEachQueryGroup), eight places at a time, with no
/// neighbour lists: a neighbour is a place with squaredDistance() <= h^2, the
/// relation of every search. Each of the eight lanes keeps its own partial sums,
/// added in a fixed order at the end; the AVX2 and the portable version do the
/// same IEEE operations in the same order, so the result does not depend on the
/// processor, the thread count or the batch a particle is sampled in
/// (CASCADE_NO_AVX2=1 in the environment runs the portable version).
#pragma once

#include "libsph/Types.h"
#include "libsph/search/UniformGridSearch.h"

#include <cstdint>
#include <vector>

namespace cascade::whitewater {

/// What sampleFluid() finds around one position.
struct FluidSample {
  Vec3r velocity = Vec3r::Zero();  ///< v_f, when weight > 0
  float weight = 0;                ///< sum_j W(x - x_j)
  std::uint32_t neighbors = 0;     ///< fluid particles within h
};

/// Fluid velocities in a grid's place order (placeOrder()), as padded arrays.
struct PlaceVelocities {
  std::vector<Real> x, y, z;
  /// velocities[i] of point i of the grid's last build.
  void gather(const search::UniformGridSearch& grid, const std::vector<Vec3r>& velocities);
};

/// Samples the fluid of `grid` (built over the fluid positions with radius h)
/// at `count` positions. Without `velocities`, only the neighbour counts.
void sampleFluid(const search::UniformGridSearch& grid, const PlaceVelocities* velocities, const Vec3r* positions,
                 std::size_t count, Real h, std::vector<FluidSample>& samples);

} // namespace cascade::whitewater
