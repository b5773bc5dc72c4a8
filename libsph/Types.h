/// @file Types.h
/// @brief The scalar and vector types every Cascade stage shares.
///
/// `Real` is float by default (the particle state of a million-particle bake
/// fits in cache-friendly arrays); define CASCADE_DOUBLE to build with double.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>

namespace cascade {

#ifdef CASCADE_DOUBLE
using Real = double;
#else
using Real = float;
#endif

using Vec3r = Eigen::Matrix<Real, 3, 1>;
using Vec3d = Eigen::Matrix<double, 3, 1>;
using ParticleId = std::uint32_t;

/// Gravitational acceleration magnitude (m/s^2); scenes are z up.
constexpr Real kStandardGravity = Real(9.81);

} // namespace cascade
