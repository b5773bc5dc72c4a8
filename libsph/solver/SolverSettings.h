/// @file SolverSettings.h
/// @brief The settings of a simulation as plain structs with documented
///        defaults: the fluid (SEED section 1), the time-step strategy and its
///        equation of state (SEED (10); Tait: Monaghan 1994, Becker & Teschner
///        2007), the adaptive CFL time step, and the two kinds of virtual
///        boundary particles (SEED section 2.2).
///
/// A value of 0 for a derived quantity (stiffness, repulsion strength,
/// repulsion radius, expected speed) means "derive it as documented" when
/// the simulation starts; the derived values are kept in checkpoints.
#pragma once

#include "libsph/Types.h"

#include <string>

namespace cascade {

/// The fluid (SEED section 1).
struct FluidSettings {
  /// Initial particle spacing, m. The particle mass is restDensity / (sum of
  /// poly6 over the cubic lattice of this spacing), about restDensity * spacing^3,
  /// so that a particle inside the initial lattice has exactly the rest density.
  Real spacing = Real(0.02);
  Real restDensity = Real(1000);    ///< rho_0, kg/m^3
  Real viscosity = Real(0);         ///< dynamic viscosity mu of SEED (6), Pa s; 0 skips the term
};

/// SEED (10) linear p = k (rho - rho_0), or Tait p = (rho_0 k / gamma) ((rho/rho_0)^gamma - 1).
/// With the same k both have the same speed of sound sqrt(k) at rest density.
enum class EquationOfState { Linear, Tait };

/// The pressure force of SEED (5).
enum class PressureForce {
  /// -m_j (p_i + p_j) / rho_j grad W: a consistent estimate of grad p in the
  /// bulk (sum_j m_j / rho_j grad W = 0 there), symmetric, so momentum is conserved.
  Symmetric,
  /// SEED (5) as printed (Mueller 2003): -m_j (p_i + p_j) / (2 rho_j) grad W. In
  /// the bulk it gives grad p / 2, so the pressure that holds water at rest is
  /// twice rho g d (the hydrostatic test fails by a factor 2).
  MuellerHalf,
  /// Monaghan (1992, 2005) symmetric (Hamiltonian) form
  /// -m_j (p_i / rho_i^2 + p_j / rho_j^2) grad W: the force that follows from
  /// the summation density by the variational principle, so with the density
  /// summed with the same kernel it conserves momentum and energy (the
  /// equilibrium is a minimum of the energy).
  Hamiltonian,
};

/// The kernels of the WCSPH density (SEED (4)) and pressure gradient (SEED (5)).
enum class KernelPair {
  /// The SEED's pair (Mueller 2003): poly6 density SEED (7), spiky gradient
  /// SEED (8). The two do not match: on the particle lattice about 10 % of the
  /// short waves change the poly6 density with the opposite sign of the spiky
  /// pressure response, and grow (about 137 /s in a still tank at 1 cm).
  Mueller2003,
  /// Cubic spline (Monaghan 1992) for both density and gradient.
  CubicSpline,
  /// Wendland C2 (Wendland 1995; Dehnen & Aly 2012) for both density and gradient.
  WendlandC2,
  /// Chosen when the simulation starts (Simulation::start): the cubic spline when a
  /// rigid body floats in the water (a dynamic solid), else Wendland C2. The
  /// resting Wendland C2 lattice is stable under pressure, which keeps still water
  /// still, but it also holds a floating body by a static shear: a cube released
  /// 1 cm off its draft at 1 cm spacing stayed 7-8 % off it. The cubic spline's
  /// lattice yields (docs/moving-solids.md, "Floating in WCSPH").
  Automatic,
};

/// How WCSPH gets each particle's density.
enum class DensityEvolution {
  /// Summed every step over the neighbours, SEED (4) (with the mirror particles).
  Summation,
  /// Integrated from the continuity equation, drho_i/dt = sum_j m (v_i - v_j) . grad W_ij
  /// (Monaghan 1992, eq. 2.17), mirrors included, plus the density diffusion term
  /// (SolverSettings::densityDiffusion). The free surface keeps rho_0 instead of the
  /// summation's deficit, so no surface-layer pressure is needed.
  Continuity,
};

/// WCSPH's support radius over the spacing. At 2 spacings the resting Wendland C2
/// lattice under pressure has a shear rigidity of the order of the pressure: water at
/// rest answers like a jelly, and the first sloshing mode of a 10 cm deep flume runs
/// 14-15 % short of its linear period at every spacing (1 cm to 2.5 mm) and amplitude.
/// The rigidity is gone from 2.15 spacings on (period within 1 %; docs/solvers.md,
/// "Gravity waves"), and floating bodies, held or free, come within 1 % of Archimedes.
constexpr double kWcsphSupportFactor = 2.15;
/// WCSPH with continuity density: the largest support (in spacings) at which still water
/// was measured to stay still without the velocity filter (SolverSettings::velocityFilter):
/// 2.15 holds, 2.3 and beyond a particle-scale motion grows from round-off.
constexpr double kWcsphStableContinuitySupport = 2.2;
/// DFSPH's: 2 spacings (cubic spline; B&K 2017, SPlisHSPlasH's 4 particle radii). Its
/// lattice has no such rigidity (the same flume: period -2.5 %), and larger supports damp
/// its waves more (0.82, 0.76, 0.72 of the amplitude kept per period at 2, 2.1, 2.15).
constexpr double kDfsphSupportFactor = 2;

/// The support factor a solver takes when SolverSettings::supportRadiusFactor is 0.
inline double defaultSupportFactor(const std::string& solverType) {
  return solverType == "wcsph" ? kWcsphSupportFactor : kDfsphSupportFactor;
}

struct SolverSettings {
  std::string type = "wcsph";        ///< time-step strategy: "wcsph" (SEED); later "dfsph"
  /// Support radius h = factor * spacing; 0: the solver's own (defaultSupportFactor()).
  Real supportRadiusFactor = Real(0);

  // --- WCSPH equation of state (SEED (10)) ---
  EquationOfState equationOfState = EquationOfState::Linear;
  Real taitExponent = Real(7);        ///< gamma of Tait's equation
  /// k of SEED (10), m^2/s^2 (= squared speed of sound). 0: (10 * expectedSpeed)^2,
  /// the weakly compressible choice (density varies by about 1 %).
  Real stiffness = Real(0);
  /// Default: the Hamiltonian form with the Wendland C2 pair below (the
  /// still-water test; docs/solvers.md).
  PressureForce pressureForce = PressureForce::Hamiltonian;
  /// Density and pressure-gradient kernels of WCSPH (the viscosity Laplacian stays
  /// SEED (9)). Default Automatic: Wendland C2, at h = 2 spacings the resting
  /// particle lattice under pressure is linearly stable with it (with the SEED pair
  /// it is not at any pressure, with the cubic spline only below a small pressure);
  /// the cubic spline when a rigid body floats (KernelPair::Automatic).
  KernelPair kernels = KernelPair::Automatic;
  bool clampNegativePressure = true;  ///< p = max(p, 0): no tensile pull at the free surface
  /// WCSPH, with clampNegativePressure: particles of a water body (rho >= 0.8 rho_0)
  /// keep at least p = rho_0 |g| s / 2, the hydrostatic pressure at the centre of
  /// the top particle layer (half a spacing below the surface), instead of the
  /// clamp's 0 (the summed density of the top layer is ~0.88 rho_0). With h = 2
  /// spacings, layers an odd and an even number of spacings deep do not see each
  /// other's pressure (W(2 s) = 0), so a top layer at 0 offsets the two sets of
  /// layers by -/+ rho_0 |g| s / 2 (a pressure zigzag, 2.3 % of rho g H in the
  /// 16 cm hydrostatic tank).
  bool surfaceLayerPressure = true;
  /// Monaghan (1992) artificial viscosity alpha, added to SEED (6) for stability; 0 = off.
  Real artificialViscosity = Real(0.1);
  /// WCSPH: the artificial viscosity term also for receding pairs (v_ij . r_ij > 0),
  /// not only approaching ones (Monaghan 1992). Applied to all pairs it is a shear
  /// viscosity of order alpha h c / 10 (Monaghan 2005, Rep. Prog. Phys. 68, sec. 4),
  /// which damps the sideways slip of the pressure-free top particle layer over
  /// the layer below (a receding/approaching pair pattern the one-sided term
  /// barely sees; 4-6 % of sqrt(g H) in the still-water tank without it).
  bool artificialViscosityAllPairs = true;
  /// Hydrostatic initial state (WCSPH only): a fluid box resting on a boundary
  /// (addFluidBox) starts with the density of hydrostatic equilibrium,
  /// rho(d) = rho_0 (1 + |g| d / k) (linear EOS; Tait: rho_0 (1 + gamma |g| d / k)^(1/gamma)),
  /// made by compressing its lattice along gravity, as in Monaghan (1994)
  /// "Simulating free surface flows with SPH", J. Comput. Phys. 110, section 4
  /// (particles start with the hydrostatic density). Off, the box starts at
  /// rest density and zero pressure: it falls onto the floor and rings in its
  /// acoustic quarter-wave mode with speeds up to about |g| H / c (7 % of
  /// sqrt(|g| H) at the default c = 10 sqrt(2 |g| H)), which artificial
  /// viscosity damps only slowly.
  bool hydrostaticStart = true;
  /// WCSPH density: summation (SEED (4)) or continuity (DensityEvolution).
  DensityEvolution density = DensityEvolution::Summation;
  /// delta of the delta-SPH density diffusion term with continuity density,
  /// delta h c_0 lap(rho) (Molteni & Colagrossi 2009, h the smoothing length, half the
  /// support radius), less its hydrostatic part (Fourtakas et al. 2019), so water at
  /// rest stays at rest. 0 = off; 0.1 is the value of both papers.
  Real densityDiffusion = Real(0.1);
  /// WCSPH: strength beta of the bi-Laplacian velocity filter, a_i -= beta c_0 / h
  /// L(L(v))_i (wcsph::addVelocityFilter), 0 = off. With continuity density at supports
  /// beyond kWcsphStableContinuitySupport still water is unstable: a zigzag of vertical
  /// velocity between neighbouring columns grows from round-off (e-folding 0.1-0.2 s at
  /// 1-2 cm and 3 spacings, faster with delta-SPH's diffusion and with the support, the
  /// same at a tenth of the time step) and then drains gravity waves (docs/solvers.md,
  /// "Still water set for waves"). The filter damps that scale and leaves smooth flow
  /// alone; the slower sliding of layers that follows it is held ten times lower.
  Real velocityFilter = Real(0);

  /// The largest speed the scene is expected to produce, m/s. 0: the free-fall
  /// speed sqrt(2 |g| H) over the height H from the lowest boundary (or fluid)
  /// point to the highest fluid point, or the largest initial / emitted speed,
  /// whichever is larger. Sets the default stiffness, the default repulsion
  /// strength D and the instability threshold.
  Real expectedSpeed = Real(0);
  /// A particle faster than this multiple of expectedSpeed (or NaN) stops the
  /// simulation with InstabilityError.
  Real instabilitySpeedFactor = Real(20);

  // --- DFSPH (unused by WCSPH) ---
  Real densityTolerance = Real(0.0005);     ///< relative average density error
  /// DFSPH divergence-free solve: mean predicted relative density change of one step from
  /// the velocity divergence (SPlisHSPlasH: 0.1 %; docs/solvers.md).
  Real divergenceTolerance = Real(0.0002);
  /// DFSPH: most operator products of each solve per step (docs/dfsph-deep-water.md).
  int maxIterations = 300;
  /// DFSPH constant-density solve: two-level, Jacobi plus a coarse correction on cells of
  /// 2 h (CoarseCorrection.h; one process only: over MPI ranks Jacobi), or Jacobi alone
  /// (false). Measured in docs/dfsph-deep-water.md, "Two levels".
  bool twoLevelPreconditioner = true;
  /// DFSPH constant-density solve: the largest predicted compression of any one particle,
  /// as a share of densityTolerance (the mean alone is diluted by depth); 0: 0.2 with the
  /// two-level preconditioner, 0.02 with Jacobi alone, the largest shares that hold a
  /// 200-layer column at rest (docs/dfsph-deep-water.md, "Two levels").
  Real particleToleranceShare = Real(0);

  // --- adaptive time step ---
  /// dt = min(cflFactor h / (c + v_max), 0.125 h^2 / nu (viscous), 0.25 sqrt(h / a_max) (force)),
  /// clamped to [minTimeStep, maxTimeStep].
  Real cflFactor = Real(0.4);
  Real minTimeStep = Real(1e-6);   ///< s
  Real maxTimeStep = Real(5e-3);   ///< s

  Vec3r gravity = Vec3r(0, 0, -kStandardGravity);  ///< m/s^2, z up

  std::string neighborSearch = "grid";  ///< makeNeighborSearch() method
  int reorderInterval = 25;             ///< steps between Morton reorders; 0 = never
};

/// How mirror (type II) particles take the velocity of their source.
enum class MirrorSlip {
  FreeSlip,  ///< normal component reversed, tangential kept
  NoSlip,    ///< whole velocity reversed
  /// Free-slip mirrors plus the wall shear stress of a laminar boundary layer
  /// thinner than a particle, tau_w = mu u / sqrt(pi nu t) (Stokes' first
  /// problem; libsph/boundary/WallShearStress.h), from the fluid's viscosity
  /// (FluidSettings::viscosity; 0: none). DFSPH; WCSPH treats it as free slip.
  LaminarWallShear,
};

/// The two kinds of virtual boundary particles (SEED section 2.2).
struct BoundarySettings {
  bool repulsionParticles = true;   ///< type I (Monaghan 1994), SEED (11)
  bool mirrorParticles = true;      ///< type II (Libersky & Petschke 1993)
  /// WCSPH: a mirror image's pressure is its source's plus rho_0 g . (x' - x), its
  /// hydrostatic part (Adami et al. 2012, eq. 27, for walls at rest), not the source's
  /// alone. Without type I particles the images alone carry the water's weight, and with
  /// the source's pressure they carry too little: the floor layer sinks into the floor
  /// until the guard puts it back a quarter spacing off it (docs/solvers.md, "Gravity
  /// waves"). With type I particles it changes little (the Martin & Moyce column and
  /// Lobovsky, measured), so it is off by default.
  bool mirrorHydrostatic = false;
  /// D of SEED (11), m^2/s^2. 0: expectedSpeed^2 (the SEED: "of the order of
  /// the squared maximum speed").
  Real repulsionStrength = Real(0);
  /// r0 of SEED (11), m. 0: half the fluid spacing. The SEED sets r0 "about
  /// the initial particle spacing" between the wall and the first fluid layer;
  /// with mirror particles that layer sits half a spacing off the wall (its
  /// mirror images complete the lattice), so r0 = spacing would push the
  /// resting first layer away with a huge force at the start.
  Real repulsionRadius = Real(0);
  /// Largest gap between neighbouring type I particles, as a fraction of r0
  /// (SEED: no gap may exceed r0; meshes are subdivided until it holds).
  Real sampleGap = Real(1);
  MirrorSlip slip = MirrorSlip::FreeSlip;
  /// Mirror particles are made for fluid particles closer than kappa * h to a
  /// boundary (SEED: kappa = 1 or 2).
  Real kappa = Real(1);
};

/// Particles outside [min, max] are removed and counted (never left to fly to infinity).
struct DomainSettings {
  bool enabled = false;
  Vec3r min = Vec3r::Constant(Real(-1e6));
  Vec3r max = Vec3r::Constant(Real(1e6));
};

struct SimulationSettings {
  FluidSettings fluid;
  SolverSettings solver;
  BoundarySettings boundary;
  DomainSettings domain;
};

/// Throws InputError("<context>: <field>: must be ... (got ...)") on an
/// out-of-range value. `context` names the source (a scene file).
void validateSettings(const SimulationSettings& settings, const std::string& context);

} // namespace cascade
