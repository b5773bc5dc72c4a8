// Point probes: the velocity probe is the Shepard-normalised kernel average
// of the fluid's velocity (exact for a uniform field, the field's value at the centre
// of a symmetric lattice for a linear one, none where no fluid is near); the grid that
// finds each point's particles lists exactly those within the radius, so the pressure
// probe through it equals the pass over all particles.
#include "libsph/Particles.h"
#include "libsph/probes/Probes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace cascade::test {

namespace {
/// A cubic lattice (n^3, spacing s) centred on `centre`, velocity v(x) = a + B (x - centre).
Particles lattice(const Vec3r& centre, int n, Real s, const Vec3r& a, const Eigen::Matrix<Real, 3, 3>& b) {
  Particles p;
  p.mass = Real(1e-3);
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Vec3r x = centre + s * Vec3r(Real(i) - Real(n - 1) / 2, Real(j) - Real(n - 1) / 2, Real(k) - Real(n - 1) / 2);
        p.add(x, a + b * (x - centre), ParticleId(p.size()));
        p.density.back() = Real(1000);
        p.pressure.back() = Real(100) * x.z();
      }
  return p;
}
} // namespace

TEST(PointProbes, VelocityIsTheKernelAverageOfTheFluid) {
  const Vec3r centre(0.3f, -0.2f, 0.5f), a(1.0f, -2.0f, 0.5f);
  Eigen::Matrix<Real, 3, 3> b;
  b << 0.3f, -1.0f, 0.2f, 2.0f, 0.1f, -0.5f, 0.0f, 0.7f, 1.5f;
  const Real h = 0.02f;
  const Particles fluid = lattice(centre, 9, 0.01f, a, b);
  const NeighborLists near = probeNeighborhoods(fluid, {centre, centre + Vec3r(1, 1, 1)}, h);
  Vec3d v = Vec3d::Constant(-7);
  ASSERT_TRUE(velocityAt(fluid, centre, h, near.begin(0), near.end(0), v));
  EXPECT_NEAR((v - a.cast<double>()).norm(), 0.0, 1e-5);  // symmetric weights: the linear part cancels
  EXPECT_FALSE(velocityAt(fluid, centre + Vec3r(1, 1, 1), h, near.begin(1), near.end(1), v));
  EXPECT_NEAR((v - a.cast<double>()).norm(), 0.0, 1e-5);  // left untouched
}

TEST(PointProbes, GridNeighbourhoodsAreExactAndThePressureMatchesTheFullPass) {
  std::mt19937 random(7);
  std::uniform_real_distribution<float> u(-0.1f, 0.1f);
  Particles fluid;
  fluid.mass = Real(1e-3);
  for (int k = 0; k < 4000; ++k) {
    fluid.add(Vec3r(u(random), u(random), u(random)), Vec3r::Zero(), ParticleId(k));
    fluid.density.back() = Real(1000) + Real(5) * u(random);
    fluid.pressure.back() = Real(2000) + Real(1000) * u(random);
  }
  const Real h = 0.025f;
  std::vector<Vec3r> points;
  for (int k = 0; k < 20; ++k) points.emplace_back(u(random), u(random), u(random));
  const NeighborLists near = probeNeighborhoods(fluid, points, h);
  const Vec3r gravity(0, 0, -9.81f);
  for (std::size_t q = 0; q < points.size(); ++q) {
    std::vector<std::uint32_t> listed(near.begin(q), near.end(q)), brute;
    for (std::uint32_t j = 0; j < fluid.size(); ++j)
      if ((fluid.position[j] - points[q]).squaredNorm() < h * h) brute.push_back(j);
    std::sort(listed.begin(), listed.end());
    // The grid may list points at exactly h; those carry zero weight.
    for (std::uint32_t j : brute) EXPECT_TRUE(std::binary_search(listed.begin(), listed.end(), j));
    for (std::uint32_t j : listed) EXPECT_LE((fluid.position[j] - points[q]).norm(), h * 1.0001f);
    EXPECT_NEAR(pressureAt(fluid, points[q], h, gravity, near.begin(q), near.end(q)),
                pressureAt(fluid, points[q], h, gravity), 1e-6);
  }
}

} // namespace cascade::test
