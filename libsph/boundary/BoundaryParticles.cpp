#include "libsph/boundary/BoundaryParticles.h"

#include "libsph/boundary/TriangleBand.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace cascade {

/// A dense cell grid over the type I samples that are not on a lattice (mesh
/// obstacles; cell edge >= the query radius), with a dilated occupancy flag so
/// that particles far from every such sample are rejected with one lookup.
/// The samples themselves are stored in cell order, so a query reads each row
/// of cells as one contiguous run.
struct BoundaryParticles::Grid {
  Vec3r origin = Vec3r::Zero();
  Real cellSize = 1, inverseCellSize = 1;
  long dims[3] = {0, 0, 0};
  std::vector<std::uint32_t> cellStart;  // dims product + 1
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

  /// Sorts samples [base, end) (and their owners) into cell order and indexes them.
  void build(std::vector<Vec3r>& samples, std::vector<std::uint32_t>& owners, std::size_t base, Real radius) {
    Vec3r lo = Vec3r::Constant(std::numeric_limits<Real>::max()), hi = -lo;
    for (std::size_t k = base; k < samples.size(); ++k) { lo = lo.cwiseMin(samples[k]); hi = hi.cwiseMax(samples[k]); }
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
    const std::size_t count = samples.size() - base;
    std::vector<std::uint32_t> cellOfSample(count);
    cellStart.assign(cellCount + 1, 0);
    for (std::size_t k = 0; k < count; ++k) {
      long c[3] = {0, 0, 0};
      cellOf(samples[base + k], c);
      cellOfSample[k] = static_cast<std::uint32_t>(cellIndex(c[0], c[1], c[2]));
      ++cellStart[cellOfSample[k] + 1];
    }
    cellStart[0] = static_cast<std::uint32_t>(base);  // indices into the whole sample array
    for (std::size_t c = 0; c < cellCount; ++c) cellStart[c + 1] += cellStart[c];
    // Counting sort (stable: within a cell, the sampling order).
    std::vector<Vec3r> sortedSamples(count);
    std::vector<std::uint32_t> sortedOwners(count);
    std::vector<std::uint32_t> fill(cellStart.begin(), cellStart.end() - 1);
    for (std::size_t k = 0; k < count; ++k) {
      const std::uint32_t slot = fill[cellOfSample[k]]++ - static_cast<std::uint32_t>(base);
      sortedSamples[slot] = samples[base + k];
      sortedOwners[slot] = owners[base + k];
    }
    std::copy(sortedSamples.begin(), sortedSamples.end(), samples.begin() + std::ptrdiff_t(base));
    std::copy(sortedOwners.begin(), sortedOwners.end(), owners.begin() + std::ptrdiff_t(base));
    nearOccupied.assign(cellCount, 0);
    tbb::parallel_for(long(0), dims[2], [&](long z) {
      for (long y = 0; y < dims[1]; ++y)
        for (long x = 0; x < dims[0]; ++x) {
          char any = 0;
          for (long dz = std::max(0L, z - 1); dz <= std::min(dims[2] - 1, z + 1) && !any; ++dz)
            for (long dy = std::max(0L, y - 1); dy <= std::min(dims[1] - 1, y + 1) && !any; ++dy) {
              const long row = cellIndex(0, dy, dz);
              if (cellStart[row + std::min(dims[0] - 1, x + 1) + 1] > cellStart[row + std::max(0L, x - 1)]) any = 1;
            }
          nearOccupied[cellIndex(x, y, z)] = any;
        }
    });
  }

  /// Calls visit(k, samples[k]) for every sample k within `radius` (<= cellSize) of p.
  template <typename F>
  void forEachWithin(const Vec3r& p, Real radius, const std::vector<Vec3r>& samples, F&& visit) const {
    long c[3] = {0, 0, 0};
    if (!cellOf(p, c) || !nearOccupied[cellIndex(c[0], c[1], c[2])]) return;
    // Only the cells the ball [p - radius, p + radius] overlaps: with cells no
    // smaller than the radius, at most 2 per axis.
    long lo[3], hi[3];
    for (int a = 0; a < 3; ++a) {
      const Real offset = (p[a] - origin[a]) * inverseCellSize, reach = radius * inverseCellSize;
      lo[a] = std::max(0L, static_cast<long>(std::floor(offset - reach)));
      hi[a] = std::min(dims[a] - 1, static_cast<long>(std::floor(offset + reach)));
    }
    const Real radius2 = radius * radius;
    for (long z = lo[2]; z <= hi[2]; ++z)
      for (long y = lo[1]; y <= hi[1]; ++y) {
        const long row = cellIndex(0, y, z);
        // cells lo..hi of a row are contiguous
        const std::uint32_t end = cellStart[row + hi[0] + 1];
        for (std::uint32_t k = cellStart[row + lo[0]]; k < end; ++k)
          if (squaredDistance(p, samples[k]) <= radius2) visit(k, samples[k]);
      }
  }
};

/// A coarse cell grid over the static solids: per cell, a bit for each lattice whose
/// rectangle and each boundary whose surface triangles may lie within reach of a point in
/// the cell (the sample radius for lattices, twice the mirror range for mirror maps:
/// Boundary::mirrorsNearSurfaceMeshOnly(), or the sample radius if larger), so that
/// update() skips the planes and boundaries that cannot matter to a particle, and the
/// mesh samples' grid (a miss in a large table) where no boundary sampled in it can. Moving
/// solids have their bit set everywhere; solids not bounded by their surface (unbounded
/// planes, open tanks) cell by cell by their own test (Boundary::mayMirrorNear) and
/// everywhere outside the grid. Conservative: a cell is
/// marked when its centre lies within reach plus its half diagonal, so a particle's
/// lists are exactly those of the full scan, in the same order.
struct BoundaryParticles::Proximity {
  static constexpr std::size_t kMaxBits = 64;
  Real sampleRadius = -1, mirrorRange = -1;
  std::size_t boundaryCount = 0, latticeCount = 0;
  bool usable = false;  ///< false: more than 64 lattices or boundaries, every bit everywhere
  Vec3r origin = Vec3r::Zero();
  Real inverseCellSize = 1;
  long dims[3] = {0, 0, 0};
  std::uint64_t everywhere = 0;  ///< boundaries marked in every cell (and outside the grid)
  std::uint64_t outside = 0;     ///< boundaries marked cell by cell and everywhere outside the grid
  std::vector<std::uint64_t> lattices, boundaries;  // per cell

  void lookup(const Vec3r& x, std::uint64_t& latticeBits, std::uint64_t& boundaryBits) const {
    if (!usable) {
      latticeBits = boundaryBits = ~std::uint64_t(0);
      return;
    }
    long c[3];
    for (int a = 0; a < 3; ++a) {
      const Real f = std::floor((x[a] - origin[a]) * inverseCellSize);
      if (!(f >= 0 && f < Real(dims[a]))) {  // beyond every static solid's reach
        latticeBits = 0;
        boundaryBits = everywhere | outside;
        return;
      }
      c[a] = static_cast<long>(f);
    }
    const long cell = (c[2] * dims[1] + c[1]) * dims[0] + c[0];
    latticeBits = lattices[std::size_t(cell)];
    boundaryBits = boundaries[std::size_t(cell)] | everywhere;
  }
};

void BoundaryParticles::makeProximity(const std::vector<BoundaryPtr>& boundaries, Real sampleRadius,
                                      Real mirrorRange) {
  auto proximity = std::make_unique<Proximity>();
  Proximity& p = *proximity;
  p.sampleRadius = sampleRadius;
  p.mirrorRange = mirrorRange;
  p.boundaryCount = boundaries.size();
  p.latticeCount = mLattices.size();
  mProximity = std::move(proximity);
  if (boundaries.size() > Proximity::kMaxBits || mLattices.size() > Proximity::kMaxBits) return;
  // The pieces to mark: lattice rectangles (grown by the sample radius) and the triangles of
  // the static boundaries whose maps stay near them (grown by twice the mirror range).
  struct Triangle {
    Vec3d a, b, c;
    double reach;
    std::uint32_t bit;
    bool lattice;
  };
  std::vector<Triangle> pieces;
  for (std::size_t l = 0; l < mLattices.size(); ++l) {
    const SampleLattice& q = mLattices[l].lattice;
    const Vec3d c = q.center.cast<double>(), u = (q.halfU * q.axisU).cast<double>(), v = (q.halfV * q.axisV).cast<double>();
    pieces.push_back({c - u - v, c + u - v, c + u + v, double(sampleRadius), std::uint32_t(l), true});
    pieces.push_back({c - u - v, c + u + v, c - u + v, double(sampleRadius), std::uint32_t(l), true});
  }
  std::vector<std::size_t> unbounded;  // static, but mirroring beyond reach of their surface
  for (std::size_t b = 0; b < boundaries.size(); ++b) {
    if (boundaries[b]->moves()) {
      p.everywhere |= std::uint64_t(1) << b;
      continue;
    }
    if (!boundaries[b]->mirrorsNearSurfaceMeshOnly()) {
      p.outside |= std::uint64_t(1) << b;
      unbounded.push_back(b);  // marked below, cell by cell (an unbounded plane: every cell)
      continue;
    }
    // Reach: the maps' (twice the mirror range), and the sample radius of the samples on
    // the surface (a boundary's bit also gates its samples in the mesh grid).
    const double reach = std::max(2 * double(mirrorRange), double(sampleRadius));
    const TriangleMesh mesh = boundaries[b]->surfaceMesh();
    for (const auto& t : mesh.triangles)
      pieces.push_back({mesh.vertices[t[0]].cast<double>(), mesh.vertices[t[1]].cast<double>(),
                        mesh.vertices[t[2]].cast<double>(), reach, std::uint32_t(b), false});
  }
  Vec3d lo = Vec3d::Constant(std::numeric_limits<double>::max()), hi = -lo;
  for (const Triangle& t : pieces)
    for (const Vec3d& x : {t.a, t.b, t.c}) {
      lo = lo.cwiseMin(x - Vec3d::Constant(t.reach));
      hi = hi.cwiseMax(x + Vec3d::Constant(t.reach));
    }
  if (pieces.empty()) {
    p.usable = true;  // no static piece: nothing but the everywhere bits
    p.dims[0] = p.dims[1] = p.dims[2] = 0;
    return;
  }
  // Cells of the larger reach, at most ~4 M of them.
  double cell = std::max(double(sampleRadius), 2 * double(mirrorRange));
  const Vec3d extent = hi - lo;
  while (cell > 0 && (std::ceil(extent.x() / cell) * std::ceil(extent.y() / cell) * std::ceil(extent.z() / cell)) > 4e6)
    cell *= 1.5;
  if (!(cell > 0)) return;
  p.inverseCellSize = Real(1 / cell);
  p.origin = lo.cast<Real>();
  for (int a = 0; a < 3; ++a) p.dims[a] = std::max(1L, long(std::ceil(extent[a] / cell)));
  const std::size_t cells = std::size_t(p.dims[0] * p.dims[1] * p.dims[2]);
  p.lattices.assign(cells, 0);
  p.boundaries.assign(cells, 0);
  // A point x of a cell lies within reach of a piece if the cell's centre does within
  // reach + half diagonal; the centre as the lookup's float arithmetic places it, with a
  // margin for rounding.
  const double halfDiagonal = 0.5 * std::sqrt(3.0) * cell * (1 + 1e-4);
  const Vec3d origin = p.origin.cast<double>();
  for (const Triangle& t : pieces) {
    const double reach = t.reach + halfDiagonal;
    long from[3], to[3];
    for (int a = 0; a < 3; ++a) {
      const double low = std::min({t.a[a], t.b[a], t.c[a]}) - reach, high = std::max({t.a[a], t.b[a], t.c[a]}) + reach;
      from[a] = std::max(0L, long(std::floor((low - origin[a]) / cell)));
      to[a] = std::min(p.dims[a] - 1, long(std::floor((high - origin[a]) / cell)));
    }
    std::vector<std::uint64_t>& bits = t.lattice ? p.lattices : p.boundaries;
    const std::uint64_t bit = std::uint64_t(1) << t.bit;
    for (long z = from[2]; z <= to[2]; ++z)
      for (long y = from[1]; y <= to[1]; ++y)
        for (long x = from[0]; x <= to[0]; ++x) {
          const std::size_t index = std::size_t((z * p.dims[1] + y) * p.dims[0] + x);
          if (bits[index] & bit) continue;
          const Vec3d centre = origin + cell * Vec3d(double(x) + 0.5, double(y) + 0.5, double(z) + 0.5);
          if ((closestOnTriangle(centre, t.a, t.b, t.c) - centre).norm() <= reach) bits[index] |= bit;
        }
  }
  // The unbounded ones cell by cell (an open tank's wall slabs, Boundary::mayMirrorNear), as
  // far as twice the mirror range: the guard asks the solids marked where a move ends
  // (boundariesNear), and a move that leaves the water through a wall ends within its
  // length, at most that reach, of the wall.
  for (std::size_t b : unbounded) {
    const std::uint64_t bit = std::uint64_t(1) << b;
    const Real slack = Real(halfDiagonal + std::max(2 * double(mirrorRange), double(sampleRadius)));
    tbb::parallel_for(long(0), p.dims[2], [&](long z) {
      for (long y = 0; y < p.dims[1]; ++y)
        for (long x = 0; x < p.dims[0]; ++x) {
          const Vec3d centre = origin + cell * Vec3d(double(x) + 0.5, double(y) + 0.5, double(z) + 0.5);
          if (boundaries[b]->mayMirrorNear(centre.cast<Real>(), slack, mirrorRange))
            p.boundaries[std::size_t((z * p.dims[1] + y) * p.dims[0] + x)] |= bit;
        }
    });
  }
  p.usable = true;
}

BoundaryParticles::BoundaryParticles() = default;
BoundaryParticles::~BoundaryParticles() = default;
BoundaryParticles::BoundaryParticles(BoundaryParticles&&) noexcept = default;
BoundaryParticles& BoundaryParticles::operator=(BoundaryParticles&&) noexcept = default;

void BoundaryParticles::sample(const std::vector<BoundaryPtr>& boundaries, Real maxGap,
                               Real sampleRadius) {
  mGap = maxGap;
  mProximity.reset();
  mSamples.clear();
  mOwners.clear();
  mLattices.clear();
  mGridBoundaries = 0;
  // Lattices first (flat walls: found from a particle's plane coordinates),
  // then the other samples (meshes), indexed by the grid.
  std::vector<Vec3r> points;
  std::vector<std::uint32_t> pointOwners;
  std::vector<SampleLattice> lattices;
  for (std::size_t b = 0; b < boundaries.size(); ++b) {
    if (boundaries[b]->moves()) continue;  // below, in their own frames
    lattices.clear();
    boundaries[b]->sampleSurfaceLattices(maxGap, lattices, points);
    if (points.size() > pointOwners.size())
      mGridBoundaries |= b < Proximity::kMaxBits ? std::uint64_t(1) << b : ~std::uint64_t(0);
    pointOwners.resize(points.size(), static_cast<std::uint32_t>(b));
    for (const SampleLattice& lattice : lattices) {
      LatticeEntry entry;
      entry.lattice = lattice;
      entry.normal = lattice.axisU.cross(lattice.axisV).normalized();
      entry.first = static_cast<std::uint32_t>(mSamples.size());
      entry.owner = static_cast<std::uint32_t>(b);
      lattice.append(mSamples);
      mOwners.resize(mSamples.size(), static_cast<std::uint32_t>(b));
      mLattices.push_back(entry);
    }
  }
  const std::size_t base = mSamples.size();
  mSamples.insert(mSamples.end(), points.begin(), points.end());
  mOwners.insert(mOwners.end(), pointOwners.begin(), pointOwners.end());
  mGrid.reset();
  if (mSamples.size() > base) {
    mGrid = std::make_unique<Grid>();
    mGrid->build(mSamples, mOwners, base, sampleRadius);
  }
  // Moving solids last: sampled once in their reference frames, each with a grid
  // over its reference samples (queries are turned into the solid's frame); deforming
  // ones for their current frame interval.
  mSampleRadius = sampleRadius;
  mMoving.clear();
  mMovingBegin = static_cast<std::uint32_t>(mSamples.size());
  for (std::size_t b = 0; b < boundaries.size(); ++b) {
    if (!boundaries[b]->moves()) continue;
    MovingSet set;
    set.boundary = static_cast<std::uint32_t>(b);
    if (boundaries[b]->deformation().interval != -1) {
      sampleDeforming(set, *boundaries[b]);
    } else {
      boundaries[b]->sampleReference(maxGap, set.reference);
      if (set.reference.empty()) continue;
      std::vector<std::uint32_t> owners(set.reference.size(), set.boundary);
      set.grid = std::make_shared<Grid>();
      set.grid->build(set.reference, owners, 0, sampleRadius);
    }
    mMoving.push_back(std::move(set));
  }
  layOutMovingSamples();
  placeMovingSamples(boundaries);
}

void BoundaryParticles::layOutMovingSamples() {
  mSamples.resize(mMovingBegin);
  mOwners.resize(mMovingBegin);
  for (MovingSet& set : mMoving) {
    set.first = static_cast<std::uint32_t>(mSamples.size());
    mSamples.insert(mSamples.end(), set.reference.begin(), set.reference.end());
    mOwners.resize(mSamples.size(), set.boundary);
  }
  mMovingVelocity.assign(mSamples.size() - mMovingBegin, Vec3r::Zero());
}

void BoundaryParticles::sampleDeforming(MovingSet& set, const Boundary& solid) const {
  set.interval = solid.deformation().interval;
  std::vector<Vec3r> start, end;
  solid.sampleDeformation(mGap, start, end);
  const std::size_t count = start.size();
  set.middle.resize(count);
  set.reach = 0;
  for (std::size_t k = 0; k < count; ++k) {
    set.middle[k] = Real(0.5) * (start[k] + end[k]);
    set.reach = std::max(set.reach, Real(0.5) * (end[k] - start[k]).norm());
  }
  set.reach *= Real(1.0001);  // rounding of the interpolation
  // The grid sorts the midpoints into cell order; the owner slots carry the permutation.
  std::vector<std::uint32_t> order(count);
  for (std::size_t k = 0; k < count; ++k) order[k] = static_cast<std::uint32_t>(k);
  set.grid.reset();
  set.reference.clear();
  set.end.clear();
  if (count == 0) return;
  set.grid = std::make_shared<Grid>();
  set.grid->build(set.middle, order, 0, mSampleRadius + set.reach);
  set.reference.resize(count);
  set.end.resize(count);
  for (std::size_t k = 0; k < count; ++k) {
    set.reference[k] = start[order[k]];
    set.end[k] = end[order[k]];
  }
}

void BoundaryParticles::placeMovingSamples(const std::vector<BoundaryPtr>& boundaries) {
  bool resampled = false;
  for (MovingSet& set : mMoving)
    if (set.interval != -1 && boundaries[set.boundary]->deformation().interval != set.interval) {
      sampleDeforming(set, *boundaries[set.boundary]);
      resampled = true;
    }
  if (resampled) layOutMovingSamples();
  for (MovingSet& set : mMoving) {
    const Boundary& solid = *boundaries[set.boundary];
    const std::size_t count = set.reference.size();
    if (set.interval != -1) {
      // A deforming solid: between its interval's start and end.
      const Boundary::Deformation d = solid.deformation();
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 4096), [&](const auto& range) {
        for (std::size_t k = range.begin(); k != range.end(); ++k) {
          const Vec3r move = set.end[k] - set.reference[k];
          mSamples[set.first + k] = set.reference[k] + d.weight * move;
          mMovingVelocity[set.first - mMovingBegin + k] = d.rate * move;
        }
      });
      continue;
    }
    set.pose = solid.pose();
    const Eigen::Matrix<Real, 3, 3> rotation = set.pose.rotation.cast<Real>();
    const Vec3r translation = set.pose.translation.cast<Real>();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 4096), [&](const auto& range) {
      for (std::size_t k = range.begin(); k != range.end(); ++k) {
        const Vec3r x = rotation * set.reference[k] + translation;
        mSamples[set.first + k] = x;
        mMovingVelocity[set.first - mMovingBegin + k] = solid.velocityAt(x);
      }
    });
  }
}

namespace {
/// The lattice indices i with |s_i - s| <= reach (s_i = -half + 2 half i / intervals),
/// clamped to [first, last], widened by a rounding margin; false if none.
bool latticeRange(Real s, Real reach, Real half, long intervals, long first, long last, long& lo, long& hi) {
  const Real scale = Real(intervals) / (2 * half);
  constexpr Real kMargin = Real(1e-3);  // in lattice steps: the exact distance test decides
  lo = std::max(first, static_cast<long>(std::ceil((s - reach + half) * scale - kMargin)));
  hi = std::min(last, static_cast<long>(std::floor((s + reach + half) * scale + kMargin)));
  return lo <= hi;
}
} // namespace

template <typename F>
void BoundaryParticles::forEachSampleWithin(const Vec3r& x, Real radius, std::uint64_t lattices, bool nearGrid,
                                            F&& visit) const {
  const Real radius2 = radius * radius;
  // The lattices whose bit is set, in order (every lattice past the bits' reach).
  const std::size_t latticeCount = mLattices.size();
  std::uint64_t pending = latticeCount >= Proximity::kMaxBits ? lattices
                                                              : lattices & ((std::uint64_t(1) << latticeCount) - 1);
  for (std::size_t l = 0; l < latticeCount; ++l) {
    if (l < Proximity::kMaxBits) {
      if (pending == 0) {
        l = Proximity::kMaxBits - 1;  // none left among the first 64
        continue;
      }
      l = std::size_t(__builtin_ctzll(pending));
      pending &= pending - 1;
    }
    const LatticeEntry& entry = mLattices[l];
    const SampleLattice& lattice = entry.lattice;
    const Vec3r relative = x - lattice.center;
    const Real height = relative.dot(entry.normal);
    if (std::abs(height) > radius) continue;
    // The disc of the ball in the lattice's plane.
    const Real reach = std::sqrt(std::max(Real(0), radius2 - height * height));
    long i0, i1, j0, j1;
    if (!latticeRange(relative.dot(lattice.axisU), reach, lattice.halfU, lattice.intervalsU, lattice.firstU,
                      lattice.lastU, i0, i1) ||
        !latticeRange(relative.dot(lattice.axisV), reach, lattice.halfV, lattice.intervalsV, lattice.firstV,
                      lattice.lastV, j0, j1))
      continue;
    // Positions from the lattice (the same arithmetic that stored them, so the
    // same floats) rather than from memory: no cache miss per row.
    for (long j = j0; j <= j1; ++j) {
      const std::uint32_t row = entry.first + static_cast<std::uint32_t>(lattice.offset(i0, j));
      for (long i = i0; i <= i1; ++i) {
        const Vec3r point = lattice.point(i, j);
        if (squaredDistance(x, point) <= radius2) visit(row + static_cast<std::uint32_t>(i - i0), point, entry.owner);
      }
    }
  }
  if (mGrid && nearGrid)
    mGrid->forEachWithin(x, radius, mSamples, [&](std::uint32_t k, const Vec3r& p) { visit(k, p, mOwners[k]); });
  for (const MovingSet& set : mMoving) {
    if (!set.grid) continue;
    if (set.interval != -1) {
      // A sample within radius now lies within radius + reach of its midpoint.
      set.grid->forEachWithin(x, radius + set.reach, set.middle, [&](std::uint32_t k, const Vec3r&) {
        if (squaredDistance(x, mSamples[set.first + k]) <= radius2)
          visit(set.first + k, mSamples[set.first + k], set.boundary);
      });
      continue;
    }
    // x in the solid's reference frame (a rigid motion keeps distances)
    const Vec3r local = (set.pose.rotation.transpose() * (x.cast<double>() - set.pose.translation)).cast<Real>();
    set.grid->forEachWithin(local, radius, set.reference, [&](std::uint32_t k, const Vec3r&) {
      visit(set.first + k, mSamples[set.first + k], set.boundary);
    });
  }
}

std::uint64_t BoundaryParticles::boundariesNear(const Vec3r& x) const {
  if (!mProximity) return ~std::uint64_t(0);
  std::uint64_t lattices = 0, boundaries = 0;
  mProximity->lookup(x, lattices, boundaries);
  if (mProximity->boundaryCount > Proximity::kMaxBits) boundaries = ~std::uint64_t(0);
  return boundaries;
}

Real BoundaryParticles::proximityReach() const {
  return mProximity ? std::max(2 * mProximity->mirrorRange, mProximity->sampleRadius) : Real(0);
}

std::vector<std::size_t> BoundaryParticles::samplesPerBoundary(std::size_t boundaryCount) const {
  std::vector<std::size_t> counts(boundaryCount, 0);
  for (std::uint32_t owner : mOwners)
    if (owner < boundaryCount) ++counts[owner];
  return counts;
}

void addJunctionMaps(const Vec3r& x, Real mirrorRange, const std::vector<BoundaryPtr>& boundaries,
                     std::vector<MirrorMap>& maps, std::size_t begin) {
  const std::size_t end = maps.size();
  bool twoSolids = false;  // most particles with two maps are in a tank's edge
  for (std::size_t m = begin + 1; m < end && !twoSolids; ++m) twoSolids = maps[m].boundary != maps[begin].boundary;
  if (!twoSolids) return;
  const Real probe = Real(0.1) * mirrorRange;
  using Matrix = Eigen::Matrix<Real, 3, 3>;
  constexpr Real kRightAngle = Real(0.1);  // |cos| of the planes' angle
  for (std::size_t a = begin; a < end; ++a)
    for (std::size_t b = a + 1; b < end; ++b) {
      const MirrorMap& first = maps[a];
      const MirrorMap& second = maps[b];
      if (first.boundary == second.boundary || (first.frontOnly && second.frontOnly)) continue;
      // (I - L) / 2 projects on a map's reflected normals (mutually at right angles).
      const Matrix pa = Real(0.5) * (Matrix::Identity() - first.linear);
      const Matrix pb = Real(0.5) * (Matrix::Identity() - second.linear);
      if ((pa * pb).cwiseAbs().maxCoeff() > kRightAngle) continue;
      const Vec3r footA = Real(0.5) * (x + first.apply(x)), footB = Real(0.5) * (x + second.apply(x));
      const Vec3r towardA = x - footA, towardB = x - footB;
      const Real la = towardA.norm(), lb = towardB.norm();
      if (!(la > 0) || !(lb > 0)) continue;
      const Vec3r corner = footA + footB - x, da = (probe / la) * towardA, db = (probe / lb) * towardB;
      if (!boundaries[first.boundary]->isInsideNear(corner - da + db, 2 * probe) ||
          !boundaries[second.boundary]->isInsideNear(corner + da - db, 2 * probe))
        continue;
      MirrorMap map = second.after(first);
      map.frontOnly = first.frontOnly || second.frontOnly;
      if (map.frontOnly) {
        const bool isFirst = first.frontOnly;
        map.frontNormal = (isFirst ? towardA / la : towardB / lb);
        map.frontDistance = map.frontNormal.dot(isFirst ? footA : footB);
      }
      maps.push_back(map);  // after `first` and `second` are last read
    }
}

void BoundaryParticles::update(const Particles& particles, const std::vector<BoundaryPtr>& boundaries,
                               Real sampleRadius, Real mirrorRange, bool withSamples,
                               bool withMirrors) {
  const std::size_t n = particles.size();
  // Fixed chunks (deterministic output order), small enough to balance two
  // threads on a few thousand particles; their buffers persist across steps.
  constexpr std::size_t kChunk = 256;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<ChunkOut>& out = mChunks;
  if (out.size() < chunks) out.resize(chunks);
  for (std::size_t c = 0; c < chunks; ++c) {
    out[c].maps.clear();
    out[c].samples.clear();
    out[c].positions.clear();
    out[c].owners.clear();
  }
  mMirrorOffsets.resize(n + 1);
  mSampleNeighbors.offsets.resize(n + 1);
  placeMovingSamples(boundaries);
  const bool samples = withSamples && !mSamples.empty();
  const std::uint32_t boundaryCount = static_cast<std::uint32_t>(boundaries.size());
  if (!mProximity || mProximity->sampleRadius != sampleRadius || mProximity->mirrorRange != mirrorRange ||
      mProximity->boundaryCount != boundaries.size() || mProximity->latticeCount != mLattices.size())
    makeProximity(boundaries, sampleRadius, mirrorRange);
  const Proximity& proximity = *mProximity;

  // Pass 1: per chunk, the maps and sample indices, and per particle their counts
  // (stored temporarily in the offset arrays at i + 1).
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    ChunkOut& chunk = out[c];
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    for (std::size_t i = c * kChunk; i < end; ++i) {
      const Vec3r& x = particles.position[i];
      const std::size_t mapsBefore = chunk.maps.size(), samplesBefore = chunk.samples.size();
      std::uint64_t nearLattices = 0, nearBoundaries = 0;
      proximity.lookup(x, nearLattices, nearBoundaries);
      if (withMirrors)
        for (std::uint32_t b = 0; b < boundaryCount; ++b)
          if (b >= Proximity::kMaxBits || ((nearBoundaries >> b) & 1u)) boundaries[b]->mirrorMaps(x, mirrorRange, b, chunk.maps);
      if (chunk.maps.size() - mapsBefore >= 2) addJunctionMaps(x, mirrorRange, boundaries, chunk.maps, mapsBefore);
      if (samples)
        forEachSampleWithin(x, sampleRadius, nearLattices, (nearBoundaries & mGridBoundaries) != 0,
                            [&](std::uint32_t k, const Vec3r& position, std::uint32_t owner) {
                              chunk.samples.push_back(k);
                              chunk.positions.push_back(position);
                              chunk.owners.push_back(owner);
                            });
      mMirrorOffsets[i + 1] = static_cast<std::uint32_t>(chunk.maps.size() - mapsBefore);
      mSampleNeighbors.offsets[i + 1] = static_cast<std::uint32_t>(chunk.samples.size() - samplesBefore);
    }
  });
  // Chunk bases (serial over chunks, in order: deterministic).
  std::size_t mapTotal = 0, sampleTotal = 0;
  for (std::size_t c = 0; c < chunks; ++c) {
    ChunkOut& chunk = out[c];
    chunk.mapBase = mapTotal;
    chunk.sampleBase = sampleTotal;
    mapTotal += chunk.maps.size();
    sampleTotal += chunk.samples.size();
  }
  mMirrors.resize(mapTotal);
  mSampleNeighbors.indices.resize(sampleTotal);
  mEntryPositions.resize(sampleTotal);
  mEntryOwners.resize(sampleTotal);
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
    std::copy(chunk.positions.begin(), chunk.positions.end(), mEntryPositions.begin() + chunk.sampleBase);
    std::copy(chunk.owners.begin(), chunk.owners.end(), mEntryOwners.begin() + chunk.sampleBase);
  });
  // The layer: per chunk its members, then placed in order.
  std::vector<std::uint32_t> layerStart(chunks + 1, 0);
  const auto inLayer = [&](std::size_t i) {
    return mMirrorOffsets[i + 1] > mMirrorOffsets[i] || mSampleNeighbors.offsets[i + 1] > mSampleNeighbors.offsets[i];
  };
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    std::uint32_t members = 0;
    for (std::size_t i = c * kChunk, end = std::min(n, (c + 1) * kChunk); i < end; ++i) members += inLayer(i) ? 1u : 0u;
    layerStart[c + 1] = members;
  });
  for (std::size_t c = 0; c < chunks; ++c) layerStart[c + 1] += layerStart[c];
  mLayer.resize(layerStart[chunks]);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    std::uint32_t next = layerStart[c];
    for (std::size_t i = c * kChunk, end = std::min(n, (c + 1) * kChunk); i < end; ++i)
      if (inLayer(i)) mLayer[next++] = static_cast<std::uint32_t>(i);
  });
}

} // namespace cascade
