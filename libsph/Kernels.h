/// @file Kernels.h
/// @brief The SPH smoothing kernels of Mueller, Charypar & Gross 2003
///        ("Particle-based fluid simulation for interactive applications"),
///        as the SEED uses them: poly6 for density (SEED (7)), spiky for the
///        pressure gradient (SEED (8)), viscosity for the velocity Laplacian
///        (SEED (9)); and the cubic spline (Monaghan 1992) and Wendland C2
///        (Wendland 1995) used for density and gradient alike.
///
/// Each kernel has support radius h (zero for r > h) and integrates to 1 over
/// R^3. `r` is the vector x_i - x_j; gradients are with respect to x_i, so
/// grad W(r) = -grad W(-r) (antisymmetric).
#pragma once

#include "libsph/Types.h"

#include <cmath>

namespace cascade {

constexpr Real kPi = Real(3.14159265358979323846);

/// Poly6: W = 315/(64 pi h^9) (h^2 - r^2)^3. Mueller 2003 eq. 20, SEED (7).
struct KernelPoly6 {
  Real supportRadius;
  Real valueCoeff, gradientCoeff;

  explicit KernelPoly6(Real h)
      : supportRadius(h),
        valueCoeff(Real(315) / (Real(64) * kPi * std::pow(h, Real(9)))),
        gradientCoeff(Real(-945) / (Real(32) * kPi * std::pow(h, Real(9)))) {}

  /// W(r) from the squared distance (density needs no square root).
  Real valueFromSquared(Real r2) const {
    const Real h2 = supportRadius * supportRadius;
    if (r2 >= h2) return Real(0);
    const Real d = h2 - r2;
    return valueCoeff * d * d * d;
  }
  Real value(Real r) const { return valueFromSquared(r * r); }
  /// grad W = -945/(32 pi h^9) (h^2 - r^2)^2 r_vec.
  Vec3r gradient(const Vec3r& r) const {
    const Real r2 = r.squaredNorm(), h2 = supportRadius * supportRadius;
    if (r2 >= h2) return Vec3r::Zero();
    const Real d = h2 - r2;
    return gradientCoeff * d * d * r;
  }
  /// lap W = -945/(32 pi h^9) (h^2 - r^2)(3 h^2 - 7 r^2).
  Real laplacian(Real r) const {
    const Real r2 = r * r, h2 = supportRadius * supportRadius;
    if (r2 >= h2) return Real(0);
    return gradientCoeff * (h2 - r2) * (Real(3) * h2 - Real(7) * r2);
  }
};

/// Spiky: W = 15/(pi h^6) (h - r)^3. Mueller 2003 eq. 21; its gradient is SEED (8).
struct KernelSpiky {
  Real supportRadius;
  Real valueCoeff, gradientCoeff;

  explicit KernelSpiky(Real h)
      : supportRadius(h),
        valueCoeff(Real(15) / (kPi * std::pow(h, Real(6)))),
        gradientCoeff(Real(-45) / (kPi * std::pow(h, Real(6)))) {}

  Real value(Real r) const {
    if (r >= supportRadius) return Real(0);
    const Real d = supportRadius - r;
    return valueCoeff * d * d * d;
  }
  /// grad W = -45/(pi h^6) (h - r)^2 r_vec/|r|; zero at r = 0 (the direction is undefined).
  Vec3r gradient(const Vec3r& r) const {
    const Real len = r.norm();
    if (len >= supportRadius || len <= Real(0)) return Vec3r::Zero();
    const Real d = supportRadius - len;
    return (gradientCoeff * d * d / len) * r;
  }
};

/// Viscosity: W = 15/(2 pi h^3) (-r^3/(2h^3) + r^2/h^2 + h/(2r) - 1).
/// Mueller 2003 eq. 22; its Laplacian 45/(pi h^6)(h - r) is SEED (9).
struct KernelViscosity {
  Real supportRadius;
  Real valueCoeff, laplacianCoeff;

  explicit KernelViscosity(Real h)
      : supportRadius(h),
        valueCoeff(Real(15) / (Real(2) * kPi * h * h * h)),
        laplacianCoeff(Real(45) / (kPi * std::pow(h, Real(6)))) {}

  Real value(Real r) const {
    if (r >= supportRadius || r <= Real(0)) return Real(0);
    const Real h = supportRadius, q = r / h;
    return valueCoeff * (-q * q * q / Real(2) + q * q + h / (Real(2) * r) - Real(1));
  }
  /// grad W = 15/(2 pi h^3) (-3r/(2h^3) + 2/h^2 - h/(2r^3)) r_vec.
  Vec3r gradient(const Vec3r& r) const {
    const Real len = r.norm(), h = supportRadius;
    if (len >= h || len <= Real(0)) return Vec3r::Zero();
    const Real s = -Real(3) * len / (Real(2) * h * h * h) + Real(2) / (h * h) -
                   h / (Real(2) * len * len * len);
    return (valueCoeff * s) * r;
  }
  Real laplacian(Real r) const {
    if (r >= supportRadius) return Real(0);
    return laplacianCoeff * (supportRadius - r);
  }
};

/// Cubic spline (Monaghan 1992) with support h (zero for r >= h), the usual
/// kernel of DFSPH (Bender & Koschier 2017; SPlisHSPlasH):
/// W = 8/(pi h^3) (6 q^3 - 6 q^2 + 1) for q = r/h <= 1/2, 16/(pi h^3) (1 - q)^3 for q <= 1.
struct KernelCubicSpline {
  Real supportRadius;
  Real valueCoeff, gradientCoeff, inverseSupport;

  explicit KernelCubicSpline(Real h)
      : supportRadius(h), valueCoeff(Real(8) / (kPi * h * h * h)),
        gradientCoeff(Real(48) / (kPi * h * h * h * h)), inverseSupport(Real(1) / h) {}

  Real value(Real r) const {
    const Real q = r * inverseSupport;
    if (q >= Real(1)) return Real(0);
    if (q <= Real(0.5)) return valueCoeff * (Real(6) * q * q * (q - Real(1)) + Real(1));
    const Real d = Real(1) - q;
    return valueCoeff * Real(2) * d * d * d;
  }
  Real valueFromSquared(Real r2) const { return value(std::sqrt(r2)); }
  /// grad W = 48/(pi h^4) q (3q - 2) r/|r| (q <= 1/2), -48/(pi h^4) (1 - q)^2 r/|r| (q <= 1); zero at r = 0.
  Vec3r gradient(const Vec3r& r) const {
    const Real len = r.norm();
    const Real q = len * inverseSupport;
    if (q >= Real(1) || len <= Real(0)) return Vec3r::Zero();
    Real s;
    if (q <= Real(0.5)) {
      s = gradientCoeff * q * (Real(3) * q - Real(2));
    } else {
      const Real d = Real(1) - q;
      s = -gradientCoeff * d * d;
    }
    return (s / len) * r;
  }
};

/// Wendland C2 (Wendland 1995) in 3-D with support h (zero for r >= h), as
/// Dehnen & Aly 2012 (MNRAS 425, table 1) normalise it:
/// W = 21/(2 pi h^3) (1 - q)^4 (1 + 4 q), q = r/h. Positive Fourier transform,
/// so no pairing instability (Dehnen & Aly 2012, section 3).
struct KernelWendlandC2 {
  Real supportRadius;
  Real valueCoeff, gradientCoeff, inverseSupport;

  explicit KernelWendlandC2(Real h)
      : supportRadius(h), valueCoeff(Real(21) / (Real(2) * kPi * h * h * h)),
        gradientCoeff(Real(-210) / (kPi * h * h * h * h * h)), inverseSupport(Real(1) / h) {}

  Real value(Real r) const {
    if (r >= supportRadius) return Real(0);
    const Real q = r * inverseSupport;
    const Real d = Real(1) - q, d2 = d * d;
    return valueCoeff * d2 * d2 * (Real(1) + Real(4) * q);
  }
  Real valueFromSquared(Real r2) const { return value(std::sqrt(r2)); }
  /// grad W = -210/(pi h^5) (1 - q)^3 r_vec (smooth, zero at r = 0).
  Vec3r gradient(const Vec3r& r) const {
    const Real len = r.norm();
    if (len >= supportRadius) return Vec3r::Zero();
    const Real d = Real(1) - len * inverseSupport;
    return (gradientCoeff * d * d * d) * r;
  }
};

} // namespace cascade
