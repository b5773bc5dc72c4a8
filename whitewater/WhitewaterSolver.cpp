// One frame interval of whitewater: births, classification, advection, removal.
#include "whitewater/WhitewaterSolver.h"

#include "whitewater/DiffuseAdvection.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace cascade::whitewater {

namespace {

/// SplitMix64's finaliser: a well-mixed 64-bit hash of a 64-bit key.
inline std::uint64_t mix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

/// Uniform numbers in [0, 1) from a counter: the k-th draw of a key is mix64(key + k).
struct Draws {
  std::uint64_t key;
  std::uint64_t next = 0;
  double uniform() { return double(mix64(key + next++) >> 11) * 0x1.0p-53; }
};

std::uint64_t drawKey(std::uint64_t seed, std::uint64_t stream, std::uint64_t a, std::uint64_t b) {
  return mix64(seed ^ mix64(stream ^ mix64(a ^ mix64(b))));
}

constexpr std::uint64_t kBirthStream = 0xb1e7, kLifetimeStream = 0x11fe;
} // namespace

WhitewaterSolver::WhitewaterSolver(const scene::WhitewaterSettings& settings, const Vec3r& gravity, double spacing,
                                   const RemovalBox& domain)
    : mSettings(settings), mGravity(gravity), mH(Real(2 * spacing)), mRadius(Real(0.5 * spacing)), mDomain(domain),
      mSeed(mix64(std::uint64_t(settings.seed))) {}

double WhitewaterSolver::lifetime(std::uint32_t id) const {
  Draws draws{drawKey(mSeed, kLifetimeStream, id, 0)};
  return mSettings.lifetime[0] + (mSettings.lifetime[1] - mSettings.lifetime[0]) * draws.uniform();
}

int WhitewaterSolver::substepsFor(const FluidInterval& fluid) const {
  if (mSettings.substeps > 0) return mSettings.substeps;
  const double steps = std::ceil(fluid.maxSpeed() * (fluid.t1() - fluid.t0()) / double(mH));
  return int(std::clamp(steps, 1.0, 64.0));
}

void WhitewaterSolver::buildFluid(const std::vector<Vec3r>& fluidPositions) {
  if (&fluidPositions != &mFluidX) mFluidX = fluidPositions;
  mGrid.build(mFluidX.data(), mFluidX.size(), mH);
}

std::vector<DiffuseType> WhitewaterSolver::classify(const DiffuseParticles& particles,
                                                    const std::vector<Vec3r>& fluidPositions) {
  buildFluid(fluidPositions);
  sampleFluid(mGrid, nullptr, particles.position.data(), particles.size(), mH, mSamples);
  std::vector<DiffuseType> types(particles.size());
  for (std::size_t i = 0; i < particles.size(); ++i)
    types[i] = classifyDiffuse(mSamples[i].neighbors, mSettings.sprayNeighbors, mSettings.bubbleNeighbors);
  return types;
}

void WhitewaterSolver::frameRates(const std::vector<Vec3r>& positions, std::vector<float> rates,
                                  FrameBirthRates& out) const {
  out.rate = std::move(rates);
  out.field.build(positions.data(), out.rate.data(), std::min(positions.size(), out.rate.size()), 2 * mRadius);
}

IntervalStats WhitewaterSolver::advance(const FluidInterval& fluid, const std::vector<float>& rates, int frame,
                                        DiffuseParticles& particles, std::uint32_t& nextId) {
  FrameBirthRates atStart, atEnd;
  frameRates(fluid.startPositions(), rates, atStart);
  // The end's rates in the second frame's order: the same particles' (a particle
  // new there has none).
  const std::vector<std::int64_t>& second = fluid.secondIndex();
  const std::vector<Vec3r>& endPositions = fluid.endPositions();
  std::int64_t count = 0;
  for (std::int64_t j : second) count = std::max(count, j + 1);
  std::vector<float> endRates(std::size_t(count), 0.0f);
  std::vector<Vec3r> endX(std::size_t(count), Vec3r::Constant(Real(1e30)));
  for (std::size_t i = 0; i < second.size(); ++i)
    if (second[i] >= 0 && i < rates.size()) {
      endRates[std::size_t(second[i])] = rates[i];
      endX[std::size_t(second[i])] = endPositions[i];
    }
  frameRates(endX, std::move(endRates), atEnd);
  return advance(fluid, atStart, atEnd, frame, particles, nextId);
}

IntervalStats WhitewaterSolver::advance(const FluidInterval& fluid, const FrameBirthRates& atStart,
                                        const FrameBirthRates& atEnd, int frame, DiffuseParticles& particles,
                                        std::uint32_t& nextId) {
  IntervalStats stats;
  stats.substeps = substepsFor(fluid);
  const double interval = fluid.t1() - fluid.t0();
  const double dt = interval / stats.substeps;
  const bool births = !atStart.field.empty() || !atEnd.field.empty();
  if (births) {
    // Sources that move with the water: a rate at one frame where the other has
    // none (the particle's own rate, carried along its path).
    const std::vector<Vec3r>& start = fluid.startPositions();
    const std::vector<Vec3r>& end = fluid.endPositions();
    const std::size_t n = fluid.size();
    mMovingStart.assign(n, 0.0f);
    mMovingEnd.assign(n, 0.0f);
    for (std::size_t i = 0; i < std::min(n, atStart.rate.size()); ++i)
      if (atStart.rate[i] > 0 && atEnd.field.at(start[i]) == 0) mMovingStart[i] = atStart.rate[i];
    const std::vector<std::int64_t>& second = fluid.secondIndex();
    for (std::size_t i = 0; i < n; ++i) {
      if (second[i] < 0 || std::size_t(second[i]) >= atEnd.rate.size()) continue;
      const float rate = atEnd.rate[std::size_t(second[i])];
      if (rate > 0 && atStart.field.at(end[i]) == 0) mMovingEnd[i] = rate;
    }
  }
  std::vector<std::uint32_t>& sources = mSources;
  const std::vector<std::uint32_t>& fluidIds = fluid.ids();
  const Vec3r buoyancy = Real(-mSettings.buoyancy) * mGravity;
  const Vec3r still = Vec3r::Zero();

  // Along the Z curve, so that the sub-steps visit the particles (in their
  // cells' order) along memory. The order depends only on the positions.
  particles.permute(zOrderPermutation(particles.position.data(), particles.size(), mH));

  std::vector<std::uint8_t> keep;
  std::vector<std::uint32_t> made;  // births per source, then their running sum
  for (int step = 0; step < stats.substeps; ++step) {
    const double t = fluid.t0() + step * dt;
    fluid.at(t, mFluidX, mFluidV);
    buildFluid(mFluidX);

    // Classify and advect every particle by its kind, then age it.
    const std::size_t count = particles.size();
    mPlaceV.gather(mGrid, mFluidV);
    sampleFluid(mGrid, &mPlaceV, particles.position.data(), count, mH, mSamples);
    keep.assign(count, 1);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 4096), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        Vec3r& x = particles.position[i];
        Vec3r& v = particles.velocity[i];
        const FluidSample& fluidAround = mSamples[i];
        const DiffuseType type =
            classifyDiffuse(fluidAround.neighbors, mSettings.sprayNeighbors, mSettings.bubbleNeighbors);
        if (type == DiffuseType::Spray) {
          relaxMotion(x, v, still, mGravity, mSettings.airDrag, dt);
        } else {
          // v_f: the fluid velocity around the particle (Ihmsen 2012 eq. 10).
          const Vec3r fluidVelocity = fluidAround.weight > 0 ? fluidAround.velocity : v;
          if (type == DiffuseType::Foam) {
            x += Real(dt) * fluidVelocity;
            v = fluidVelocity;
          } else {
            relaxMotion(x, v, fluidVelocity, buoyancy, mSettings.bubbleDrag, dt);
          }
        }
        particles.age[i] += float(dt);
        if (type == DiffuseType::Foam && particles.age[i] > lifetime(particles.id[i])) keep[i] = 2;  // dissolved
        else if (!mDomain.contains(x)) keep[i] = 3;                                                 // left
      }
    });
    for (std::uint8_t& k : keep) {
      if (k == 2) ++stats.dissolved;
      if (k == 3) ++stats.left;
      k = k == 1;
    }
    particles.keepWhere(keep);

    if (!births) continue;
    // Each fluid particle's rate, the frames' blended linearly in time (at the
    // sub-step's middle): a source that stays, that of the place the particle
    // passes; one that moves, its own.
    const double late = (t + 0.5 * dt - fluid.t0()) / interval;
    mRateNow.resize(mFluidX.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mFluidX.size(), 4096), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        double early = mMovingStart[i], later = mMovingEnd[i];
        const Vec3r middle = mFluidX[i] + Real(0.5 * dt) * mFluidV[i];
        const float staysStart = atStart.field.at(middle);
        if (staysStart > 0) {
          const float staysEnd = atEnd.field.at(middle);
          if (staysEnd > 0) {
            early += double(staysStart);
            later += double(staysEnd);
          }
        }
        mRateNow[i] = float((1 - late) * early + late * later);
      }
    });
    sources.clear();
    for (std::size_t i = 0; i < mRateNow.size(); ++i)
      if (mRateNow[i] > 0) sources.push_back(std::uint32_t(i));
    made.resize(sources.size() + 1);

    // Births along each source's path over [t, t + dt] (eqs. 7-9).
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sources.size(), 4096), [&](const auto& range) {
      for (std::size_t s = range.begin(); s != range.end(); ++s) {
        const std::uint32_t i = sources[s];
        const double expected = double(mRateNow[i]) * dt;
        Draws draws{drawKey(mSeed, kBirthStream, fluidIds[i], std::uint64_t(frame) * 4096 + std::uint64_t(step))};
        const double whole = std::floor(expected);
        made[s] = std::uint32_t(whole) + (draws.uniform() < expected - whole ? 1u : 0u);
      }
    });
    made[sources.size()] = 0;
    std::exclusive_scan(made.begin(), made.end(), made.begin(), std::uint32_t(0));
    const std::uint32_t newCount = made[sources.size()];
    if (std::uint64_t(nextId) + newCount > std::uint64_t(INT32_MAX))
      throw std::runtime_error("whitewater: more than 2^31 particles born in one run (lower rate_scale)");
    const std::size_t first = particles.size();
    particles.position.resize(first + newCount);
    particles.velocity.resize(first + newCount);
    particles.id.resize(first + newCount);
    particles.age.resize(first + newCount, 0.0f);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, sources.size(), 1024), [&](const auto& range) {
      for (std::size_t s = range.begin(); s != range.end(); ++s) {
        const std::uint32_t count = made[s + 1] - made[s];
        if (count == 0) continue;
        const std::uint32_t i = sources[s];
        const Vec3r& x = mFluidX[i];
        const Vec3r& v = mFluidV[i];
        const Real speed = v.norm();
        const Vec3r along = speed > 0 ? Vec3r(v / speed) : Vec3r(0, 0, 1);
        // e1, e2: an orthonormal pair across the path.
        const Vec3r helper = std::abs(along.x()) < Real(0.9) ? Vec3r(1, 0, 0) : Vec3r(0, 1, 0);
        const Vec3r e1 = along.cross(helper).normalized();
        const Vec3r e2 = along.cross(e1);
        Draws draws{drawKey(mSeed, kBirthStream, fluidIds[i], std::uint64_t(frame) * 4096 + std::uint64_t(step))};
        draws.uniform();  // the count's draw
        for (std::uint32_t k = 0; k < count; ++k) {
          const std::size_t out = first + made[s] + k;
          const Real r = mRadius * Real(std::sqrt(draws.uniform()));
          const Real theta = Real(2 * M_PI * draws.uniform());
          const Real along_ = Real(draws.uniform()) * speed * Real(dt);
          particles.position[out] = x + r * std::cos(theta) * e1 + r * std::sin(theta) * e2 + along_ * along;
          particles.velocity[out] = v;
          particles.id[out] = nextId + made[s] + k;
          particles.age[out] = 0.0f;
        }
      }
    });
    nextId += newCount;
    stats.born += newCount;
  }
  return stats;
}

} // namespace cascade::whitewater
