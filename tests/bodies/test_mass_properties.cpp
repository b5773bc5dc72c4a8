#include "libsph/Errors.h"
#include "libsph/bodies/MassProperties.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include <algorithm>

#include <cmath>
#include <map>
#include <stdexcept>
#include <utility>

using namespace cascade;

namespace {

constexpr double kPi = 3.14159265358979323846;

/// Appends the quad a b c d (a cycle around a face) as two triangles, counter-clockwise seen from the
/// side `outward` points to.
void addQuad(TriangleMesh& mesh, std::uint32_t a, std::uint32_t b, std::uint32_t c, std::uint32_t d,
             const Eigen::Vector3f& outward) {
  const auto& v = mesh.vertices;
  if ((v[b] - v[a]).cross(v[c] - v[a]).dot(outward) < 0) std::swap(b, d);
  mesh.triangles.push_back({a, b, c});
  mesh.triangles.push_back({a, c, d});
}

/// The box [-size/2, size/2] placed by `rotation` and `center` (in double, then stored as float),
/// 12 outward triangles.
TriangleMesh box(const Vec3d& size, const Mat3d& rotation, const Vec3d& center) {
  TriangleMesh mesh;
  for (int i = 0; i < 8; ++i) {
    const Vec3d local((i & 1 ? 0.5 : -0.5) * size.x(), (i & 2 ? 0.5 : -0.5) * size.y(),
                      (i & 4 ? 0.5 : -0.5) * size.z());
    mesh.vertices.push_back((rotation * local + center).cast<float>());
  }
  const Eigen::Matrix3f r = rotation.cast<float>();
  // Faces by the bit of the axis they are normal to: cycle through the 4 corners with that bit fixed.
  for (int axis = 0; axis < 3; ++axis) {
    const int bit = 1 << axis, u = 1 << ((axis + 1) % 3), w = 1 << ((axis + 2) % 3);
    for (int side = 0; side < 2; ++side) {
      const std::uint32_t base = side ? bit : 0;
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[axis] = side ? 1.0f : -1.0f;
      addQuad(mesh, base, base + u, base + u + w, base + w, r * normal);
    }
  }
  return mesh;
}

TriangleMesh unitCubeAt(const Vec3d& minCorner) {
  return box(Vec3d::Ones(), Mat3d::Identity(), minCorner + Vec3d::Constant(0.5));
}

/// Icosahedron subdivided `levels` times, vertices projected on the sphere of `radius` about `center`.
TriangleMesh icosphere(int levels, double radius, const Vec3d& center) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vec3d> points = {{-1, g, 0}, {1, g, 0},  {-1, -g, 0}, {1, -g, 0}, {0, -1, g},  {0, 1, g},
                               {0, -1, -g}, {0, 1, -g}, {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  for (auto& p : points) p.normalize();
  std::vector<std::array<std::uint32_t, 3>> faces = {
      {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},  {4, 9, 5},  {2, 4, 11},  {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < levels; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    const auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      auto found = midpoints.find(key);
      if (found != midpoints.end()) return found->second;
      points.push_back((points[a] + points[b]).normalized());
      const auto index = std::uint32_t(points.size() - 1);
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<std::uint32_t, 3>> finer;
    for (const auto& f : faces) {
      const std::uint32_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }
  TriangleMesh mesh;
  for (const auto& p : points) mesh.vertices.push_back((center + radius * p).cast<float>());
  mesh.triangles = faces;
  return mesh;
}

/// Radius of the largest ball about `center` inside the mesh's convex hull: the least distance from
/// `center` to the planes of the triangles (for a convex mesh around `center`).
double inscribedRadius(const TriangleMesh& mesh, const Vec3d& center) {
  double least = INFINITY;
  for (const auto& t : mesh.triangles) {
    const Vec3d p0 = mesh.vertices[t[0]].cast<double>() - center;
    const Vec3d p1 = mesh.vertices[t[1]].cast<double>() - center;
    const Vec3d p2 = mesh.vertices[t[2]].cast<double>() - center;
    least = std::min(least, std::abs((p1 - p0).cross(p2 - p0).normalized().dot(p0)));
  }
  return least;
}

void expectMatrixNear(const Mat3d& actual, const Mat3d& expected, double tolerance) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      EXPECT_NEAR(actual(i, j), expected(i, j), tolerance) << "entry (" << i << ", " << j << ")\nactual\n"
                                                           << actual << "\nexpected\n" << expected;
}

TriangleMesh flipped(TriangleMesh mesh) {
  for (auto& t : mesh.triangles) std::swap(t[1], t[2]);
  return mesh;
}

} // namespace

TEST(MassProperties, UnitCubeFarFromOriginIsExact) {
  for (const Vec3d& corner : {Vec3d(100, -50, 20), Vec3d(100000, -50000, 20000)}) {
    SCOPED_TRACE(corner.transpose());
    const MassProperties p = massPropertiesOfMesh(unitCubeAt(corner), 500.0, "cube");
    EXPECT_NEAR(p.volume, 1.0, 1e-12);
    EXPECT_NEAR(p.mass, 500.0, 500.0 * 1e-12);
    const Vec3d center = corner + Vec3d::Constant(0.5);
    EXPECT_NEAR((p.centerOfMass - center).norm(), 0.0, 1e-9);
    const double expected = 500.0 / 6.0;
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(p.inertia(i, i), expected, expected * 1e-9);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        if (i != j) {
          EXPECT_NEAR(p.inertia(i, j), 0.0, expected * 1e-9);
        }
  }
}

TEST(MassProperties, RightTetrahedronHasExactOffDiagonalProducts) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  const MassProperties p = massPropertiesOfMesh(mesh, 2.0, "tetrahedron");
  EXPECT_NEAR(p.volume, 1.0 / 6.0, 1e-15);
  EXPECT_NEAR(p.mass, 1.0 / 3.0, 1e-15);
  EXPECT_NEAR((p.centerOfMass - Vec3d::Constant(0.25)).norm(), 0.0, 1e-15);
  // Per unit density about the centroid: I_ii = 1/80, I_ij = +1/480 (int x^2 = 1/60, int xy = 1/120).
  Mat3d expected = Mat3d::Constant(2.0 / 480.0);
  expected.diagonal().setConstant(2.0 / 80.0);
  expectMatrixNear(p.inertia, expected, 1e-15);
}

TEST(MassProperties, SquarePyramidCentreIsNotItsVertexMean) {
  // Base side a in the plane z = 0 about (x0, y0), apex at height h: V = a^2 h / 3, centre of mass h / 4
  // above the base (the mean of the vertices is h / 5 above it), and about the centre of mass
  // I_zz = m a^2 / 10, I_xx = I_yy = m a^2 / 20 + 3 m h^2 / 80.
  const double a = 2, h = 3, density = 250, x0 = -40, y0 = 60;
  TriangleMesh mesh;
  mesh.vertices = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}, {0, 0, 3}};
  for (auto& v : mesh.vertices) v += Eigen::Vector3f(float(x0), float(y0), 0);
  mesh.triangles = {{0, 2, 1}, {0, 3, 2}, {0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}};
  const MassProperties p = massPropertiesOfMesh(mesh, density, "pyramid");
  const double m = density * a * a * h / 3;
  EXPECT_NEAR(p.volume, a * a * h / 3, 1e-12);
  EXPECT_NEAR(p.mass, m, 1e-12 * m);
  EXPECT_NEAR((p.centerOfMass - Vec3d(x0, y0, h / 4)).norm(), 0.0, 1e-12);
  const Vec3d principal(m * a * a / 20 + 3 * m * h * h / 80, m * a * a / 20 + 3 * m * h * h / 80, m * a * a / 10);
  expectMatrixNear(p.inertia, Mat3d(principal.asDiagonal()), 1e-12 * principal.maxCoeff());
}

TEST(MassProperties, RotatedBoxInertiaIsRotatedPrincipalInertia) {
  const double a = 1, b = 2, c = 3, density = 800;
  const Mat3d rotation = (Eigen::AngleAxisd(0.7, Vec3d(1, 2, 3).normalized()) *
                          Eigen::AngleAxisd(-1.9, Vec3d(-2, 0.5, 1).normalized()))
                             .toRotationMatrix();
  ASSERT_GT((rotation - Mat3d::Identity()).norm(), 0.5);
  const Vec3d center(0.25, -0.5, 0.125);
  const MassProperties p = massPropertiesOfMesh(box(Vec3d(a, b, c), rotation, center), density, "box");
  const double m = density * a * b * c;
  // Vertices are stored as float (about 1e-7 relative), so compare to 1e-5 relative.
  EXPECT_NEAR(p.volume, a * b * c, 6e-5);
  EXPECT_NEAR(p.mass, m, m * 1e-5);
  EXPECT_NEAR((p.centerOfMass - center).norm(), 0.0, 1e-5);
  const Vec3d principal = m / 12.0 * Vec3d(b * b + c * c, c * c + a * a, a * a + b * b);
  const Mat3d expected = rotation * principal.asDiagonal() * rotation.transpose();
  // The rotation mixes the axes: the expected tensor has sizeable off-diagonal entries.
  ASSERT_GT(std::abs(expected(0, 1)) + std::abs(expected(1, 2)) + std::abs(expected(0, 2)), 0.1 * principal.maxCoeff());
  expectMatrixNear(p.inertia, expected, 1e-5 * principal.maxCoeff());
  // Symmetric, with the box's principal moments as eigenvalues.
  EXPECT_NEAR((p.inertia - p.inertia.transpose()).norm(), 0.0, 1e-12 * principal.maxCoeff());
  Eigen::SelfAdjointEigenSolver<Mat3d> eigen(p.inertia);
  Vec3d sorted = principal;
  std::sort(sorted.data(), sorted.data() + 3);
  EXPECT_NEAR((eigen.eigenvalues() - sorted).norm(), 0.0, 1e-5 * principal.maxCoeff());
}

TEST(MassProperties, IcosphereIsBetweenInscribedAndCircumscribedBallsAndConverges) {
  const double r = 0.5, density = 1000;
  const Vec3d center(3, -7, 11);
  const double sphereVolume = 4.0 / 3.0 * kPi * r * r * r;
  double previousError = INFINITY;
  for (int levels = 2; levels <= 5; ++levels) {
    SCOPED_TRACE(levels);
    const TriangleMesh mesh = icosphere(levels, r, center);
    const MassProperties p = massPropertiesOfMesh(mesh, density, "sphere");
    // The polyhedron contains the ball of its inscribed radius and lies in the ball of radius r
    // (float vertices: allow 1e-6 r either way), so its volume and its moment about any axis through
    // the centre lie between the two balls'.
    const double rIn = inscribedRadius(mesh, center) - 1e-6 * r, rOut = r * (1 + 1e-6);
    const double vIn = 4.0 / 3.0 * kPi * std::pow(rIn, 3), vOut = 4.0 / 3.0 * kPi * std::pow(rOut, 3);
    EXPECT_GE(p.volume, vIn);
    EXPECT_LE(p.volume, vOut);
    EXPECT_NEAR(p.mass, density * p.volume, 1e-12 * p.mass);
    EXPECT_NEAR((p.centerOfMass - center).norm(), 0.0, 1e-6 * r);
    const double iIn = 0.4 * density * vIn * rIn * rIn, iOut = 0.4 * density * vOut * rOut * rOut;
    for (int i = 0; i < 3; ++i) {
      EXPECT_GE(p.inertia(i, i), iIn);
      EXPECT_LE(p.inertia(i, i), iOut);
    }
    // Icosahedral symmetry: the tensor is isotropic.
    const double mean = p.inertia.trace() / 3.0;
    expectMatrixNear(p.inertia, mean * Mat3d::Identity(), 1e-6 * mean);
    // The error against the sphere shrinks about fourfold per level (it is O(edge^2)).
    const double error = std::abs(p.volume - sphereVolume) / sphereVolume;
    EXPECT_LT(error, previousError / 3.0);
    previousError = error;
    if (levels >= 4) {
      EXPECT_NEAR(p.volume, sphereVolume, 0.01 * sphereVolume);
      const double sphereInertia = 0.4 * density * sphereVolume * r * r;
      EXPECT_NEAR(mean, sphereInertia, 0.01 * sphereInertia);
    }
  }
}

TEST(MassProperties, UnweldedTriangleSoupIsClosed) {
  const TriangleMesh welded = unitCubeAt(Vec3d(-2, 3, 5));
  TriangleMesh soup;
  for (const auto& t : welded.triangles) {
    const auto base = std::uint32_t(soup.vertices.size());
    for (auto i : t) soup.vertices.push_back(welded.vertices[i]);
    soup.triangles.push_back({base, base + 1, base + 2});
  }
  const MassProperties a = massPropertiesOfMesh(welded, 7.0, "welded");
  const MassProperties b = massPropertiesOfMesh(soup, 7.0, "soup");
  EXPECT_NEAR(b.volume, a.volume, 1e-12);
  EXPECT_NEAR((b.centerOfMass - a.centerOfMass).norm(), 0.0, 1e-12);
  expectMatrixNear(b.inertia, a.inertia, 1e-12);
}

TEST(MassProperties, InwardFacingCubeIsInputError) {
  const TriangleMesh mesh = flipped(unitCubeAt(Vec3d(100, -50, 20)));
  try {
    massPropertiesOfMesh(mesh, 500.0, "scene.json: bodies[0].mesh");
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind("scene.json: bodies[0].mesh: ", 0), 0u) << message;
    EXPECT_NE(message.find("volume"), std::string::npos) << message;
  }
}

TEST(MassProperties, OpenBoxIsInputError) {
  TriangleMesh mesh = unitCubeAt(Vec3d(0, 0, 0));
  mesh.triangles.resize(mesh.triangles.size() - 2);  // the last face is gone
  try {
    massPropertiesOfMesh(mesh, 500.0, "open");
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind("open: ", 0), 0u) << message;
    EXPECT_NE(message.find("not closed"), std::string::npos) << message;
  }
  // Open with no net area either (two opposite faces gone): still refused.
  TriangleMesh tube = unitCubeAt(Vec3d(0, 0, 0));
  tube.triangles.erase(tube.triangles.begin(), tube.triangles.begin() + 4);
  EXPECT_THROW(massPropertiesOfMesh(tube, 500.0, "tube"), InputError);
}

TEST(MassProperties, InconsistentlyOrientedTriangleIsInputError) {
  TriangleMesh mesh = unitCubeAt(Vec3d(0, 0, 0));
  std::swap(mesh.triangles[3][1], mesh.triangles[3][2]);
  EXPECT_THROW(massPropertiesOfMesh(mesh, 500.0, "mixed"), InputError);
}

TEST(MassProperties, BadInputIsInputError) {
  EXPECT_THROW(massPropertiesOfMesh(TriangleMesh{}, 500.0, "empty"), InputError);
  const TriangleMesh cube = unitCubeAt(Vec3d(0, 0, 0));
  EXPECT_THROW(massPropertiesOfMesh(cube, 0.0, "zero density"), InputError);
  EXPECT_THROW(massPropertiesOfMesh(cube, -1.0, "negative density"), InputError);
  EXPECT_THROW(massPropertiesOfMesh(cube, NAN, "nan density"), InputError);
  TriangleMesh badIndex = cube;
  badIndex.triangles[0][0] = 8;
  EXPECT_THROW(massPropertiesOfMesh(badIndex, 500.0, "index"), InputError);
  TriangleMesh nanVertex = cube;
  nanVertex.vertices[0].x() = NAN;
  EXPECT_THROW(massPropertiesOfMesh(nanVertex, 500.0, "nan"), InputError);
  // A closed but flat surface (a square, both sides) bounds nothing.
  TriangleMesh sheet;
  sheet.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  sheet.triangles = {{0, 1, 2}, {0, 2, 3}, {0, 2, 1}, {0, 3, 2}};
  EXPECT_THROW(massPropertiesOfMesh(sheet, 500.0, "sheet"), InputError);
}

TEST(MassProperties, WithMassScalesMassAndInertiaAndKeepsCentre) {
  const Mat3d rotation = Eigen::AngleAxisd(0.4, Vec3d(0, 1, 1).normalized()).toRotationMatrix();
  const MassProperties p = massPropertiesOfMesh(box(Vec3d(1, 2, 3), rotation, Vec3d(1, 2, 3)), 1000.0, "box");
  const MassProperties q = withMass(p, 1500.0);  // a quarter of the mass at 1000 kg/m^3
  EXPECT_DOUBLE_EQ(q.mass, 1500.0);
  EXPECT_DOUBLE_EQ(q.volume, p.volume);
  EXPECT_EQ(q.centerOfMass, p.centerOfMass);
  expectMatrixNear(q.inertia, p.inertia * (1500.0 / p.mass), 1e-12 * p.inertia.norm());
  // The same as computing at density mass / volume.
  const MassProperties r =
      massPropertiesOfMesh(box(Vec3d(1, 2, 3), rotation, Vec3d(1, 2, 3)), 1500.0 / p.volume, "box");
  EXPECT_NEAR(r.mass, q.mass, 1e-12 * q.mass);
  expectMatrixNear(r.inertia, q.inertia, 1e-12 * q.inertia.norm());
  EXPECT_THROW(withMass(p, 0.0), std::invalid_argument);
  EXPECT_THROW(withMass(MassProperties{}, 1.0), std::invalid_argument);
}
