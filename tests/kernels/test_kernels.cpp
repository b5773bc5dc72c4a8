// The SEED kernels (Mueller 2003 eqs. 20-22; SEED (7)-(9)) and the kernels used
// for density and gradient alike (cubic spline, Monaghan 1992; Wendland C2,
// Wendland 1995): normalised, compactly supported, with analytic derivatives
// that match finite differences.
#include "libsph/Kernels.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

using namespace cascade;

namespace {

constexpr double kPiD = 3.14159265358979323846;

/// 4 pi int_0^h W(r) r^2 dr by composite Simpson (the kernels are radial).
template <typename Value>
double radialIntegral(Value value, double h, int intervals = 4000) {
  const double dr = h / intervals;
  double sum = 0;
  for (int i = 0; i <= intervals; ++i) {
    const double r = i * dr;
    const double weight = (i == 0 || i == intervals) ? 1 : (i % 2 ? 4 : 2);
    sum += weight * double(value(Real(r))) * r * r;
  }
  return 4 * kPiD * sum * dr / 3;
}

/// Midpoint sum over a Cartesian grid covering [-h, h]^3: independent of the
/// radial reduction (catches a wrong power of h or a missing 4 pi).
template <typename Value>
double cartesianIntegral(Value value, double h, int cells = 120) {
  const double d = 2 * h / cells;
  double sum = 0;
  for (int k = 0; k < cells; ++k)
    for (int j = 0; j < cells; ++j)
      for (int i = 0; i < cells; ++i) {
        const double x = -h + (i + 0.5) * d, y = -h + (j + 0.5) * d, z = -h + (k + 0.5) * d;
        sum += double(value(Real(std::sqrt(x * x + y * y + z * z))));
      }
  return sum * d * d * d;
}

/// Radial derivative dW/dr by central differences.
template <typename Value>
double radialDerivative(Value value, double r, double step) {
  return (double(value(Real(r + step))) - double(value(Real(r - step)))) / (2 * step);
}

const Real kSupports[] = {0.0457f, 1.0f, 2.5f};

} // namespace

TEST(Kernels, Poly6IntegratesToOne) {
  for (const Real h : kSupports) {
    const KernelPoly6 kernel(h);
    EXPECT_NEAR(radialIntegral([&](Real r) { return kernel.value(r); }, h), 1.0, 1e-3) << h;
    EXPECT_NEAR(cartesianIntegral([&](Real r) { return kernel.value(r); }, h), 1.0, 1e-3) << h;
  }
}

TEST(Kernels, SpikyIntegratesToOne) {
  for (const Real h : kSupports) {
    const KernelSpiky kernel(h);
    EXPECT_NEAR(radialIntegral([&](Real r) { return kernel.value(r); }, h), 1.0, 1e-3) << h;
    EXPECT_NEAR(cartesianIntegral([&](Real r) { return kernel.value(r); }, h), 1.0, 1e-3) << h;
  }
}

TEST(Kernels, ViscosityIntegratesToOne) {
  // W ~ h/(2r) near 0: integrable in 3-D (r^2 W -> 0), fine for the radial rule.
  for (const Real h : kSupports) {
    const KernelViscosity kernel(h);
    EXPECT_NEAR(radialIntegral([&](Real r) { return kernel.value(r); }, h, 20000), 1.0, 1e-3) << h;
  }
}

TEST(Kernels, ZeroOutsideTheSupportAndAtTheSupportRadius) {
  for (const Real h : kSupports) {
    const KernelPoly6 poly6(h);
    const KernelSpiky spiky(h);
    const KernelViscosity viscosity(h);
    for (const Real r : {h, Real(1.0001f) * h, 3 * h}) {
      EXPECT_EQ(poly6.value(r), 0);
      EXPECT_EQ(spiky.value(r), 0);
      EXPECT_EQ(viscosity.value(r), 0);
      EXPECT_EQ(poly6.laplacian(r), 0);
      EXPECT_EQ(viscosity.laplacian(r), 0);
      EXPECT_EQ(poly6.gradient(Vec3r(r, 0, 0)), Vec3r::Zero());
      EXPECT_EQ(spiky.gradient(Vec3r(0, r, 0)), Vec3r::Zero());
      EXPECT_EQ(viscosity.gradient(Vec3r(0, 0, r)), Vec3r::Zero());
    }
    // Positive inside.
    EXPECT_GT(poly6.value(0.5f * h), 0);
    EXPECT_GT(spiky.value(0.5f * h), 0);
    EXPECT_GT(viscosity.value(0.5f * h), 0);
  }
}

TEST(Kernels, GradientsAreAntisymmetricAndMatchFiniteDifferences) {
  std::mt19937 rng(3);
  for (const Real h : kSupports) {
    const KernelPoly6 poly6(h);
    const KernelSpiky spiky(h);
    const KernelViscosity viscosity(h);
    std::uniform_real_distribution<Real> u(-h, h);
    int tested = 0;
    while (tested < 200) {
      const Vec3r r(u(rng), u(rng), u(rng));
      const double len = r.cast<double>().norm();
      if (len < 0.05 * h || len > 0.95 * h) continue;
      ++tested;
      const Vec3r g[3] = {poly6.gradient(r), spiky.gradient(r), viscosity.gradient(r)};
      EXPECT_EQ(poly6.gradient(-r), -g[0]);
      EXPECT_EQ(spiky.gradient(-r), -g[1]);
      EXPECT_EQ(viscosity.gradient(-r), -g[2]);
      // grad W = dW/dr r_vec / |r|.
      const double step = 1e-3 * h;
      const double dW[3] = {
          radialDerivative([&](Real s) { return poly6.value(s); }, len, step),
          radialDerivative([&](Real s) { return spiky.value(s); }, len, step),
          radialDerivative([&](Real s) { return viscosity.value(s); }, len, step)};
      const double scale[3] = {945 / (32 * kPiD * std::pow(h, 4.0)), 45 / (kPiD * std::pow(h, 4.0)),
                               45 / (kPiD * std::pow(h, 4.0)) * h / len * h / len};
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d expected = dW[k] * r.cast<double>() / len;
        EXPECT_LT((g[k].cast<double>() - expected).norm(), 2e-3 * scale[k])
            << "kernel " << k << " h " << h << " r " << len;
      }
    }
  }
}

TEST(Kernels, LaplaciansMatchFiniteDifferences) {
  // lap W = W'' + 2 W'/r for a radial function.
  for (const Real h : kSupports) {
    const KernelPoly6 poly6(h);
    const KernelViscosity viscosity(h);
    for (double q = 0.15; q < 0.9; q += 0.1) {
      const double r = q * h, step = 1e-2 * h;
      auto laplacian = [&](auto value) {
        const double w0 = value(Real(r)), wp = value(Real(r + step)), wm = value(Real(r - step));
        return (wp - 2 * w0 + wm) / (step * step) + 2 / r * (wp - wm) / (2 * step);
      };
      const double poly6Lap = laplacian([&](Real s) { return double(poly6.value(s)); });
      const double viscLap = laplacian([&](Real s) { return double(viscosity.value(s)); });
      EXPECT_NEAR(poly6.laplacian(Real(r)), poly6Lap, 2e-2 * 945 / (32 * kPiD * std::pow(h, 5.0)))
          << h << " " << q;
      EXPECT_NEAR(viscosity.laplacian(Real(r)), viscLap, 2e-2 * 45 / (kPiD * std::pow(h, 5.0)))
          << h << " " << q;
      // SEED (9): 45/(pi h^6) (h - r).
      EXPECT_NEAR(viscosity.laplacian(Real(r)), 45 / (kPiD * std::pow(h, 6.0)) * (h - r),
                  1e-5 * 45 / (kPiD * std::pow(h, 5.0)));
    }
  }
}

TEST(Kernels, CubicSplineAndWendlandC2IntegrateToOne) {
  for (const Real h : kSupports) {
    const KernelCubicSpline cubic(h);
    const KernelWendlandC2 wendland(h);
    EXPECT_NEAR(radialIntegral([&](Real r) { return cubic.value(r); }, h), 1.0, 1e-3) << h;
    EXPECT_NEAR(cartesianIntegral([&](Real r) { return cubic.value(r); }, h), 1.0, 1e-3) << h;
    EXPECT_NEAR(radialIntegral([&](Real r) { return wendland.value(r); }, h), 1.0, 1e-3) << h;
    EXPECT_NEAR(cartesianIntegral([&](Real r) { return wendland.value(r); }, h), 1.0, 1e-3) << h;
  }
}

TEST(Kernels, WendlandC2MatchesDehnenAly) {
  // Dehnen & Aly 2012, table 1 (3-D): W(0) = 21 / (2 pi h^3); W(h/2) = W(0) (1/2)^4 3.
  for (const Real h : kSupports) {
    const KernelWendlandC2 kernel(h);
    const double w0 = 21 / (2 * kPiD * std::pow(double(h), 3.0));
    EXPECT_NEAR(kernel.value(0), w0, 1e-5 * w0);
    EXPECT_NEAR(kernel.value(h / 2), w0 * 3 / 16, 1e-5 * w0);
    for (const Real r : {h, Real(1.0001f) * h, 3 * h}) {
      EXPECT_EQ(kernel.value(r), 0);
      EXPECT_EQ(kernel.gradient(Vec3r(r, 0, 0)), Vec3r::Zero());
    }
    EXPECT_EQ(kernel.gradient(Vec3r::Zero()), Vec3r::Zero());
  }
}

TEST(Kernels, CubicSplineAndWendlandC2GradientsMatchFiniteDifferences) {
  std::mt19937 rng(5);
  for (const Real h : kSupports) {
    const KernelCubicSpline cubic(h);
    const KernelWendlandC2 wendland(h);
    std::uniform_real_distribution<Real> u(-h, h);
    int tested = 0;
    while (tested < 200) {
      const Vec3r r(u(rng), u(rng), u(rng));
      const double len = r.cast<double>().norm();
      if (len < 0.05 * h || len > 0.95 * h || std::abs(len - 0.5 * h) < 0.01 * h) continue;
      ++tested;
      const Vec3r g[2] = {cubic.gradient(r), wendland.gradient(r)};
      EXPECT_EQ(cubic.gradient(-r), -g[0]);
      EXPECT_EQ(wendland.gradient(-r), -g[1]);
      const double step = 1e-3 * h;
      const double dW[2] = {radialDerivative([&](Real s) { return cubic.value(s); }, len, step),
                            radialDerivative([&](Real s) { return wendland.value(s); }, len, step)};
      const double scale = 50 / (kPiD * std::pow(double(h), 4.0));
      for (int k = 0; k < 2; ++k) {
        const Eigen::Vector3d expected = dW[k] * r.cast<double>() / len;
        EXPECT_LT((g[k].cast<double>() - expected).norm(), 2e-3 * scale) << "kernel " << k << " h " << h << " r " << len;
      }
    }
  }
}
