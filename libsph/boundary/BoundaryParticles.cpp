#include "libsph/boundary/BoundaryParticles.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace cascade {

/// A dense cell grid over the static type I samples (cell edge >= the query
/// radius), with a dilated occupancy flag so that particles far from every
/// wall are rejected with one lookup.
struct BoundaryParticles::Grid {
  Vec3r origin = Vec3r::Zero();
  Real cellSize = 1, inverseCellSize = 1;
  long dims[3] = {0, 0, 0};
  std::vector<std::uint32_t> cellStart;  // dims product + 1
  std::vector<std::uint32_t> sorted;     // sample indices grouped by cell
  std::vector<char> nearOccupied;        // any sample in the 27 cells around

  long cellIndex(long x, long y, long z) const { return (z * dims[1] + y) * dims[0] + x; }

  bool cellOf(const Vec3r& p, long c[3]) const {
    for (int a = 0; a < 3; ++a) {
      const Real f = std::floor((p[a] - origin[a]) * inverseCellSize);
      if (!(f >= 0 && f < Real(dims[a]))) return false;
      c[a] = static_cast<long>(f);
    }
    return true;
  }

  void build(const std::vector<Vec3r>& samples, Real radius) {
    Vec3r lo = Vec3r::Constant(std::numeric_limits<Real>::max()), hi = -lo;
    for (const Vec3r& p : samples) { lo = lo.cwiseMin(p); hi = hi.cwiseMax(p); }
    cellSize = radius;
    // Keep the dense grid below ~32 M cells.
    const Vec3r extent = hi - lo + Vec3r::Constant(2 * radius);
    const double volume = double(extent.x()) * extent.y() * extent.z();
    const double limit = 32.0e6;
    if (volume / (double(cellSize) * cellSize * cellSize) > limit)
      cellSize = static_cast<Real>(std::cbrt(volume / limit) * 1.001);
    inverseCellSize = Real(1) / cellSize;
    origin = lo - Vec3r::Constant(cellSize);
    for (int a = 0; a < 3; ++a)
      dims[a] = static_cast<long>(std::floor((hi[a] - origin[a]) * inverseCellSize)) + 2;
    const std::size_t cellCount = std::size_t(dims[0]) * dims[1] * dims[2];
    std::vector<std::uint32_t> cellOfSample(samples.size());
    cellStart.assign(cellCount + 1, 0);
    for (std::size_t k = 0; k < samples.size(); ++k) {
      long c[3] = {0, 0, 0};
      cellOf(samples[k], c);
      cellOfSample[k] = static_cast<std::uint32_t>(cellIndex(c[0], c[1], c[2]));
      ++cellStart[cellOfSample[k] + 1];
    }
    for (std::size_t c = 0; c < cellCount; ++c) cellStart[c + 1] += cellStart[c];
    sorted.resize(samples.size());
    std::vector<std::uint32_t> fill(cellStart.begin(), cellStart.end() - 1);
    for (std::size_t k = 0; k < samples.size(); ++k) sorted[fill[cellOfSample[k]]++] = std::uint32_t(k);
    nearOccupied.assign(cellCount, 0);
    tbb::parallel_for(long(0), dims[2], [&](long z) {
      for (long y = 0; y < dims[1]; ++y)
        for (long x = 0; x < dims[0]; ++x) {
          char any = 0;
          for (long dz = std::max(0L, z - 1); dz <= std::min(dims[2] - 1, z + 1) && !any; ++dz)
            for (long dy = std::max(0L, y - 1); dy <= std::min(dims[1] - 1, y + 1) && !any; ++dy)
              for (long dx = std::max(0L, x - 1); dx <= std::min(dims[0] - 1, x + 1); ++dx) {
                const long c = cellIndex(dx, dy, dz);
                if (cellStart[c + 1] > cellStart[c]) { any = 1; break; }
              }
          nearOccupied[cellIndex(x, y, z)] = any;
        }
    });
  }

  template <typename F>
  void forEachWithin(const Vec3r& p, Real radius2, const std::vector<Vec3r>& samples, F&& visit) const {
    long c[3] = {0, 0, 0};
    if (!cellOf(p, c) || !nearOccupied[cellIndex(c[0], c[1], c[2])]) return;
    for (long z = std::max(0L, c[2] - 1); z <= std::min(dims[2] - 1, c[2] + 1); ++z)
      for (long y = std::max(0L, c[1] - 1); y <= std::min(dims[1] - 1, c[1] + 1); ++y) {
        const long row = cellIndex(0, y, z);
        const long x0 = std::max(0L, c[0] - 1), x1 = std::min(dims[0] - 1, c[0] + 1);
        // cells x0..x1 of a row are contiguous
        for (std::uint32_t s = cellStart[row + x0]; s < cellStart[row + x1 + 1]; ++s) {
          const std::uint32_t k = sorted[s];
          if (squaredDistance(p, samples[k]) <= radius2) visit(k);
        }
      }
  }
};

BoundaryParticles::BoundaryParticles() = default;
BoundaryParticles::~BoundaryParticles() = default;
BoundaryParticles::BoundaryParticles(BoundaryParticles&&) noexcept = default;
BoundaryParticles& BoundaryParticles::operator=(BoundaryParticles&&) noexcept = default;

void BoundaryParticles::sample(const std::vector<BoundaryPtr>& boundaries, Real maxGap,
                               Real sampleRadius) {
  mSamples.clear();
  mOwners.clear();
  for (std::size_t b = 0; b < boundaries.size(); ++b) {
    const std::size_t first = mSamples.size();
    boundaries[b]->sampleSurface(maxGap, mSamples);
    mOwners.resize(mSamples.size(), static_cast<std::uint32_t>(b));
    (void)first;
  }
  mGrid.reset();
  if (!mSamples.empty()) {
    mGrid = std::make_unique<Grid>();
    mGrid->build(mSamples, sampleRadius);
  }
}

std::vector<std::size_t> BoundaryParticles::samplesPerBoundary(std::size_t boundaryCount) const {
  std::vector<std::size_t> counts(boundaryCount, 0);
  for (std::uint32_t owner : mOwners)
    if (owner < boundaryCount) ++counts[owner];
  return counts;
}

void BoundaryParticles::update(const Particles& particles, const std::vector<BoundaryPtr>& boundaries,
                               Real sampleRadius, Real mirrorRange, bool withSamples,
                               bool withMirrors) {
  const std::size_t n = particles.size();
  constexpr std::size_t kChunk = 1024;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  struct ChunkOut {
    std::vector<MirrorMap> maps;
    std::vector<std::uint32_t> samples;
    std::size_t mapBase = 0, sampleBase = 0;
  };
  std::vector<ChunkOut> out(chunks);
  mMirrorOffsets.resize(n + 1);
  mSampleNeighbors.offsets.resize(n + 1);
  const bool samples = withSamples && mGrid;
  const Real radius2 = sampleRadius * sampleRadius;
  const std::uint32_t boundaryCount = static_cast<std::uint32_t>(boundaries.size());

  // Pass 1: per chunk, the maps and sample indices, and per particle their counts
  // (stored temporarily in the offset arrays at i + 1).
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    ChunkOut& chunk = out[c];
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const Vec3r& x = particles.position[i];
      const std::size_t mapsBefore = chunk.maps.size(), samplesBefore = chunk.samples.size();
      if (withMirrors)
        for (std::uint32_t b = 0; b < boundaryCount; ++b) boundaries[b]->mirrorMaps(x, mirrorRange, b, chunk.maps);
      if (samples)
        mGrid->forEachWithin(x, radius2, mSamples, [&](std::uint32_t k) { chunk.samples.push_back(k); });
      mMirrorOffsets[i + 1] = static_cast<std::uint32_t>(chunk.maps.size() - mapsBefore);
      mSampleNeighbors.offsets[i + 1] = static_cast<std::uint32_t>(chunk.samples.size() - samplesBefore);
    }
  });
  // Chunk bases (serial over chunks, in order: deterministic).
  std::size_t mapTotal = 0, sampleTotal = 0;
  for (ChunkOut& chunk : out) {
    chunk.mapBase = mapTotal;
    chunk.sampleBase = sampleTotal;
    mapTotal += chunk.maps.size();
    sampleTotal += chunk.samples.size();
  }
  mMirrors.resize(mapTotal);
  mSampleNeighbors.indices.resize(sampleTotal);
  mMirrorOffsets[0] = 0;
  mSampleNeighbors.offsets[0] = 0;
  // Pass 2: offsets within chunks, copy.
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    const ChunkOut& chunk = out[c];
    const std::size_t begin = c * kChunk, end = std::min(n, (c + 1) * kChunk);
    std::uint32_t mapOffset = static_cast<std::uint32_t>(chunk.mapBase);
    std::uint32_t sampleOffset = static_cast<std::uint32_t>(chunk.sampleBase);
    for (std::size_t i = begin; i < end; ++i) {
      mapOffset += mMirrorOffsets[i + 1];
      sampleOffset += mSampleNeighbors.offsets[i + 1];
      mMirrorOffsets[i + 1] = mapOffset;
      mSampleNeighbors.offsets[i + 1] = sampleOffset;
    }
    std::copy(chunk.maps.begin(), chunk.maps.end(), mMirrors.begin() + chunk.mapBase);
    std::copy(chunk.samples.begin(), chunk.samples.end(),
              mSampleNeighbors.indices.begin() + chunk.sampleBase);
  });
  mLayer.clear();
  for (std::size_t i = 0; i < n; ++i)
    if (mMirrorOffsets[i + 1] > mMirrorOffsets[i] ||
        mSampleNeighbors.offsets[i + 1] > mSampleNeighbors.offsets[i])
      mLayer.push_back(static_cast<std::uint32_t>(i));
}

} // namespace cascade
