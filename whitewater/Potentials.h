/// @file Potentials.h
/// @brief Where a fluid makes whitewater: the three potentials of Ihmsen,
///        Akinci, Akinci & Teschner 2012 (sec. 4) per fluid particle, their
///        clamping, and the birth rate they give.
///
/// With x_ij = x_i - x_j, v_ij = v_i - v_j, hats for unit vectors and the
/// radially symmetric weight W(r, h) = 1 - r/h for r <= h (eq. 3):
///  - trapped air (eq. 2): I_ta = sum_j |v_ij| (1 - v^_ij . x^_ij) W(|x_ij|, h),
///    large where neighbours move towards each other (air is trapped);
///  - wave crest (eqs. 4-6): the surface curvature
///    kappa_i = sum_j (1 - n^_i . n^_j) W(|x_ij|, h) over the neighbours with
///    x^_ji . n^_i < 0 (behind the surface), counted only for particles moving
///    along their normal (v^_i . n^_i >= 0.6). n_i is the colour-field normal
///    sum_j x^_ij W(|x_ij|, h), made only at the surface, i.e. for particles with
///    at most 20 neighbours (a full neighbourhood at h = 2 spacings holds about
///    33). Only surface neighbours enter the sum: it measures how the surface's
///    normals spread. (SPlisHSPlasH's FoamGenerator gives interior neighbours
///    n = 0, so each adds its whole W: a flat surface then scores about 2.6,
///    more than a crest's tip, hence the paper's limits [2, 8]. Here a flat
///    surface scores 0 and the default fixed limits are [0.5, 2].)
///  - kinetic energy per mass: E_k = |v_i|^2 / 2 (J/kg; the paper's m |v|^2 / 2
///    divided by the particle mass, so the limits do not change with resolution).
/// A fluid particle with fewer than 15 neighbours (a droplet) makes no
/// whitewater: its potentials are zero. (The thresholds 15 and 20 are those of
/// SPlisHSPlasH's FoamGenerator.)
/// Each is clamped to [0, 1] by Phi(I, tau_min, tau_max) =
/// (min(I, tau_max) - min(I, tau_min)) / (tau_max - tau_min) (eq. 1), and a
/// fluid particle gives birth at the rate (eq. 7, per second)
///   n_i = rate_scale I_k (k_ta I_ta + k_wc I_wc).
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/Types.h"

#include <array>
#include <vector>

namespace cascade::whitewater {

struct FluidPotentials {
  std::vector<float> trappedAir;     ///< I_ta before clamping, m/s
  std::vector<float> waveCrest;      ///< I_wc before clamping (0 off the surface)
  std::vector<float> kineticEnergy;  ///< |v|^2 / 2, J/kg
  std::vector<Vec3r> normal;         ///< unit colour-field normal at the surface, zero inside
};

/// The potentials of every fluid particle; `neighbors` are its neighbours
/// within h (self excluded), e.g. from UniformGridSearch::findNeighbors.
/// Fills `out`, reusing its memory. A particle whose kinetic energy is at or
/// below `energyFloor` (J/kg) gives birth to nothing (eq. 1 clamps its I_k to 0):
/// its trapped air and crest are left 0 and its neighbours are summed only for
/// a surface normal. The default (-1) computes every particle's potentials, as
/// the bake's statistics need.
void computePotentials(const std::vector<Vec3r>& positions, const std::vector<Vec3r>& velocities,
                       const NeighborLists& neighbors, Real h, FluidPotentials& out, float energyFloor = -1);
inline FluidPotentials computePotentials(const std::vector<Vec3r>& positions, const std::vector<Vec3r>& velocities,
                                         const NeighborLists& neighbors, Real h) {
  FluidPotentials out;
  computePotentials(positions, velocities, neighbors, h, out);
  return out;
}

/// Phi of eq. 1: 0 below tau_min, 1 above tau_max, linear between.
inline float clampPotential(float value, double tauMin, double tauMax) {
  const double low = value < tauMin ? value : tauMin;
  const double high = value < tauMax ? value : tauMax;
  return float((high - low) / (tauMax - tauMin));
}

/// The clamping ranges of the three potentials.
struct PotentialLimits {
  std::array<double, 2> trappedAir{5, 20}, waveCrest{0.5, 2}, kineticEnergy{5, 50};
};

/// Birth rates (particles per second) of every fluid particle, eq. 7.
std::vector<float> birthRates(const FluidPotentials& potentials, const PotentialLimits& limits,
                              double trappedAirRate, double waveCrestRate, double rateScale);

/// Limits from a bake's own statistics, as SPlisHSPlasH's FoamGenerator makes
/// them: M, the mean over the sampled frames of each potential's largest value,
/// gives [0.1 M, M]. Unlike FoamGenerator, each lower limit is at least a floor
/// below which water makes no whitewater whatever the shot (`floors`, from
/// physicalFloors()), and each upper limit at least twice the lower.
PotentialLimits limitsFromStatistics(const std::vector<FluidPotentials>& samples, const PotentialLimits& floors);

/// The floors of the automatic limits, for support radius h and gravity |g|:
/// kinetic energy g h / 2 (a particle that could not rise h against gravity
/// makes no spray), trapped air sqrt(g h) (neighbours closing at that speed),
/// wave crest 0.5 (a flat surface scores 0; the tip of a 60-degree wedge of
/// lattice particles 0.33).
/// Still water stays below all three. Only the lower limits ([k] [0]) are used.
PotentialLimits physicalFloors(double h, double gravity);

} // namespace cascade::whitewater
