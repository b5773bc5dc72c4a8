// Ihmsen et al. 2012 sec. 4: trapped air, wave crest and kinetic energy potentials.
#include "whitewater/Potentials.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace cascade::whitewater {

namespace {

/// At most this many neighbours: at the surface (a normal is made).
constexpr std::uint32_t kSurfaceNeighbors = 20;
/// Fewer neighbours: a droplet, which makes no whitewater.
constexpr std::uint32_t kSourceNeighbors = 15;
/// v^ . n^ at or above this: moving along the normal (Ihmsen 2012 eq. 6).
constexpr float kCrestVelocityAlignment = 0.6f;

inline float weight(float r, float h) { return r < h ? 1.0f - r / h : 0.0f; }

} // namespace

void computePotentials(const std::vector<Vec3r>& positions, const std::vector<Vec3r>& velocities,
                       const NeighborLists& neighbors, Real h, FluidPotentials& out, float energyFloor) {
  const std::size_t n = positions.size();
  out.trappedAir.resize(n);
  out.waveCrest.resize(n);
  out.kineticEnergy.resize(n);
  out.normal.resize(n);
  const float support = float(h), inverseSupport = 1.0f / support;
  std::vector<Vec3r>& normal = out.normal;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const std::uint32_t count = neighbors.count(i);
      const Vec3r& xi = positions[i];
      const Vec3r& vi = velocities[i];
      const bool source = count >= kSourceNeighbors;
      out.kineticEnergy[i] = source ? 0.5f * float(vi.squaredNorm()) : 0.0f;
      out.waveCrest[i] = 0;
      const bool births = source && out.kineticEnergy[i] > energyFloor;
      if (!births) out.trappedAir[i] = 0;
      if (!births && count > kSurfaceNeighbors) {
        normal[i] = Vec3r::Zero();  // inside, and too slow to give birth
        continue;
      }
      Vec3r sum = Vec3r::Zero();
      float trapped = 0;
      for (const std::uint32_t* j = neighbors.begin(i); j != neighbors.end(i); ++j) {
        const Vec3r xij = xi - positions[*j];
        const float r = float(xij.norm());
        if (r <= 0) continue;
        const float w = std::max(1.0f - r * inverseSupport, 0.0f);
        const Vec3r xHat = xij * Real(1.0f / r);
        sum += Real(w) * xHat;
        if (!births) continue;
        const Vec3r vij = vi - velocities[*j];
        const float speed = float(vij.norm());
        // eq. 2: |v_ij| (1 - v^_ij . x^_ij) W_ij, as (|v_ij| - v_ij . x^_ij) W_ij.
        if (speed > 1e-6f) trapped += (speed - float(vij.dot(xHat))) * w;
      }
      normal[i] = count <= kSurfaceNeighbors && sum.squaredNorm() > 0 ? Vec3r(sum.normalized()) : Vec3r::Zero();
      if (births) out.trappedAir[i] = trapped;
    }
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3r& ni = normal[i];
      if (neighbors.count(i) < kSourceNeighbors || ni.squaredNorm() == 0 || !(out.kineticEnergy[i] > energyFloor))
        continue;
      const Vec3r& vi = velocities[i];
      const float speed = float(vi.norm());
      if (speed <= 0 || float(vi.dot(ni)) < kCrestVelocityAlignment * speed) continue;  // eq. 6
      float curvature = 0;
      for (const std::uint32_t* j = neighbors.begin(i); j != neighbors.end(i); ++j) {
        const Vec3r xji = positions[*j] - positions[i];
        const float r = float(xji.norm());
        // Only surface neighbours behind the surface (eq. 5); interior ones have no normal.
        if (r <= 0 || float(xji.dot(ni)) >= 0 || normal[*j].squaredNorm() == 0) continue;
        curvature += (1.0f - float(ni.dot(normal[*j]))) * weight(r, support);
      }
      out.waveCrest[i] = curvature;
    }
  });
}

std::vector<float> birthRates(const FluidPotentials& potentials, const PotentialLimits& limits,
                              double trappedAirRate, double waveCrestRate, double rateScale) {
  const std::size_t n = potentials.kineticEnergy.size();
  std::vector<float> rate(n, 0.0f);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const float energy =
          clampPotential(potentials.kineticEnergy[i], limits.kineticEnergy[0], limits.kineticEnergy[1]);
      if (energy <= 0) continue;
      const float trapped = clampPotential(potentials.trappedAir[i], limits.trappedAir[0], limits.trappedAir[1]);
      const float crest = clampPotential(potentials.waveCrest[i], limits.waveCrest[0], limits.waveCrest[1]);
      rate[i] = float(rateScale * energy * (trappedAirRate * trapped + waveCrestRate * crest));
    }
  });
  return rate;
}

PotentialLimits limitsFromStatistics(const std::vector<FluidPotentials>& samples, const PotentialLimits& floors) {
  const auto limit = [&](std::vector<float> FluidPotentials::*field, double floor) {
    double meanOfMaxima = 0;
    for (const FluidPotentials& sample : samples) {
      const std::vector<float>& values = sample.*field;
      meanOfMaxima += values.empty() ? 0.0 : double(*std::max_element(values.begin(), values.end()));
    }
    if (!samples.empty()) meanOfMaxima /= double(samples.size());
    const double low = std::max(0.1 * meanOfMaxima, floor);
    return std::array<double, 2>{low, std::max(meanOfMaxima, 2 * low)};
  };
  PotentialLimits limits;
  limits.trappedAir = limit(&FluidPotentials::trappedAir, floors.trappedAir[0]);
  limits.waveCrest = limit(&FluidPotentials::waveCrest, floors.waveCrest[0]);
  limits.kineticEnergy = limit(&FluidPotentials::kineticEnergy, floors.kineticEnergy[0]);
  return limits;
}

PotentialLimits physicalFloors(double h, double gravity) {
  PotentialLimits floors;
  floors.kineticEnergy = {0.5 * gravity * h, gravity * h};
  floors.trappedAir = {std::sqrt(gravity * h), 2 * std::sqrt(gravity * h)};
  floors.waveCrest = {0.5, 1};
  return floors;
}

} // namespace cascade::whitewater
