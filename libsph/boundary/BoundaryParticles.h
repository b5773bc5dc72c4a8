/// @file BoundaryParticles.h
/// @brief The virtual boundary particles of one time step (SEED section 2.2),
///        built by the Simulation and read by every pass of the step:
///        - type I: the static surface samples of every boundary (sampled once
///          with no gap above sampleGap * r0), with for each fluid particle the
///          samples within a query radius (r0 for WCSPH; compressed rows).
///          Samples on flat walls are kept as lattices and found from the
///          particle's coordinates in the wall's plane; the others (meshes)
///          through a cell grid;
///          A moving solid's samples are kept in its reference frame with a
///          grid of their own (made once, never re-sampled for a rigid motion):
///          each step they are placed by the solid's pose (positions and
///          velocities), and a particle's query is turned into the solid's frame.
///          A deforming solid's are made when it enters a frame interval, at the
///          interval's start and end, and placed each step by interpolation;
///        - type II: for each fluid particle within kappa h of a boundary the
///          mirror maps it sees (compressed rows); its mirror particles are the
///          images of itself and of its fluid neighbours under those maps that
///          fall within h ("rebuilt each step").
/// Only the boundary layer is touched: `layer` lists the fluid particles that
/// have any sample or mirror, so the boundary passes skip the bulk. A coarse
/// proximity grid over the static solids tells each particle which lattices and
/// solids can be within reach, so update() asks only those (same lists as asking all).
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/Particles.h"
#include "libsph/boundary/Boundary.h"

#include <limits>
#include <memory>
#include <vector>

namespace cascade {

/// Type II maps across a junction of two solids (a paddle standing on a tank's floor
/// or beside its wall, a tower on the floor). Each solid mirrors only itself; a tank
/// adds its own edges' and corners' products (SEED section 2.2 over a box), but where
/// two solids meet at right angles a particle in the corner had no images across both,
/// so its kernel sums lacked that quadrant and its pressure pushed it into the junction
/// (a flume's paddle: into the gap beside it, and through it). For each pair of the
/// particle's maps from two solids whose planes are at right angles (within 6 degrees),
/// the product is added when the solids do meet there: just behind each plane, beside
/// the other, lies inside its solid (probed a tenth of the mirror range from the
/// corner, so a gap narrower than that, as a paddle's clearance, counts as closed).
/// The image is attributed to the later solid (an obstacle after the tank) and, with a
/// front-only factor (a mesh's), images only the sources in front of that factor's plane.
/// Appended to `maps`, where the maps of the particle at x begin at `begin`
/// (BoundaryParticles::update calls it for every particle).
void addJunctionMaps(const Vec3r& x, Real mirrorRange, const std::vector<BoundaryPtr>& boundaries,
                     std::vector<MirrorMap>& maps, std::size_t begin);

class BoundaryParticles {
public:
  BoundaryParticles();
  ~BoundaryParticles();
  BoundaryParticles(BoundaryParticles&&) noexcept;
  BoundaryParticles& operator=(BoundaryParticles&&) noexcept;

  /// Samples the boundaries' surfaces (type I) and indexes the samples for
  /// queries of radius up to sampleRadius (WCSPH: r0 of SEED (11)).
  void sample(const std::vector<BoundaryPtr>& boundaries, Real maxGap, Real sampleRadius);

  /// Places the moving solids' samples at their poses this step (positions and
  /// velocities); update() calls it, a caller that moved solids without a step may too.
  void placeMovingSamples(const std::vector<BoundaryPtr>& boundaries);

  /// Rebuilds the per-particle sample lists (samples within sampleRadius) and
  /// the mirror maps (boundaries within mirrorRange = kappa h) for this step.
  void update(const Particles& particles, const std::vector<BoundaryPtr>& boundaries,
              Real sampleRadius, Real mirrorRange, bool withSamples, bool withMirrors);

  // --- type I ---
  /// All samples: the flat walls' lattices row by row, then the other
  /// samples (meshes) in the order of the sample grid's cells.
  const std::vector<Vec3r>& samplePositions() const { return mSamples; }
  const std::vector<std::uint32_t>& sampleOwners() const { return mOwners; }  ///< boundary index per sample
  /// Velocity of sample k (zero for the samples of solids at rest).
  Vec3r sampleVelocity(std::uint32_t k) const {
    return k >= mMovingBegin ? mMovingVelocity[k - mMovingBegin] : Vec3r::Zero();
  }
  /// For fluid particle i: samples within sampleRadius (indices into samplePositions()).
  const NeighborLists& sampleNeighbors() const { return mSampleNeighbors; }
  /// The position and owner of the sample at each entry of sampleNeighbors().indices,
  /// kept with the lists (the passes read them in list order, not from the large arrays).
  const std::vector<Vec3r>& sampleNeighborPositions() const { return mEntryPositions; }
  const std::vector<std::uint32_t>& sampleNeighborOwners() const { return mEntryOwners; }

  // --- type II ---
  /// Mirror maps of fluid particle i: mirrors()[mirrorOffsets()[i] .. mirrorOffsets()[i+1]).
  const std::vector<std::uint32_t>& mirrorOffsets() const { return mMirrorOffsets; }
  const std::vector<MirrorMap>& mirrors() const { return mMirrors; }
  std::uint32_t mirrorCount(std::size_t i) const { return mMirrorOffsets[i + 1] - mMirrorOffsets[i]; }

  /// Fluid particles with any sample or mirror this step, ascending.
  const std::vector<std::uint32_t>& layer() const { return mLayer; }

  /// Bit b set: boundary b's surface may lie within proximityReach() of x (moving
  /// solids, unbounded planes and open tanks everywhere; every bit for boundaries past
  /// 64, or before the first update()). A clear bit is certain: farther than that.
  std::uint64_t boundariesNear(const Vec3r& x) const;
  /// The reach of boundariesNear(), m (the last update()'s).
  Real proximityReach() const;

  std::size_t sampleCount() const { return mSamples.size(); }
  /// The largest gap the samples were made with (sample()'s maxGap), m.
  Real sampleGap() const { return mGap; }
  /// Type I samples per boundary.
  std::vector<std::size_t> samplesPerBoundary(std::size_t boundaryCount) const;
  /// Whether boundary b's samples are made afresh during the run (a deforming solid's,
  /// at each frame interval): there they jump, where a rigid motion moves them smoothly.
  bool resamples(std::uint32_t b) const {
    for (const MovingSet& set : mMoving)
      if (set.boundary == b) return set.interval != -1;
    return false;
  }

private:
  /// Calls visit(k, position, owner) for every type I sample k within radius of x;
  /// lattices only those whose bit is set in `lattices`, the mesh samples' grid only if `nearGrid`.
  template <typename F>
  void forEachSampleWithin(const Vec3r& x, Real radius, std::uint64_t lattices, bool nearGrid, F&& visit) const;

  /// Which lattices and boundaries can matter to a point (made by update() for its radii).
  struct Proximity;
  void makeProximity(const std::vector<BoundaryPtr>& boundaries, Real sampleRadius, Real mirrorRange);
  std::unique_ptr<Proximity> mProximity;

  struct LatticeEntry {
    SampleLattice lattice;
    Vec3r normal = Vec3r::UnitZ();
    std::uint32_t first = 0;  ///< index of its first point in mSamples
    std::uint32_t owner = 0;  ///< its boundary
  };
  struct Grid;
  std::vector<LatticeEntry> mLattices;
  /// The samples of one moving solid at mSamples[first ..), placed each step: a rigid
  /// one's reference positions (in its grid's cell order); a deforming one's positions
  /// at its frame interval's start (`reference`) and end, indexed by a grid over their
  /// midpoints whose queries reach `reach` (half the farthest move) further.
  struct MovingSet {
    std::uint32_t boundary = 0, first = 0;
    std::vector<Vec3r> reference;
    std::shared_ptr<Grid> grid;
    RigidPose pose;
    long interval = -1;  ///< the deforming solid's frame interval the samples are made for (-1: rigid)
    std::vector<Vec3r> end, middle;
    Real reach = 0;
  };
  /// Makes a deforming solid's samples for its current frame interval.
  void sampleDeforming(MovingSet& set, const Boundary& solid) const;
  /// Lays the moving sets' samples out after the static ones, in order.
  void layOutMovingSamples();
  Real mSampleRadius = 0;
  std::vector<MovingSet> mMoving;
  std::uint32_t mMovingBegin = std::numeric_limits<std::uint32_t>::max();
  std::vector<Vec3r> mMovingVelocity;
  std::vector<Vec3r> mSamples;
  std::vector<std::uint32_t> mOwners;
  /// Bits of the boundaries whose samples are in mGrid (all bits past 64 boundaries).
  std::uint64_t mGridBoundaries = 0;
  Real mGap = 0;
  NeighborLists mSampleNeighbors;
  std::vector<Vec3r> mEntryPositions;
  std::vector<std::uint32_t> mEntryOwners;
  std::vector<std::uint32_t> mMirrorOffsets{0};
  std::vector<MirrorMap> mMirrors;
  std::vector<std::uint32_t> mLayer;
  struct ChunkOut {  ///< update()'s per-chunk output
    std::vector<MirrorMap> maps;
    std::vector<std::uint32_t> samples, owners;
    std::vector<Vec3r> positions;
    std::size_t mapBase = 0, sampleBase = 0;
  };
  std::vector<ChunkOut> mChunks;
  std::unique_ptr<Grid> mGrid;
};

} // namespace cascade
