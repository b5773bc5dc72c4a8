/// @file TimeStep.h
/// @brief The interface of a time-step strategy (a solver named after its
///        method: TimeStepWCSPH, TimeStepDFSPH). The Simulation builds the
///        neighbour lists and the boundary particles once per step and hands
///        them to the strategy, which computes the fluid forces and advances
///        velocities and positions by dt.
#pragma once

#include "libsph/NeighborSearch.h"
#include "libsph/Particles.h"
#include "libsph/solver/SolverSettings.h"

#include <algorithm>
#include <iosfwd>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace cascade {

class BoundaryParticles;
class DomainPartition;

/// Wall-clock milliseconds spent per phase, summed over steps.
struct StepTimings {
  double neighbors = 0, density = 0, forces = 0, boundary = 0, integrate = 0;
  std::uint64_t steps = 0;
  double total() const { return neighbors + density + forces + boundary + integrate; }
};

/// Quantities derived once when the simulation starts (kept in checkpoints).
struct DerivedConstants {
  Real supportRadius = 0;      ///< h, m
  Real particleMass = 0;       ///< m, kg
  Real expectedSpeed = 0;      ///< m/s
  Real stiffness = 0;          ///< k of SEED (10), m^2/s^2
  Real speedOfSound = 0;       ///< sqrt(k), m/s
  Real repulsionStrength = 0;  ///< D of SEED (11), m^2/s^2
  Real repulsionRadius = 0;    ///< r0 of SEED (11), m
  /// 1 / C with C = -(1/3) sum_j V_j (x_j - x_i) . grad W_spiky(x_i - x_j) over the
  /// rest lattice (V_j = m / rho_0): the spiky gradient sums to C I, not I, on the
  /// lattice (C = 0.947 for h = 2 spacings), so grad p is under-estimated by C.
  /// Pressure forces are divided by C (computed once, like the particle mass).
  Real gradientCorrection = 1;
};

/// Everything a strategy reads and writes in one step.
struct StepContext {
  Particles& particles;
  const NeighborLists& neighbors;        ///< fluid neighbours within h, without self
  const BoundaryParticles& boundary;     ///< type I samples and type II mirrors of this step
  const SimulationSettings& settings;
  const DerivedConstants& constants;
  std::vector<Vec3r>& acceleration;      ///< scratch, one per particle
  /// out: force on each boundary by the fluid in this step, N: exactly minus the impulse
  /// the boundary gave the fluid over dt (action = reaction; what moves a rigid body)
  std::vector<Vec3d>& obstacleForce;
  /// out: the same as force probes report it (a strategy may smooth its solver's
  /// iteration noise: DFSPH's shortened steps report the last regular step's pressure)
  std::vector<Vec3d>& reportedObstacleForce;
  /// out: moment of that force about the world origin, sum x × F over the points the
  /// forces act at (a type I sample; a mirror's plane), N m (torque on moving solids).
  std::vector<Vec3d>& obstacleMoment;
  StepTimings& timings;
  double time = 0;                       ///< s, at the start of the step
  Real maxAcceleration = 0;              ///< out: largest |a| of the owned particles (force limit of dt)
  /// Over MPI ranks: the decomposition, and the count of owned particles; the ghosts
  /// after them are neighbours only (DomainPartition.h). Null: one process owns all.
  DomainPartition* partition = nullptr;
  std::size_t owned = std::numeric_limits<std::size_t>::max();
  /// Rigid bodies the water moves (two-way coupled) are in the scene.
  bool coupledBodies = false;
  /// The step's index (Simulation::stepCount() before it; checkpointed), for passes a
  /// strategy runs every few steps only.
  std::uint64_t step = 0;
  /// The particles whose forces and motion this step computes: [0, ownedCount()).
  std::size_t ownedCount() const { return std::min(owned, particles.size()); }
};

/// What a strategy needs the Simulation to prepare each step (the defaults
/// are the SEED's WCSPH needs).
struct TimeStepNeeds {
  /// CFL dt = cfl h / (c + v_max) with c = sqrt(k) (weakly compressible); false:
  /// dt = cfl h / v_max, no speed of sound (incompressible solvers, e.g. DFSPH).
  bool speedOfSoundInCfl = true;
  /// Type II mirror particles, if BoundarySettings enable them; false: never built.
  bool mirrorParticles = true;
  /// Type I samples even if BoundarySettings::repulsionParticles is off.
  bool alwaysSamples = false;
  /// Largest gap between type I samples, m (0: BoundarySettings::sampleGap * r0).
  Real sampleGap = 0;
  /// Radius of each fluid particle's type I sample list, m (0: r0 of SEED (11)).
  Real sampleRadius = 0;
  /// Force limit of the time step: dt <= forceStepFactor sqrt(h / a_max).
  Real forceStepFactor = Real(0.25);
  /// Damping limit of the time step, s: dt <= dampingStep (the method's explicit
  /// viscous terms; infinity: none beyond the viscous limit on the scene's viscosity).
  double dampingStep = std::numeric_limits<double>::infinity();
  /// Largest CFL factor the method holds; a larger SolverSettings::cflFactor is
  /// used as this (0: no cap).
  Real maxCflFactor = Real(0);
};

/// A particle the solids' guard (Simulation::keepOutOfSolids) put back out of a solid
/// after advance(): the velocity that would have made its actual move this step,
/// (x_end - x_start) / dt, which its velocity no longer tells.
struct GuardedMove {
  std::uint32_t index = 0;
  Vec3r displacementRate = Vec3r::Zero();
};

class TimeStep {
public:
  /// What this method needs prepared (called when the simulation starts).
  virtual TimeStepNeeds needs(const SimulationSettings&, const DerivedConstants&) const { return {}; }
  virtual ~TimeStep() = default;
  /// The method's name as used in scenes ("wcsph", "dfsph").
  virtual std::string name() const = 0;
  /// Computes forces and advances velocities and positions by dt.
  virtual void advance(StepContext& context, Real dt) = 0;
  /// Completes the step once the solids have moved and the guard has put particles back
  /// out of them (positions and velocities final; ghosts still present).
  virtual void finishStep(StepContext& /*context*/, Real /*dt*/, const std::vector<GuardedMove>& /*guarded*/) {}
  /// An extra upper bound on the next dt from the method's own state, s (infinity if none).
  virtual double maxTimeStep(const DerivedConstants&) const { return std::numeric_limits<double>::infinity(); }

  // Per-particle state a strategy keeps (e.g. warm starts) follows the particles:
  virtual void permute(const std::vector<std::size_t>& /*order*/) {}
  virtual void removeIf(const std::vector<char>& /*remove*/) {}
  virtual void resize(std::size_t /*count*/) {}
  /// The same state as Reals per particle, so that it travels with a particle between
  /// MPI ranks and into a checkpoint gathered from them: stateWidth() values each.
  virtual std::size_t stateWidth() const { return 0; }
  virtual void packState(std::size_t /*i*/, Real* /*out*/) const {}
  virtual void unpackState(std::size_t /*i*/, const Real* /*in*/) {}
  /// Exact binary save / restore of the strategy's own state.
  virtual void save(std::ostream& /*out*/) const {}
  virtual void restore(std::istream& /*in*/) {}
};

/// Creates the strategy for a solver type ("wcsph"; a new strategy adds one
/// line to makeTimeStep in TimeStep.cpp). Throws std::invalid_argument for an
/// unknown type.
std::unique_ptr<TimeStep> makeTimeStep(const std::string& type);
/// The types makeTimeStep accepts.
std::vector<std::string> timeStepTypes();

} // namespace cascade
