/// @file TimeStepDFSPH.h
/// @brief Divergence-free SPH (Bender & Koschier 2015, "Divergence-free smoothed
///        particle hydrodynamics"; 2017, "Divergence-free SPH for incompressible
///        and viscous fluids", TVCG 23(3)): an implicit pressure solver that
///        keeps both the density (constant-density solve) and the velocity
///        divergence (divergence-free solve) at rest values to a tolerance.
///
/// Each step, with the neighbour lists of the Simulation (x at time t):
///   1. one pass over the pairs (prepare): density rho_i = rho_0 (V W_ii + sum_j V W_ij)
///      over fluid and mirror neighbours (B&K 2017 eq. 5 in volume form; cubic spline
///      kernel, V the rest volume of the initial lattice), the factor alpha_i = 1 / D_i
///      with D_i = |sum_j V grad W_ij|^2 + sum_j |V grad W_ij|^2 (B&K 2017 eq. 10); with
///      mirrors D_i is the exact diagonal of the solves' operator: i's own images move
///      with it, and kappa_i reaches each neighbour j both by the pair and by j's images
///      of i, which i sees again through its images of j (eq. 10 alone is up to 1.57 x
///      too small there, measured), the pair terms
///      V grad W_ij kept for the solves (neighbours with grad W = 0 dropped, one 16-byte
///      stream; the AVX2 pass, eight neighbours at a time, keeps them with a zero gradient),
///      the density change rate of the initial velocities, and the non-pressure
///      accelerations of the initial velocities: gravity, viscosity (Morris 1997 form with
///      nu = mu / rho_0) and Monaghan (1992) artificial viscosity alpha h c_ref with
///      c_ref = 10 x the expected speed (the default WCSPH's speed of sound), both with the
///      rest volume V and over the mirror particles too (image velocity: a no-slip wall
///      exerts friction);
///   2. divergence-free solve (B&K 2017 alg. 2): kappa^v_i = (D rho_i/Dt / rho_0) alpha_i / dt,
///      v_i -= dt sum_j V (kappa_i + kappa_j) grad W_ij, until the mean predicted
///      density change of one step is below divergenceTolerance;
///   3. v += dt a (the accelerations of step 1);
///   4. constant-density solve (B&K 2017 alg. 3): with the predicted density
///      rho*_i = rho_i + dt D rho_i/Dt, the stiffness kappa >= 0 that removes the predicted
///      compression where there is pressure (kappa_i > 0 only where rho*_i would exceed
///      rho_0): a bound-constrained problem, solved by the primal-dual active set method with
///      Jacobi-scaled conjugate gradients (BoundConstrainedCG.h; with solver.preconditioner =
///      two_level, plus a coarse correction on cells of 2 h: CoarseCorrection.h), from the whole stiffness of
///      the last step; it stops when the mean compression is below densityTolerance and every
///      particle's below 20 % of it with two levels, 2 % with Jacobi alone (the mean alone is
///      diluted by depth: docs/dfsph-deep-water.md), at most maxIterations operator products;
///   5. x += dt v (symplectic Euler).
/// Each divergence-free Jacobi sweep, and each product of the density solve's operator, is
/// two passes over the pair terms: the velocity change of a stiffness vector
/// (v_i -= dt (s_i G_i + sum_j s_j V grad W_ij), G_i = sum_j V grad W_ij) and the density
/// rates it gives (fixed chunks: deterministic). The divergence solve starts from half the
/// stiffness the particle ended the previous step with where the velocity field compresses
/// (B&K 2017 section 4.1); both stiffnesses follow the particles through reorders, removals
/// and checkpoints. Reported pressure p_i = (kappa_i + kappa^v_i) rho_i^2 / rho_0 (from
/// a_i = -sum_j m (p_i / rho_i^2 + p_j / rho_j^2) grad W_ij); in resting water it is
/// hydrostatic step by step (a 200-layer column: floor within 1.2 % of rho g H).
///
/// Boundaries: the SEED's type II mirror particles (Libersky & Petschke 1993),
/// rebuilt each step by the Simulation for the fluid within kappa h of a wall,
/// as ghost neighbours that move with their source (velocity mirrored for free
/// slip, reversed for no slip) and share its stiffness, so the constraint holds
/// across walls (a flat wall completes the kernel support exactly; the same
/// model as WCSPH, so the two solvers differ only in the pressure). The force on
/// a solid is the impulse its mirror particles gave the fluid. The solves only
/// resist compression, so an under-dense surface particle could creep into a
/// wall: its velocity towards a wall it mirrors across is limited so that it
/// stays a quarter spacing off.
///
/// Wall friction: with BoundarySettings::slip = LaminarWallShear the mirrors are free
/// slip and, after step 3, the wall-adjacent layer feels the wall shear stress of an
/// unresolved laminar boundary layer (Stokes' first problem, WallShearStress.h), with
/// the boundary layer's age kept per particle. Symmetry planes (MirrorMap::symmetry)
/// are always free slip.
///
/// Time step (TimeStepNeeds): CFL on the velocity only, dt = cfl h / v_max (no
/// speed of sound), dt <= 0.06 sqrt(h / a_max) with a_max the largest
/// non-pressure acceleration, and dt <= 0.2 h / sqrt(kappa_max) (maxTimeStep(): a wall
/// particle and its own mirror image act as an explicit spring whose stiffness grows
/// with kappa, i.e. with depth). A step the Simulation shortened to land on a frame
/// (dt == maxTimeStep and less than half the last regular step) removes only its share
/// of the density error already there, keeps the warm starts, and reports the last
/// regular step's pressure and forces (with the half warm start of the earlier Jacobi
/// solve its own stiffness was not the water's pressure; kept so that frames report
/// regular steps).
/// Robustness: a step removes at most 1 % of a compression already there (so
/// overlapping particles part over several steps); alpha_i is 0 for a particle with nearly no neighbours (not 1/0);
/// the divergence solve skips particles with fewer than 20 neighbours (free
/// surface, B&K 2017); sums are taken in fixed chunks (bit-identical restarts).
#pragma once

#include "libsph/solver/BoundConstrainedCG.h"
#include "libsph/solver/CoarseCorrection.h"
#include "libsph/solver/HalfFloat.h"
#include "libsph/solver/TimeStep.h"

#include <vector>

namespace cascade {

/// Particle layers of resting water up to which DFSPH is measured to hold it still (a
/// 200-layer column at rest after 2 s, floor pressure within 1 % of rho g H;
/// docs/dfsph-deep-water.md). Deeper water has not been measured: `cascade bake` warns.
constexpr int kDfsphStillWaterLayers = 200;

/// Largest CFL factor (dt = cfl h / v_max, h the support radius: one spacing a step at
/// 0.5) DFSPH holds; a larger solver.cfl is used as this. Measured, a 10 m/s
/// jet into the 900-triangle bunny at 1 cm spacing (stress suite), where the velocity
/// CFL binds: 0.5 and below keep every particle out of the bunny (also at 15 and
/// 20 m/s); 0.6 lets 18 particles into it, 0.75 41, 1.0 45 (and the kinetic energy
/// rises to 1.65 x the stress bound), 2.0 166 (5.1 x): the mirror layer (kappa h = 2
/// spacings) and the wall limiter catch only particles that travel about a spacing a step.
constexpr Real kDfsphMaxCfl = Real(0.5);

class TimeStepDFSPH final : public TimeStep {
public:
  std::string name() const override { return "dfsph"; }
  TimeStepNeeds needs(const SimulationSettings& settings, const DerivedConstants& constants) const override;
  void advance(StepContext& context, Real dt) override;
  /// kStiffnessStepFactor h / sqrt(kappa_max) over the stiffness of the last step (TimeStepDFSPH.cpp).
  double maxTimeStep(const DerivedConstants& constants) const override;

  void permute(const std::vector<std::size_t>& order) override;
  void removeIf(const std::vector<char>& remove) override;
  void resize(std::size_t count) override;
  std::size_t stateWidth() const override { return 3; }
  void packState(std::size_t i, Real* out) const override;
  void unpackState(std::size_t i, const Real* in) override;
  void save(std::ostream& out) const override;
  void restore(std::istream& in) override;

  /// What the last step's solves did.
  struct Statistics {
    int densityIterations = 0;       ///< constant-density solve
    int divergenceIterations = 0;    ///< divergence-free solve
    double densityError = 0;         ///< mean predicted (rho* - rho_0) / rho_0 at the end (compression only)
    double divergenceError = 0;      ///< mean predicted density change of one step from divergence, relative
  };
  const Statistics& lastStatistics() const { return mStatistics; }

  /// Checks of the solves' operator, valid after a step (its pair terms): the
  /// density rate of particle i per unit stiffness increment of i alone, over -dt
  /// (the diagonal as the sweeps apply it: O(n) per call), and the factor
  /// alpha_i the sweeps divide by (1 / that diagonal; 0 for a lone particle).
  Real operatorDiagonal(std::size_t i) const { return operatorEntry(i, i); }
  /// The density rate of particle i per unit stiffness increment of particle j alone, over -dt.
  Real operatorEntry(std::size_t i, std::size_t j) const;
  Real factor(std::size_t i) const { return i < mFactor.size() ? mFactor[i] : Real(0); }

private:
  void prepare(StepContext& context);
  void applyWallShear(StepContext& context, Real dt);
  void applyStep(std::vector<Vec3r>& velocity, std::vector<Real>& kappa, Real dt);
  Real densityRate(const std::vector<Vec3r>& velocity, std::size_t i) const;
  Real divergence(const std::vector<Vec3r>& velocity, std::size_t i) const;
  template <typename Residual>
  BoundConstrainedResult solveOneSided(std::vector<Vec3r>& velocity, std::vector<Real>& kappa, Real dt,
                                       Residual&& residual, double tolerance, double particleTolerance, double share,
                                       int maxProducts,
                                       double& meanCompression);
  /// sum_j (s_i + s_j) V grad W_ij over fluid and mirror neighbours (the velocity change is -dt x this).
  Vec3r velocityChange(const Real* step, std::size_t i) const;
  /// Over MPI ranks: the owners' values into the halo copies after the owned particles.
  void shareWithHalo(Real* values) const;
  void shareWithHalo(Vec3r* values) const;
  /// A value summed over the ranks (itself in one process).
  double overRanks(double local) const;
  /// Sum of f(i) over [0, n): in fixed chunks, or over every rank's particles with the
  /// same bits for any split (reproducibleSum) when the step runs over MPI ranks.
  template <typename F>
  double sumOf(std::size_t n, F&& f);
  std::vector<double> mTerms;

  // Over MPI ranks (StepContext::partition), for the step being taken.
  DomainPartition* mPartition = nullptr;
  std::size_t mOwned = 0;    ///< the owned particles, [0, mOwned)
  double mGlobalCount = 1;   ///< owned particles over all ranks

  // State (follows the particles, saved in checkpoints): warm starts, m^2/s^2.
  std::vector<Real> mDensityKappa, mDivergenceKappa;
  double mRegularStep = 0;  // s, the last step not shortened to land on a frame time
  std::vector<Real> mWallAge;  // s each particle has been within one spacing of a wall (wall shear)

  // Per-step scratch.
  std::vector<Real> mFactor, mKappaStep, mDensityRatio, mRate;
  std::vector<double> mScaling, mSolution, mGradient;  // the constant-density solve's scaled problem
  std::vector<Vec3r> mChange;                          // velocity change of a stiffness vector
  /// One neighbour j strictly inside the support and V grad W_ij as three IEEE halves
  /// (HalfFloat.h): 10 bytes, one stream for the solves, which read it twice per operator
  /// product. Every use of the pair (the density rate, G_i, the solves' diagonal, the
  /// coarse operator) takes the rounded gradient, so the solve's operator is exactly
  /// D G of these values; rounding keeps g_ji = -g_ij. Why: docs/dfsph-deep-water.md,
  /// "Half-precision pair gradients".
#pragma pack(push, 1)
  struct PairTerm {
    std::uint32_t neighbor;
    std::uint16_t gradient[3];
    Vec3r value() const { return Vec3r(floatFromHalf(gradient[0]), floatFromHalf(gradient[1]), floatFromHalf(gradient[2])); }
  };
#pragma pack(pop)
  std::vector<PairTerm> mPairs;  // row i at mPairOffsets[i], mPairCount[i] used; one record of padding
  std::vector<std::uint32_t> mRowOffsets;  // row i's room: its neighbour list's length, rows in particle order
  bool mHalfInstructions = false;  // F16C (with AVX2): the products convert 4 halves an instruction
  const std::uint32_t* mPairOffsets = nullptr;
  const Vec3r* mPosition = nullptr;  // the particles' positions during the step
  Real mSupportRadius = 0;
  bool mTwoLevel = false;       // SolverSettings::twoLevelPreconditioner
  CoarseCorrection mCoarse;     // the constant-density solve's two-level preconditioner
  std::vector<std::uint32_t> mPairCount, mNeighborCount;
  std::vector<Vec3r> mGradientSum;            // G_i = sum_j V grad W_ij over fluid and mirror neighbours
  // Mirror (ghost) pairs of the boundary layer: compressed rows over layer().
  std::vector<std::uint32_t> mLayerIndex, mGhostOffsets, mGhostSource, mGhostMap;
  std::vector<Vec3r> mGhostGradient, mGhostVelocityGradient;  // G, and L^T G for the image's velocity L v_j
  std::vector<Real> mGhostValue;
  std::vector<Vec3r> mGhostOffset;  // x_i - x_image
  // Per layer particle: sum over its ghosts of w_g . G_g, the part of the images' velocity
  // that a moving wall adds (w_g = (I - L) w free slip, 2 w no slip; 0 for walls at rest).
  std::vector<Real> mWallRate;
  std::vector<Vec3r> mGhostViscous;  // the viscous acceleration each ghost gives its particle (a wall force)
  // Rest volume of one particle: 1 / (sum of W over the initial lattice).
  Real mRestVolume = 0, mFactorFloor = 0, mLatticeSupport = 0;
  Statistics mStatistics;
};

} // namespace cascade
