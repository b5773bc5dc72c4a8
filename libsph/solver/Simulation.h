/// @file Simulation.h
/// @brief One SPH simulation: the fluid particles, the boundaries, the
///        neighbour search and the time-step strategy; adaptive CFL time steps,
///        advancing to a given time, emitting and removing particles, the
///        instability check, and exact binary checkpoints.
///
/// Each step: (every reorderInterval steps, Morton reorder for locality) ->
/// neighbour lists once (reused by every pass) -> boundary particles of the
/// step (moving solids at their poses at the step's start) -> the strategy's
/// passes -> moving solids to the step's end (a prescribed motion, or a rigid
/// body under the step's fluid force and torque and gravity) -> the guard that
/// keeps particles out of solids -> domain removal and instability check.
/// The CFL speed includes the moving solids' fastest surface point.
/// dt = clamp(min(cflFactor h / (c + v_max), 0.125 h^2 / nu, 0.25 sqrt(h / a_max)),
/// minTimeStep, maxTimeStep) (Monaghan 1992; Becker & Teschner 2007).
///
/// Determinism: a run restored from save() and continued gives bit-identical
/// particles to one never stopped (all reductions that feed the state are
/// order independent or done in a fixed order).
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/Particles.h"
#include "libsph/boundary/Boundary.h"
#include "libsph/boundary/BoundaryParticles.h"
#include "libsph/io/TriangleMesh.h"
#include "libsph/solver/SolverSettings.h"
#include "libsph/solver/TimeStep.h"

#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

namespace cascade {

class DomainPartition;
class MovingBoundary;

class Simulation {
public:
  /// Throws InputError for invalid settings or an unknown solver type.
  explicit Simulation(const SimulationSettings& settings);
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  const SimulationSettings& settings() const { return mSettings; }

  // --- set-up (boundaries before the first step) ---
  /// Adds a boundary; returns its index (force attribution, probes).
  std::size_t addBoundary(BoundaryPtr boundary);
  std::size_t boundaryCount() const { return mBoundaries.size(); }
  const Boundary& boundary(std::size_t index) const { return *mBoundaries[index]; }
  /// Index of the boundary with this name, or -1.
  long findBoundary(const std::string& name) const;

  /// Adds one fluid particle (emitters too); returns its id.
  ParticleId addParticle(const Vec3r& position, const Vec3r& velocity);
  /// Fills [lo, hi] with particles on the lattice of the fluid spacing (first
  /// particle half a spacing inside each face); returns the number added.
  /// With SolverSettings::hydrostaticStart (WCSPH) and the box resting on a
  /// boundary, the lattice is compressed along gravity to the hydrostatic
  /// density when the simulation starts (the stiffness is known then).
  std::size_t addFluidBox(const Vec3r& lo, const Vec3r& hi, const Vec3r& velocity = Vec3r::Zero());

  // --- over MPI ranks ---
  /// Runs this simulation as one rank of a spatial decomposition (DomainPartition.h;
  /// WCSPH without rigid bodies). Set it before the first step, on every rank set up
  /// the same way with the whole scene: the start (or a restore) keeps this rank's
  /// share, particles added later are kept by their owner only, and each step adds
  /// and drops the ghosts, takes the same time step on every rank and migrates
  /// particles. Neighbour lists are sorted by particle id, so that the sums, and so
  /// the particles, are bit-identical whatever the rank count. Throws InputError
  /// for a solver or scene it cannot split. Not owned; must outlive the simulation.
  void setPartition(DomainPartition* partition);
  DomainPartition* partition() const { return mPartition; }
  /// The particles of every rank, sorted by id, on rank 0 (collective; empty on the
  /// other ranks). Without a partition, a copy of particles().
  Particles gatheredParticles() const;

  // --- running ---
  /// One adaptive step; returns dt (s).
  double step();
  /// Steps until time() == endTime (the last step shortened to land on it).
  void advanceTo(double endTime);
  /// The time step the next step() would take (starts the simulation if needed).
  double nextTimeStep();

  double time() const { return mTime; }
  std::uint64_t stepCount() const { return mStepCount; }
  double lastTimeStep() const { return mLastTimeStep; }

  // --- state ---
  const Particles& particles() const { return mParticles; }
  /// Mutable access for scene set-up and tests; do not change the count
  /// other than through addParticle() / addFluidBox().
  Particles& particles() { return mParticles; }
  /// Forgets the neighbour search's memory of earlier builds (the next build
  /// is a full one, as after restore()), so that a run restored from a
  /// checkpoint taken now continues bit-identically: the incremental grid
  /// rebuild orders points within a cell by history. The bake calls it at
  /// every checkpoint.
  void resetNeighborSearch();
  /// Removes the particles whose flag is true (scene kill regions);
  /// returns how many. Not counted in removedCount().
  std::size_t removeParticles(const std::vector<char>& remove);
  /// Particles removed because they left the domain, since the start.
  std::uint64_t removedCount() const { return mRemovedCount; }
  /// Times a step had carried a particle of the boundary layer into a solid and the
  /// guard put it back (keepOutOfSolids), in this run (not kept in checkpoints).
  std::uint64_t keptOutCount() const { return mKeptOutCount; }
  /// The derived constants (valid after the first step or nextTimeStep()).
  const DerivedConstants& constants() const { return mConstants; }
  Real supportRadius() const;
  Real particleMass() const;

  /// Force the fluid exerted on boundary `index` during the last step, N
  /// (type I repulsion and type II mirror pressure and viscosity), as force probes
  /// report it (StepContext::reportedObstacleForce).
  Vec3d obstacleForce(std::size_t index) const;
  /// The force exactly exchanged in the last step: minus the boundary's impulse on the
  /// fluid over dt (the guard's too); what moves a rigid body.
  Vec3d exchangedForce(std::size_t index) const;
  /// Its torque about `center` (world), N m.
  Vec3d obstacleTorque(std::size_t index, const Vec3d& center) const;

  // --- moving solids (libsph/bodies/MovingBoundary.h) ---
  /// True if any boundary moves.
  bool hasMovingSolids() const;
  /// True if any boundary is a rigid body the water moves (two-way coupled).
  bool hasCoupledBodies() const;
  /// The moving solid at `index`, or null if that boundary stands still.
  const MovingBoundary* movingSolid(std::size_t index) const;

  /// The type I particles (after the first step or nextTimeStep()).
  const BoundaryParticles& boundaryParticles() const { return mBoundaryParticles; }
  std::size_t boundaryParticleCount() const { return mBoundaryParticles.sampleCount(); }

  /// All solids as one mesh in world coordinates, one group per boundary (named
  /// after it); the bake writes it to OUT/geometry/solids.obj.
  TriangleMesh solidsMesh() const;

  /// Time per phase, summed since the start (or since resetTimings()).
  const StepTimings& timings() const { return mTimings; }
  void resetTimings() { mTimings = StepTimings(); }

  const TimeStep& timeStep() const { return *mTimeStep; }

  // --- checkpoints ---
  /// Writes the whole dynamic state (time, step count, ids, derived constants,
  /// particle arrays, strategy state) in binary. Settings and boundaries are
  /// not written: restore into a Simulation set up the same way. Over MPI ranks it
  /// is collective: rank 0 writes every rank's particles (sorted by id), the other
  /// ranks write nothing; a restore on any number of ranks keeps each one's share.
  void save(std::ostream& out) const;
  /// Restores what save() wrote; throws InputError("checkpoint: ...") if the
  /// data is truncated or from another set-up.
  void restore(std::istream& in);
  void save(const std::string& path) const;      ///< atomically
  void restore(const std::string& path);

private:
  void start();
  /// A fluid box waiting for its hydrostatic compression (particles [first, first + count)).
  struct FluidBoxRecord {
    std::size_t first = 0, count = 0;
  };
  /// The column of a box that starts hydrostatic (hydrostaticStart, WCSPH, resting on a
  /// boundary): its bottom height along -gravity and its depth; false otherwise.
  bool hydrostaticColumn(const FluidBoxRecord& box, Real& bottom, Real& depth) const;
  /// rho_0 / rho at hydrostatic depth d (the equation of state at p = rho_0 |g| d).
  Real hydrostaticInverseRatio(Real depth) const;
  void compressHydrostatically(const FluidBoxRecord& box);
  std::vector<FluidBoxRecord> mPendingBoxes;
  void reorder();
  void removeOutside();
  /// The guard for the owned particles [0, owned) of the step's boundary layer.
  void keepOutOfSolids(double dt, std::size_t owned);
  /// Moves the moving solids over the step just taken (dt, ending at mTime + dt).
  void moveSolids(double dt);
  /// Fastest surface speed of the moving solids now.
  double maxSolidSpeed() const;
  void checkStability() const;
  /// The instability message of this rank's first offending particle, or "".
  std::string stabilityMessage() const;
  /// Over MPI ranks: removes the particles this rank does not own.
  void keepOwned();
  /// Over MPI ranks: the regions from all particles (every rank holds them all), then keepOwned().
  void distribute();
  double computeTimeStep() const;

  SimulationSettings mSettings;
  DerivedConstants mConstants;
  Particles mParticles;
  std::vector<BoundaryPtr> mBoundaries;
  BoundaryParticles mBoundaryParticles;
  std::unique_ptr<NeighborSearch> mSearch;
  std::unique_ptr<TimeStep> mTimeStep;
  NeighborLists mNeighbors;
  std::vector<Vec3r> mAcceleration;
  std::vector<Vec3d> mObstacleForce, mReportedForce, mObstacleMoment;
  StepTimings mTimings;
  double mTime = 0, mLastTimeStep = 0;
  Real mLastMaxAcceleration = 0;
  std::uint64_t mStepCount = 0, mRemovedCount = 0, mKeptOutCount = 0;
  std::vector<Vec3r> mLayerStart;  // positions of the boundary layer at the step's start
  std::vector<GuardedMove> mGuardedMoves;  // this step's particles put back out of solids (keepOutOfSolids)
  ParticleId mNextId = 0;
  bool mStarted = false;
  DomainPartition* mPartition = nullptr;
  Vec3r mLatticeAnchor = Vec3r::Zero();  ///< over ranks: the canonical search lattice's origin
};

} // namespace cascade
