/// @file TimeStepWCSPH.h
/// @brief The SEED's weakly compressible SPH step (Mueller et al. 2003 with
///        the SEED's corrections):
///        density SEED (4), or the continuity equation with delta-SPH density
///        diffusion (SolverSettings::density); pressure from SEED (10) or Tait; pressure force
///        SEED (5); viscosity SEED (6) with the viscosity Laplacian (9);
///        optional Monaghan (1992) artificial viscosity; gravity and the
///        boundary forces (SEED (15)): type I repulsion SEED (11) and type II
///        mirror particles; symplectic Euler SEED (12)-(14).
///        SolverSettings select the kernel pair of density and pressure
///        gradient (the SEED's poly6 (7) / spiky (8), or one kernel for both:
///        cubic spline, Monaghan 1992; Wendland C2, Wendland 1995, the
///        default) and the pressure force (-m (p_i + p_j) / (rho_i rho_j) grad W;
///        the printed SEED (5) with 1/2; the Hamiltonian
///        -m (p_i / rho_i^2 + p_j / rho_j^2) grad W of Monaghan 1992, the default).
///        Each pair's density is scaled so that the rest lattice of the fluid
///        spacing has rho_0, and its gradient corrected by 1 / C (DerivedConstants).
///
/// Every pass is a TBB loop over the contiguous particle arrays, reading the
/// step's neighbour lists; the boundary passes only visit the boundary layer.
/// The pair loops read one 32-byte record per neighbour (position, pressure,
/// velocity, density) and, on processors with AVX2, take eight neighbours at
/// a time. A mirror map is a reflection or a product of reflections
/// (orthogonal), so the distance between particle i and the mirror image of j
/// equals the distance between the pre-image of i and j itself: the mirror
/// passes run the fluid loops with i's pre-image and turn the sum back
/// (Libersky & Petschke 1993 mirrors, evaluated in the mirror's frame).
#pragma once

#include "libsph/solver/TimeStep.h"

#include <cstdint>
#include <vector>

namespace cascade {

namespace wcsph {
/// One particle as the pair loops read it: one aligned record per neighbour.
struct alignas(32) PairInput {
  Real x, y, z, pressure;
  Real vx, vy, vz, density;
};
/// The density scale and gradient correction of the kernel pair on the rest
/// lattice (SolverSettings::kernels), derived once.
struct KernelNormalisation {
  bool valid = false;
  KernelPair pair = KernelPair::Mueller2003;
  Real supportRadius = 0, spacing = 0, particleMass = 0;  // what it was derived for
  /// rho_i = densityScale sum_j W_ij: rho_0 / (sum of W over the rest lattice),
  /// the particle mass for the SEED pair.
  Real densityScale = 0;
  /// 1 / C, C = -(1/3) sum_j m / rho_0 (x_i - x_j) . grad W_ij over the rest lattice.
  Real gradientCorrection = 1;
};
/// Scratch the passes keep between steps.
struct Workspace {
  std::vector<PairInput> particles;
  std::vector<Real> densityRate;  ///< drho/dt of the continuity density, kg/m^3/s
  /// Over ranks: the velocities the density rate reads, with the guarded particles' moves
  /// (integrateContinuityDensity), ghosts refreshed from their owners.
  std::vector<Vec3r> moveRate;
  KernelNormalisation normalisation;
  /// The mirror pairs of this step (computeFluidDensity, collectMirrorNeighbors): for
  /// mirror map m of a layer particle i (BoundaryParticles::mirrors()), those of i's
  /// neighbours j whose image under m lies within h of i (and, for a front-only map,
  /// in front of it), in list order, at
  /// mirrorNeighbors[mirrorBegin[m] .. mirrorBegin[m] + mirrorCount[m]).
  std::vector<std::uint32_t> mirrorBegin, mirrorCount, mirrorNeighbors;
  /// Per map: whether its passes sum around i's pre-image (an isometry over a half-space).
  std::vector<std::uint8_t> mirrorPreImage;
  /// The velocity filter's L(v) and L(L(v)) (addVelocityFilter), m/s.
  std::vector<Vec3r> velocityLaplacian, velocityBilaplacian;
  /// Its fluid pairs' kernel values, per neighbour-list entry, shared by its two passes.
  std::vector<Real> filterWeights;
  const std::uint32_t* mirrorList(std::size_t m) const { return mirrorNeighbors.data() + mirrorBegin[m]; }
};
} // namespace wcsph

/// The largest CFL factor (dt = cfl h / (c + v_max)) WCSPH holds; a larger solver.cfl is
/// used as this. Measured in the stress suite's 10 m/s jet into the 900-triangle bunny at
/// 1 cm: 0.5 and 0.6 stay within the energy bound; 0.75 and 1.0 gain energy (1.0: 20.3 J
/// against the bound of 19.0 J to the end, or a stop with exit 3 at t = 0.058 s, depending
/// on round-off), 2.0 stops. Energy gained without a stop is a silently wrong splash.
constexpr Real kWcsphMaxCfl = Real(0.6);

class TimeStepWCSPH final : public TimeStep {
public:
  std::string name() const override { return "wcsph"; }
  TimeStepNeeds needs(const SimulationSettings&, const DerivedConstants&) const override {
    TimeStepNeeds needs;
    needs.maxCflFactor = kWcsphMaxCfl;
    return needs;
  }
  void advance(StepContext& context, Real dt) override;
  /// Continuity density: integrated here, after the solids' guard, with each guarded
  /// particle's actual move (GuardedMove), so that the density sees every displacement.
  void finishStep(StepContext& context, Real dt, const std::vector<GuardedMove>& guarded) override;

private:
  wcsph::Workspace mWorkspace;
};

/// Shared passes (also usable by other strategies and benchmarks).
namespace wcsph {
/// Fills the positions and velocities of workspace.particles.
void gatherPairInputs(StepContext& context, Workspace& workspace);
/// SEED (4): rho_i = m (W(0) + sum_j W(x_ij)) over fluid neighbours and, for the
/// boundary layer, the type II mirror particles (images of i and its neighbours within
/// h), summed in the same pass over the neighbours; collects the mirror pairs as
/// collectMirrorNeighbors does. Fills the positions and velocities of workspace.particles.
void computeFluidDensity(StepContext& context, Workspace& workspace);
/// Continuity density (DensityEvolution::Continuity): workspace.densityRate =
/// sum_j m (v_i - v_j) . grad W_ij (Monaghan 1992, eq. 2.17) plus the delta-SPH diffusion
/// 2 delta h c_0 sum_j m / rho_j (rho_ij - rho0 g . x_ij / c_0^2) (x_ij . grad W_ij) / |x_ij|^2
/// (Molteni & Colagrossi 2009, with the hydrostatic part removed: Fourtakas et al. 2019),
/// over fluid pairs; then the mirror images' sum_j m (v_i - v'_j) . grad W(x_i - x'_j)
/// for the boundary layer (the images' kinematic velocity w + M (v_j - w)).
/// Reads positions, velocities and densities from workspace.particles.
void computeDensityRate(StepContext& context, Workspace& workspace);
/// After integrateSymplecticEuler: rho_i += dt drho_i/dt at the step's start positions
/// and the new velocities (the records' positions and densities, the particles'
/// velocities), or for a guarded particle (Simulation::keepOutOfSolids) the velocity of
/// its actual move: a particle put back out of a wall has not moved as its velocity says,
/// and a density that missed the difference would leave it packed against the wall with
/// nothing pushing it off (docs/solvers.md, "Gravity waves").
void integrateContinuityDensity(StepContext& context, Workspace& workspace, Real dt,
                                const std::vector<GuardedMove>& guarded = {});
/// The mirror pairs of the boundary layer (Workspace::mirrorNeighbors), from the
/// positions in workspace.particles: each mirror pass then visits the few neighbours
/// whose image is within h (a fifth of them on the production tower) instead of all.
/// The passes below read them; call it again whenever the positions or the maps change.
void collectMirrorNeighbors(StepContext& context, Workspace& workspace);
/// SEED (10) or Tait for every particle; fills the pressures and densities of
/// workspace.particles.
void computePressure(StepContext& context, Workspace& workspace);
/// Over MPI ranks (context.partition): the ghosts' densities and pressures from their
/// owners, into the particles and workspace.particles (computePressure calls it).
void refreshGhostPressure(StepContext& context, Workspace& workspace);
/// The bi-Laplacian velocity filter (SolverSettings::velocityFilter), added to the owned
/// particles' accelerations: a_i -= beta c_0 / h L(L(v))_i with
/// L(f)_i = sum_j m / rho_0 W_ij (f_j - f_i) over the fluid neighbours and the mirror
/// images (free slip). A fourth-order operator: it damps the particle-scale velocity (a
/// zigzag between neighbouring columns, which the kernel average hardly sees, so that
/// L(v) is about -v there) and leaves a harmonic field alone in the bulk (an isotropic
/// kernel's L and L^2 vanish on it to every order), so waves keep their energy. Pairs
/// are symmetric: momentum is kept up to the walls. What the mirror images add is not
/// reported as a force on the solids (context.obstacleForce): a moving wall's images
/// carry its velocity, so the filter acts between a paddle and the water unmeasured by
/// its force probe. Reads positions and velocities from workspace.particles and the
/// mirror pairs of this step. Applied on every K-th step (context.step) with K times the
/// strength, K = velocityFilterInterval(): the filter is slow next to a step (it takes
/// about beta cfl of a zigzag's velocity per step), so its cost falls K-fold for the
/// same damping.
void addVelocityFilter(StepContext& context, Workspace& workspace);
/// K of addVelocityFilter: the most steps (1-8) with K beta cfl <= 0.2.
int velocityFilterInterval(const SolverSettings& solver);
/// Fluid-fluid accelerations of the owned particles: SEED (5), (6), artificial viscosity, gravity.
void computeFluidAcceleration(StepContext& context, const Workspace& workspace);
/// Boundary layer: mirror pressure / viscosity and SEED (11) repulsion; fills
/// context.obstacleForce (N, force on each boundary by the fluid). With
/// timeStep > 0, a particle in the repulsion layers of two solids at once (a
/// wedge), or hitting one solid faster than the expected speed (up to a
/// quarter of the instability speed), gets from each solid at most the SEED (11)
/// push that stops and reflects its approach in one step (an elastic bounce, at
/// least half the expected speed out): the stiff r^-13 layers do not throw it
/// out (contact limiter, not in the SEED).
void addBoundaryAcceleration(StepContext& context, const Workspace& workspace, Real timeStep = 0);
/// Whether the pair loops may take eight neighbours at a time (AVX2, if the
/// processor has it; default) or must use the scalar loops (tests compare the
/// two). Returns whether the vector loops are used from now on.
bool allowVectorPairLoops(bool allowed);
/// Whether the vector force loop may run in its AVX-512VL build (32 registers, the
/// same bits; default, if the processor has it) or must use the AVX2 one (tests
/// compare the two). Returns whether the AVX-512VL build is used from now on.
bool allowAvx512PairLoops(bool allowed);
/// SEED (12)-(14): v += a dt, x += v dt. Returns the largest |a|.
Real integrateSymplecticEuler(StepContext& context, Real dt);
} // namespace wcsph

} // namespace cascade
