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

// A transducer face (pressureOverDisc) on a field p = A y^2 (no gravity): each point's
// Shepard average is A (y^2 + sigma^2), sigma^2 the kernel's second moment, so the face
// reads A (y_c^2 + R^2 / 4 + sigma^2), R^2 / 4 above the point probe at its centre (the
// disc rule is exact for quadratics). Where a point of the face has no water within h it
// reads 0, as a dry part of a transducer's face does.
TEST(PointProbes, ATransducerFaceAveragesThePressureOverItsDisc) {
  const Vec3r centre(0, 0, 0);
  Particles fluid = lattice(centre, 15, 0.01f, Vec3r::Zero(), Eigen::Matrix<Real, 3, 3>::Zero());
  const double a = 1e5;  // Pa/m^2
  for (std::size_t i = 0; i < fluid.size(); ++i) fluid.pressure[i] = Real(a * fluid.position[i].y() * fluid.position[i].y());
  const Real h = 0.02f, radius = 0.02f;
  const Vec3r face(0, 0.005f, 0), normal(1, 0, 0), gravity = Vec3r::Zero();
  NeighborLists near = probeNeighborhoods(fluid, {face}, h + radius);
  const double point = pressureAt(fluid, face, h, gravity, near.begin(0), near.end(0));
  const double disc = pressureOverDisc(fluid, face, normal, radius, h, gravity, near.begin(0), near.end(0));
  EXPECT_NEAR(disc - point, a * radius * radius / 4, 0.03 * a * radius * radius / 4);  // 1.7 %: lattice discreteness
  EXPECT_DOUBLE_EQ(pressureOverDisc(fluid, face, normal, 0, h, gravity, near.begin(0), near.end(0)), point);

  // A uniform 2 kPa, a face of radius 4 cm centred on the lattice's last plane x = 0.07.
  for (Real& p : fluid.pressure) p = Real(2000);
  const Vec3r edge(0.07f, 0, 0);
  near = probeNeighborhoods(fluid, {edge}, h + Real(0.04));
  // In that plane (normal x) every point of it is wet.
  EXPECT_NEAR(pressureOverDisc(fluid, edge, normal, Real(0.04), h, gravity, near.begin(0), near.end(0)), 2000, 1e-3);
  // Across it (normal z), two of the six ring points lie 2.8 cm past the water (> h): 6/8 of it.
  EXPECT_NEAR(pressureOverDisc(fluid, edge, Vec3r(0, 0, 1), Real(0.04), h, gravity, near.begin(0), near.end(0)),
              1500, 1e-3);
}

} // namespace cascade::test
