/// @file WhitewaterSolver.h
/// @brief One frame interval of whitewater (Ihmsen, Akinci, Akinci & Teschner
///        2012): births from the fluid's potentials, classification by fluid
///        neighbour count, advection, foam dissolving and removal outside the
///        domain, in sub-steps over the interpolated fluid (FluidInterval).
///
/// Per sub-step [t, t + dt]:
///  1. the fluid at t (FluidInterval::at) into a uniform grid of cell h;
///  2. each diffuse particle's fluid neighbours within h: their count gives its
///     type (spray, foam, bubble; sec. 5) and their W-weighted mean velocity
///     the v_f it is carried by;
///  3. advection by type (DiffuseAdvection.h), age += dt;
///  4. foam older than its lifetime (each particle draws one, uniform in the
///     lifetime range, from its id) dissolves; particles outside the domain go;
///  5. births (sec. 4, eqs. 7-9): the caches give the rates at frame times
///     only, so a fluid particle's birth rate n_i in the sub-step is that of
///     the frames blended linearly in time, each frame's rate taken
///     - where the source stays (a cell with a rate at both frames, as at the
///       foot of a slope or an impact): from the place the particle passes at
///       the sub-step's middle (BirthRateField.h), so every particle that
///       passes gives birth there and the stream it feeds is even;
///     - where the source moves with the water (a rate at one frame only):
///       from the particle that had it, along its path, as in the paper.
///     A particle makes n_i dt particles on average (the fraction by a random
///     draw), placed uniformly in the cylinder of radius r_V (half a spacing)
///     around its path x_i(t) + s v_i dt, s in [0, 1], with its velocity.
/// Every random number is a hash of (seed, fluid particle id, frame, sub-step,
/// birth), never a running generator, and births are numbered in fluid order,
/// so a run is the same whatever the thread count and wherever it resumes.
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/scene/Scene.h"
#include "libsph/search/UniformGridSearch.h"
#include "whitewater/BirthRateField.h"
#include "whitewater/DiffuseParticles.h"
#include "whitewater/FluidSampling.h"
#include "whitewater/FluidInterval.h"

#include <cstdint>
#include <vector>

namespace cascade::whitewater {

/// An axis-aligned box; diffuse particles outside it are removed.
struct RemovalBox {
  Vec3r min{-1e30f, -1e30f, -1e30f}, max{1e30f, 1e30f, 1e30f};
  bool contains(const Vec3r& x) const {
    return x.x() >= min.x() && x.y() >= min.y() && x.z() >= min.z() && x.x() <= max.x() && x.y() <= max.y() &&
           x.z() <= max.z();
  }
};

/// What one interval did.
struct IntervalStats {
  int substeps = 0;
  std::size_t born = 0, dissolved = 0, left = 0;  ///< left: removed outside the domain
};

/// A frame's birth rates (birthRates()): per fluid particle, in the frame's
/// order, and as a field of cells (WhitewaterSolver::frameRates()).
struct FrameBirthRates {
  std::vector<float> rate;
  BirthRateField field;
};

class WhitewaterSolver {
public:
  /// `spacing`: the bake's particle spacing (h = 2 spacings, r_V = spacing / 2).
  WhitewaterSolver(const scene::WhitewaterSettings& settings, const Vec3r& gravity, double spacing,
                   const RemovalBox& domain);

  double supportRadius() const { return mH; }

  /// Sub-steps for an interval: the setting, or enough that the fastest fluid
  /// particle moves at most h per sub-step (1 to 64).
  int substepsFor(const FluidInterval& fluid) const;

  /// Advances `particles` (at fluid.t0()) to fluid.t1(). `atStart`, `atEnd`: the
  /// birth rates of the frames at t0 and t1 (frameRates()); `frame` the
  /// interval's first frame number (it keys the random draws); `nextId` is the
  /// next birth's id.
  IntervalStats advance(const FluidInterval& fluid, const FrameBirthRates& atStart, const FrameBirthRates& atEnd,
                        int frame, DiffuseParticles& particles, std::uint32_t& nextId);
  /// The same with `rates` per fluid particle of the interval at both ends.
  IntervalStats advance(const FluidInterval& fluid, const std::vector<float>& rates, int frame,
                        DiffuseParticles& particles, std::uint32_t& nextId);

  /// A frame's birth rates `rates` of its fluid particles at `positions` (the field's cells: a spacing).
  void frameRates(const std::vector<Vec3r>& positions, std::vector<float> rates, FrameBirthRates& out) const;

  /// The type of each particle among the fluid particles at `fluidPositions`.
  std::vector<DiffuseType> classify(const DiffuseParticles& particles, const std::vector<Vec3r>& fluidPositions);

  /// The foam lifetime particle `id` draws (s).
  double lifetime(std::uint32_t id) const;

private:
  void buildFluid(const std::vector<Vec3r>& fluidPositions);

  scene::WhitewaterSettings mSettings;
  Vec3r mGravity;
  Real mH, mRadius;
  RemovalBox mDomain;
  std::uint64_t mSeed;
  search::UniformGridSearch mGrid;
  std::vector<Vec3r> mFluidX, mFluidV;
  PlaceVelocities mPlaceV;           ///< mFluidV in the grid's place order
  std::vector<FluidSample> mSamples;  ///< the fluid around each diffuse particle
  std::vector<float> mRateNow;        ///< each fluid particle's birth rate in a sub-step
  std::vector<float> mMovingStart, mMovingEnd;  ///< rates of sources that move with the water
  std::vector<std::uint32_t> mSources;  ///< the fluid particles with a rate in a sub-step
};

} // namespace cascade::whitewater
