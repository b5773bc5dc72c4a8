/// @file WallShearStress.h
/// @brief Wall friction of a laminar boundary layer thinner than one particle
///        (a wall function for mirror-particle walls, which are free slip).
///
/// At the resolutions SPH affords, the viscous boundary layer of water is far
/// thinner than the particle spacing s (delta = sqrt(pi nu t) = 0.56 mm after
/// 0.1 s for nu = 1e-6 m^2/s), so a no-slip condition on the particles smears it
/// over a kernel width, and free slip drops it. Instead the wall-adjacent layer
/// of particles (centres within s of the wall) keeps its slip velocity u (the
/// velocity just outside the boundary layer) and feels the wall shear stress of
/// Stokes' first problem, a wall set impulsively into relative motion
/// (Stokes 1851; Rayleigh 1911, Phil. Mag. 21, 697; e.g. White, "Viscous Fluid
/// Flow", Stokes' first problem):
///     tau_w = mu u / sqrt(pi nu t),
/// with t the time the fluid has been in contact with the wall (its boundary
/// layer's age), mu the fluid's dynamic viscosity and nu = mu / rho_0. Over the
/// layer's area s^2 and mass rho_0 s^3 this is du/dt = -(nu / s) u / sqrt(pi nu t),
/// integrated exactly over a step [t, t + dt]:
///     u(t + dt) = u(t) exp(-(2 / s) sqrt(nu / pi) (sqrt(t + dt) - sqrt(t))),
/// finite also at t = 0. The law has no free parameter: the fluid's own
/// viscosity sets it (water: mu = 1.0e-3 Pa s).
#pragma once

#include "libsph/Types.h"

#include <cmath>

namespace cascade {

/// Factor on the slip velocity of a wall-adjacent particle layer of thickness
/// `layerThickness` (m) whose boundary layer is `age` s old, over a step dt (s);
/// kinematicViscosity nu in m^2/s. 1 for nu = 0.
inline Real laminarWallShearDecay(Real kinematicViscosity, Real layerThickness, double age, double dt) {
  if (!(kinematicViscosity > 0) || !(layerThickness > 0)) return Real(1);
  constexpr double kPiValue = 3.14159265358979323846;
  const double growth = std::sqrt(age + dt) - std::sqrt(age);
  const double exponent = 2.0 / double(layerThickness) * std::sqrt(double(kinematicViscosity) / kPiValue) * growth;
  return static_cast<Real>(std::exp(-exponent));
}

} // namespace cascade
