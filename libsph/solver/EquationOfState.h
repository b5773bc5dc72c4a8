/// @file EquationOfState.h
/// @brief Pressure from density for weakly compressible SPH: SEED (10), the
///        linear p = k (rho - rho_0) of Desbrun & Cani 1996 / Mueller 2003,
///        or Tait's p = B ((rho/rho_0)^gamma - 1), B = rho_0 k / gamma
///        (Monaghan 1994; Becker & Teschner 2007), both with sound speed sqrt(k)
///        at rest; optionally clamped at zero (no tension at the free surface).
#pragma once

#include "libsph/solver/SolverSettings.h"

#include <algorithm>
#include <cmath>

namespace cascade {

struct PressureModel {
  EquationOfState equation = EquationOfState::Linear;
  Real restDensity = Real(1000);
  Real stiffness = Real(0);   ///< k, m^2/s^2
  Real exponent = Real(7);    ///< Tait gamma
  bool clampNegative = true;

  Real operator()(Real density) const {
    Real pressure;
    if (equation == EquationOfState::Linear) {
      pressure = stiffness * (density - restDensity);  // SEED (10)
    } else {
      const Real ratio = density / restDensity;
      const Real b = restDensity * stiffness / exponent;
      pressure = b * (std::pow(ratio, exponent) - Real(1));
    }
    return clampNegative ? std::max(pressure, Real(0)) : pressure;
  }
};

} // namespace cascade
