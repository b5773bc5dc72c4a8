/// @file AnisotropicKernels.h
/// @brief Per-particle anisotropic smoothing kernels after Yu & Turk 2013,
///        "Reconstructing Surfaces of Particle-Based Fluids Using Anisotropic
///        Kernels" (ACM TOG 32(1)).
///
/// For particle i with neighbours j within r_n (weights w_ij = 1 - (|x_i - x_j| / r_n)^3,
/// Yu & Turk eq. 11):
///  - the kernel centre is Laplacian-smoothed,
///    xbar_i = (1 - lambda) x_i + lambda sum_j w_ij x_j / sum_j w_ij   (eq. 6);
///  - the weighted covariance C_i (eq. 10) is decomposed C = R diag(s1 >= s2 >= s3) R^T;
///    with at least `minNeighbors` neighbours the kernel axes are the eigenvectors,
///    stretched in proportion to max(s_k, s1 / k_r)  (eq. 15, k_r = maxAnisotropy),
///    normalised to unit determinant so that every kernel carries the particle's
///    volume (instead of eq. 15's constant k_s), and capped at `maxStretch`;
///    with fewer neighbours the kernel is isotropic and k_n = isolatedScale times
///    smaller (eq. 15), so that a lone droplet stays a small ball.
/// Particles of cells deep inside the fluid (every cell within two cells holds at
/// least 60 % of a lattice's count) have complete, symmetric neighbourhoods: they
/// get the isotropic kernel centred on the particle without the neighbour sums
/// (what eq. 6 and 15 give there up to the lattice jitter); they lie at least a
/// cell from any sparser cell, so they only fill the inside of the band's leaves.
/// The density field is then phi(x) = sum_j V_j W(G_j (x - xbar_j)) with
/// W(q) = det(G) 315 / (64 pi) (1 - |q|^2)^3 for |q| < 1 (integral 1), so phi is
/// about 1 inside the fluid and 0 outside (AnisotropicLevelSet.cpp).
/// No OpenVDB here; positions in ParticleGrid sorted order.
#pragma once

#include "surfacing/ParticleGrid.h"

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace cascade::surfacing {

struct AnisotropicKernelSettings {
  double spacing = 0;             ///< particle spacing s, m
  double neighborRadius = 2.1;    ///< r_n, in spacings
  double supportRadius = 2.0;     ///< kernel support of an isotropic interior particle, in spacings
  double centerSmoothing = 0.5;   ///< lambda of eq. 6
  double maxAnisotropy = 4;       ///< k_r
  double maxStretch = 2;          ///< cap on any axis' stretch (keeps supports bounded)
  int minNeighbors = 6;           ///< N_eps: fewer neighbours -> isotropic, isolated
  double isolatedScale = 0.5;     ///< k_n
};

/// The kernels of all particles, indexed by ParticleGrid sorted slot.
struct AnisotropicKernels {
  std::vector<Vec3r> center;               ///< xbar, m
  std::vector<Eigen::Matrix3f> transform;  ///< G: the support is |G (x - xbar)| < 1
  std::vector<float> weight;               ///< V det(G) 315 / (64 pi)
  std::vector<Eigen::Vector3f> halfExtent; ///< axis-aligned half size of the support, m
  /// A particle with a full, balanced neighbourhood: its kernel lies deep in the fluid.
  std::vector<std::uint8_t> interior;
  float maxHalfExtent = 0;                 ///< largest halfExtent component, m
};

/// Computes the kernels with neighbour queries on `grid` (cell size >= neighbour radius).
AnisotropicKernels computeAnisotropicKernels(const ParticleGrid& grid,
                                             const AnisotropicKernelSettings& settings);

} // namespace cascade::surfacing
