// The fluid between two cached frames: Hermite interpolation of matched particles.
#include "whitewater/FluidInterval.h"

#include "libsph/Errors.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace cascade::whitewater {

namespace {
double largestSpeed(const std::vector<Vec3r>& velocities) {
  double fastest = 0;
  for (const Vec3r& v : velocities) fastest = std::max(fastest, double(v.squaredNorm()));
  return std::sqrt(fastest);
}
} // namespace

void fluidArrays(const ParticleFrame& frame, std::vector<Vec3r>& positions, std::vector<Vec3r>& velocities,
                 const std::string& label) {
  if (frame.velocity.size() != frame.size())
    throw InputError(label + ": the particle cache has no velocities (whitewater needs them)");
  positions.resize(frame.size());
  velocities.resize(frame.size());
  for (std::size_t i = 0; i < frame.size(); ++i) {
    positions[i] = frame.position[i];
    velocities[i] = frame.velocity[i];
  }
}

void FluidInterval::assign(const ParticleFrame& first, const ParticleFrame& second, double t0, double t1,
                           const std::string& label) {
  mT0 = t0;
  mT1 = t1;
  std::vector<Vec3r>& x1 = mScratchX;
  std::vector<Vec3r>& v1 = mScratchV;
  fluidArrays(first, mX0, mV0, label);
  fluidArrays(second, x1, v1, label);
  const std::size_t n = first.size();
  mX1.resize(n);
  mV1.resize(n);
  mMatched.assign(n, 0);
  mSecondIndex.assign(n, -1);
  const bool withIds = first.id.size() == n && second.id.size() == second.size();
  if (withIds) {
    mIds.assign(first.id.begin(), first.id.end());
    // Index of each id in the second frame: a table when ids are dense, else a hash map.
    const ParticleId maxId = second.id.empty() ? 0 : *std::max_element(second.id.begin(), second.id.end());
    if (std::size_t(maxId) < 4 * second.size() + 1024) {
      std::vector<std::int64_t>& where = mWhere;
      where.assign(std::size_t(maxId) + 1, -1);
      for (std::size_t j = 0; j < second.size(); ++j) where[second.id[j]] = std::int64_t(j);
      tbb::parallel_for(std::size_t(0), n, [&](std::size_t i) {
        const ParticleId id = first.id[i];
        if (id <= maxId && where[id] >= 0) {
          mX1[i] = x1[std::size_t(where[id])];
          mV1[i] = v1[std::size_t(where[id])];
          mMatched[i] = 1;
          mSecondIndex[i] = where[id];
        }
      });
    } else {
      std::unordered_map<ParticleId, std::size_t> where;
      where.reserve(second.size());
      for (std::size_t j = 0; j < second.size(); ++j) where.emplace(second.id[j], j);
      for (std::size_t i = 0; i < n; ++i) {
        const auto it = where.find(first.id[i]);
        if (it == where.end()) continue;
        mX1[i] = x1[it->second];
        mV1[i] = v1[it->second];
        mMatched[i] = 1;
        mSecondIndex[i] = std::int64_t(it->second);
      }
    }
  } else {
    if (first.size() != second.size())
      throw InputError(label + ": particle caches without ids must keep their count between frames to be matched (" +
                       std::to_string(first.size()) + " then " + std::to_string(second.size()) + ")");
    mIds.resize(n);
    std::iota(mIds.begin(), mIds.end(), 0u);
    mX1 = x1;
    mV1 = v1;
    mMatched.assign(n, 1);
    std::iota(mSecondIndex.begin(), mSecondIndex.end(), std::int64_t(0));
  }
  mMaxSpeed = std::max(largestSpeed(mV0), largestSpeed(v1));
}

void FluidInterval::at(double t, std::vector<Vec3r>& positions, std::vector<Vec3r>& velocities) const {
  const std::size_t n = size();
  positions.resize(n);
  velocities.resize(n);
  const double T = mT1 - mT0;
  const double s = std::clamp((t - mT0) / T, 0.0, 1.0);
  // Cubic Hermite basis and its derivative (per unit s).
  const Real s2 = Real(s * s), s3 = Real(s * s * s), sf = Real(s), Tf = Real(T);
  const Real h00 = 2 * s3 - 3 * s2 + 1, h10 = s3 - 2 * s2 + sf, h01 = -2 * s3 + 3 * s2, h11 = s3 - s2;
  const Real d00 = 6 * s2 - 6 * sf, d10 = 3 * s2 - 4 * sf + 1, d01 = -6 * s2 + 6 * sf, d11 = 3 * s2 - 2 * sf;
  const Real dt = Real(t - mT0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      if (!mMatched[i]) {
        positions[i] = mX0[i] + dt * mV0[i];
        velocities[i] = mV0[i];
        continue;
      }
      positions[i] = h00 * mX0[i] + (h10 * Tf) * mV0[i] + h01 * mX1[i] + (h11 * Tf) * mV1[i];
      velocities[i] = (d00 / Tf) * mX0[i] + d10 * mV0[i] + (d01 / Tf) * mX1[i] + d11 * mV1[i];
    }
  });
}

} // namespace cascade::whitewater
