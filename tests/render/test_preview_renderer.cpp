// Silhouettes against analytic projections, background, water colour,
// particles as spheres, empty input (render/PreviewRenderer.h).
#include "render/MeshPrimitives.h"
#include "render/PreviewRenderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

using namespace cascade;
using namespace cascade::render;

// LeakSanitizer (CASCADE_SANITIZE builds): Mesa's OSMesa keeps a few small
// per-context buffers until process exit; they are not ours to free.
extern "C" const char* __lsan_default_suppressions() { return "leak:libOSMesa\nleak:libLLVM\n"; }

namespace {

constexpr int kWidth = 320, kHeight = 240;
constexpr double kPi = 3.14159265358979;

/// One renderer for all tests here (context and shader set-up cost once).
PreviewRenderer& renderer() {
  static RenderLook look = [] {
    RenderLook l;
    l.drawGround = false;  // only the sky behind: exact background checks
    return l;
  }();
  static PreviewRenderer instance(kWidth, kHeight, 4, look);
  return instance;
}

Camera frontCamera(float distance) {
  Camera camera;
  camera.position = {0, -distance, 0};
  camera.target = {0, 0, 0};
  camera.up = {0, 0, 1};
  camera.fovY = 40;
  return camera;
}

/// Sum of alpha / 255: the covered area in pixels (fractional at edges).
double coverage(const Image& image) {
  double sum = 0;
  for (std::size_t i = 3; i < image.rgba.size(); i += 4) sum += image.rgba[i] / 255.0;
  return sum;
}

/// Pixel radius of a sphere of radius r at distance d on the optical axis:
/// its silhouette cone has half-angle asin(r / d).
double projectedRadius(double r, double d, double fovDegrees) {
  return std::tan(std::asin(r / d)) / std::tan(fovDegrees * kPi / 360.0) * (kHeight / 2.0);
}

double polygonArea(std::vector<Eigen::Vector2d> points) {  // convex hull (monotone chain), shoelace
  std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Eigen::Vector2d> hull(2 * points.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], points[i]) <= 0) --k;
    hull[k++] = points[i];
  }
  for (std::size_t i = points.size() - 1, t = k + 1; i > 0; --i) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], points[i - 1]) <= 0) --k;
    hull[k++] = points[i - 1];
  }
  hull.resize(k - 1);
  double area = 0;
  for (std::size_t i = 0; i < hull.size(); ++i) {
    const auto& a = hull[i];
    const auto& b = hull[(i + 1) % hull.size()];
    area += a.x() * b.y() - a.y() * b.x();
  }
  return std::abs(area) / 2;
}

int luminance(const std::uint8_t* p) { return (2 * p[0] + 7 * p[1] + p[2]) / 10; }

} // namespace

TEST(PreviewRenderer, GivesAnOpenGlThreeContextWithMultisampling) {
  EXPECT_NE(renderer().glDescription().find("Mesa"), std::string::npos) << renderer().glDescription();
  EXPECT_EQ(renderer().effectiveSamples(), 4);
}

TEST(PreviewRenderer, SphereSilhouetteMatchesItsPerspectiveProjection) {
  const TriangleMesh sphere = makeIcosphere({0, 0, 0}, 1.0f, 5);  // 20480 triangles
  for (const float distance : {4.0f, 6.5f}) {
    FrameScene scene;
    scene.fluid = &sphere;
    scene.camera = frontCamera(distance);
    const Image image = renderer().render(scene);
    const double radius = projectedRadius(1.0, distance, 40);
    const double expected = kPi * radius * radius;
    EXPECT_NEAR(coverage(image), expected, 0.01 * expected) << "distance " << distance;
  }
}

TEST(PreviewRenderer, RotatedCubeSilhouetteMatchesItsProjectedHull) {
  TriangleMesh cube = makeBox({-0.6f, -0.6f, -0.6f}, {0.6f, 0.6f, 0.6f}, "obstacle");
  const Eigen::Matrix3f rotation = (Eigen::AngleAxisf(0.5f, Eigen::Vector3f::UnitZ()) *
                                    Eigen::AngleAxisf(0.35f, Eigen::Vector3f::UnitX())).toRotationMatrix();
  for (auto& v : cube.vertices) v = rotation * v + Eigen::Vector3f(0.3f, 0.2f, -0.1f);
  for (auto& n : cube.normals) n = rotation * n;
  Camera camera = frontCamera(4.5f);
  camera.position = {1.0f, -4.0f, 1.5f};
  FrameScene scene;
  scene.solids = &cube;
  scene.camera = camera;
  const Image image = renderer().render(scene);

  const Eigen::Matrix4f projection = camera.projectionMatrix(float(kWidth) / kHeight, 0.1f, 100.0f) * camera.viewMatrix();
  std::vector<Eigen::Vector2d> corners;
  for (const auto& v : cube.vertices) {
    const Eigen::Vector4f clip = projection * v.homogeneous();
    corners.emplace_back((clip.x() / clip.w() + 1) * kWidth / 2.0, (clip.y() / clip.w() + 1) * kHeight / 2.0);
  }
  const double expected = polygonArea(corners);
  EXPECT_GT(expected, 2000);
  EXPECT_NEAR(coverage(image), expected, 0.01 * expected);
}

TEST(PreviewRenderer, ParticleSpheresHaveExactSilhouettes) {
  ParticleSpheres particles;
  particles.position = {{0, 0, 0}};
  particles.speed = {0.5f};
  particles.radius = 0.8f;
  FrameScene scene;
  scene.particles = &particles;
  scene.camera = frontCamera(5.0f);
  const Image image = renderer().render(scene);
  const double radius = projectedRadius(0.8, 5.0, 40);
  EXPECT_NEAR(coverage(image), kPi * radius * radius, 0.01 * kPi * radius * radius);
}

TEST(PreviewRenderer, EmptyInputGivesTheBackgroundAndNothingElse) {
  const TriangleMesh empty;
  FrameScene scene;
  scene.fluid = &empty;
  scene.solids = &empty;
  scene.camera = frontCamera(5.0f);
  const Image image = renderer().render(scene);
  ASSERT_EQ(image.width, kWidth);
  ASSERT_EQ(image.height, kHeight);
  EXPECT_EQ(coverage(image), 0.0);
  // The sky: brighter and bluer towards the zenith than at the horizon row.
  const std::uint8_t* top = image.pixel(kWidth / 2, 2);
  const std::uint8_t* horizon = image.pixel(kWidth / 2, kHeight / 2);
  EXPECT_GT(top[2], top[0]);
  EXPECT_LT(top[0], horizon[0]);
}

TEST(PreviewRenderer, WaterLeavesTheBackgroundUntouchedAndIsWaterColoured) {
  const TriangleMesh sphere = makeIcosphere({0, 0, 0}, 1.0f, 5);
  const TriangleMesh empty;
  FrameScene scene;
  scene.camera = frontCamera(5.0f);
  scene.stage = Box3f(Eigen::Vector3f(-1, -1, -1), Eigen::Vector3f(1, 1, 1));
  scene.fluid = &empty;
  const Image background = renderer().render(scene);
  scene.fluid = &sphere;
  const Image water = renderer().render(scene);

  const double radius = projectedRadius(1.0, 5.0, 40);
  const double cx = kWidth / 2.0, cy = kHeight / 2.0;
  int outside = 0, differing = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double r = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
      if (r < radius + 2) continue;
      ++outside;
      if (!std::equal(water.pixel(x, y), water.pixel(x, y) + 4, background.pixel(x, y))) ++differing;
    }
  EXPECT_GT(outside, kWidth * kHeight / 2);
  EXPECT_EQ(differing, 0) << "pixels away from the water differ from the empty frame";

  // Where the water is thick (the centre): blue-green, unlike the sky there.
  const std::uint8_t* centre = water.pixel(kWidth / 2, kHeight / 2);
  const std::uint8_t* sky = background.pixel(kWidth / 2, kHeight / 2);
  EXPECT_EQ(centre[3], 255);
  EXPECT_GT(centre[2], centre[0] + 40) << int(centre[0]) << " " << int(centre[1]) << " " << int(centre[2]);
  EXPECT_GT(centre[1], centre[0] + 20);
  EXPECT_GT(std::abs(int(centre[0]) - int(sky[0])) + std::abs(int(centre[1]) - int(sky[1])) +
                std::abs(int(centre[2]) - int(sky[2])),
            60);
  // Fresnel: near the rim the water mirrors the bright sky, so it is lighter
  // than at the centre, where it looks into the deep water.
  double rim = 0;
  int rimCount = 0;
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      const double r = std::hypot(x + 0.5 - cx, y + 0.5 - cy);
      if (r > 0.9 * radius && r < 0.96 * radius) {
        rim += luminance(water.pixel(x, y));
        ++rimCount;
      }
    }
  EXPECT_GT(rim / rimCount, luminance(centre) + 15);
}

TEST(PreviewRenderer, KeyLightCastsShadowsWhereTheGeometrySaysSo) {
  // A block on a floor; the sun travels along (1, 0, -1): the shadow falls on +x.
  TriangleMesh solids = makeBox({-2, -2, -0.05f}, {2, 2, 0}, "floor");
  appendMesh(solids, makeBox({-0.25f, -0.25f, 0}, {0.25f, 0.25f, 1}, "block"));
  Light sun;
  sun.direction = {1, 0, -1};
  FrameScene scene;
  scene.solids = &solids;
  scene.lights = {sun};
  scene.camera.position = {0, -0.01f, 7};
  scene.camera.target = {0, 0, 0};
  scene.camera.up = {0, 1, 0};
  scene.camera.fovY = 40;
  const Image image = renderer().render(scene);
  const Eigen::Matrix4f projection =
      scene.camera.projectionMatrix(float(kWidth) / kHeight, 0.1f, 100.0f) * scene.camera.viewMatrix();
  auto at = [&](float x, float y) {
    const Eigen::Vector4f clip = projection * Eigen::Vector4f(x, y, 0, 1);
    const int px = int((clip.x() / clip.w() + 1) * kWidth / 2), py = int((1 - clip.y() / clip.w()) * kHeight / 2);
    return luminance(image.pixel(px, py));
  };
  const int shadowed = at(0.75f, 0.0f), litOpposite = at(-0.75f, 0.0f), litBeside = at(0.75f, 0.8f);
  EXPECT_LT(shadowed, 0.7 * litOpposite) << shadowed << " vs " << litOpposite;
  EXPECT_LT(shadowed, 0.7 * litBeside) << shadowed << " vs " << litBeside;
  EXPECT_NEAR(litOpposite, litBeside, 8);
  // Beyond the shadow's end (the block is 1 high: the shadow reaches x = 1.25).
  EXPECT_NEAR(at(1.6f, 0.0f), litBeside, 8);
}
