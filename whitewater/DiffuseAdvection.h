/// @file DiffuseAdvection.h
/// @brief Moving diffuse particles over one step (Ihmsen et al. 2012 sec. 5),
///        each kind by the exact solution of its equation of motion for a step
///        with the fluid velocity held, so the result does not depend on the
///        step size:
///   spray:  dv/dt = g - k_air v                     (ballistic with linear air drag)
///   bubble: dv/dt = -k_b g + k_d (v_f - v)          (buoyancy, drag towards the fluid)
///   foam:   v = v_f                                 (carried by the fluid)
/// where v_f is the fluid velocity averaged around the particle with the
/// weights W(r) = 1 - r/h (Ihmsen 2012 eq. 10 with that kernel). Both first
/// kinds are dv/dt = a + k (u - v): v relaxes towards v_inf = u + a/k at rate k,
///   v(t) = v_inf + (v0 - v_inf) e^{-k t},
///   x(t) = x0 + v_inf t + (v0 - v_inf) (1 - e^{-k t}) / k,
/// and for k = 0, x(t) = x0 + v0 t + a t^2 / 2. A bubble in still water rises
/// at k_b |g| / k_d.
#pragma once

#include "libsph/Types.h"

#include <cmath>

namespace cascade::whitewater {

/// Advances x, v by dt under dv/dt = a + k (u - v), exactly (k >= 0).
inline void relaxMotion(Vec3r& x, Vec3r& v, const Vec3r& u, const Vec3r& a, double k, double dt) {
  if (k <= 0) {
    x += Real(dt) * v + Real(0.5 * dt * dt) * a;
    v += Real(dt) * a;
    return;
  }
  const Vec3r terminal = u + Real(1.0 / k) * a;
  const double decay = std::exp(-k * dt);
  const Vec3r excess = v - terminal;
  x += Real(dt) * terminal + Real(-std::expm1(-k * dt) / k) * excess;
  v = terminal + Real(decay) * excess;
}

} // namespace cascade::whitewater
