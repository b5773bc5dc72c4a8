// Unit tests of the boundary geometry: mirror maps, type I sampling (gaps,
// SEED 7-point triangles, area-true rows), mesh loading, simplification, closure and inside tests.
#include "libsph/Errors.h"
#include "libsph/boundary/BoundaryParticles.h"
#include "libsph/boundary/BoundarySampling.h"
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/boundary/MeshBoundary.h"
#include "libsph/boundary/PlaneBoundary.h"
#include "libsph/boundary/TriangleBand.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/TriangleMesh.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <random>

namespace cascade {

namespace {

Real largestHole(const std::vector<Vec3r>& samples, const std::vector<Vec3r>& probes) {
  Real worst = 0;
  for (const Vec3r& p : probes) {
    Real best = std::numeric_limits<Real>::max();
    for (const Vec3r& s : samples) best = std::min(best, (s - p).norm());
    worst = std::max(worst, best);
  }
  return worst;
}

/// Uniform random points on the mesh's triangles (the k-th on triangle k mod count).
std::vector<Vec3r> randomPointsOnTriangles(const TriangleMesh& mesh, int count, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<Vec3r> points;
  for (int k = 0; k < count; ++k) {
    float a = u(random), b = u(random);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const std::array<std::uint32_t, 3>& tri = mesh.triangles[std::size_t(k) % mesh.triangles.size()];
    const Vec3r p0 = mesh.vertices[tri[0]].cast<Real>(), p1 = mesh.vertices[tri[1]].cast<Real>(),
                p2 = mesh.vertices[tri[2]].cast<Real>();
    points.push_back(p0 + a * (p1 - p0) + b * (p2 - p0));
  }
  return points;
}

/// The bunny scene's mesh (the SEED's 3,851-triangle scan, holes filled,
/// simplified to 900 triangles), 0.2 m wide; null if the asset is missing.
std::unique_ptr<MeshBoundary> loadScanBunny() {
  const std::string path = std::string(CASCADE_SOURCE_DIR) + "/scenes/assets/bunny_res3.ply";
  if (!std::filesystem::exists(path)) {
    ADD_FAILURE() << path << " missing";
    return nullptr;
  }
  MeshObstacleOptions options;
  options.targetTriangles = 900;
  options.transform.scale = 1.28455f;
  return MeshBoundary::load(path, options);
}

std::filesystem::path writeTemp(const std::string& name, const std::string& text) {
  const auto path = std::filesystem::temp_directory_path() / ("cascade_solver_test_" + name);
  writeTextAtomically(path, text);
  return path;
}

const char* kCubeObj =
    "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
    "f 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";

} // namespace

TEST(MirrorMap, ReflectsAcrossThePlaneAndIsAnInvolution) {
  const MirrorMap map = MirrorMap::reflection(Vec3r(0, 0, 1), Vec3r(0, 0, 1), 3);
  const Vec3r x(0.3f, -0.2f, 1.25f);
  EXPECT_TRUE(map.apply(x).isApprox(Vec3r(0.3f, -0.2f, 0.75f)));
  EXPECT_TRUE(map.apply(map.apply(x)).isApprox(x));
  EXPECT_EQ(map.boundary, 3u);
  // Free slip: the normal velocity component flips, the tangential one stays.
  EXPECT_TRUE((map.linear * Vec3r(1, 2, 3)).isApprox(Vec3r(1, 2, -3)));
}

TEST(BoxBoundary, TankCornerSeesAllSevenImages) {
  auto tank = BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(1, 1, 1));
  std::vector<MirrorMap> maps;
  tank->mirrorMaps(Vec3r(0.01f, 0.02f, 0.03f), 0.1f, 0, maps);
  ASSERT_EQ(maps.size(), 7u);  // 3 walls, 3 edges, 1 corner
  // The corner image is the point reflection through the corner.
  bool foundCorner = false;
  for (const MirrorMap& m : maps)
    if (m.apply(Vec3r(0.01f, 0.02f, 0.03f)).isApprox(Vec3r(-0.01f, -0.02f, -0.03f))) foundCorner = true;
  EXPECT_TRUE(foundCorner);
  maps.clear();
  tank->mirrorMaps(Vec3r(0.5f, 0.5f, 0.5f), 0.1f, 0, maps);
  EXPECT_TRUE(maps.empty());
  // Open top: no image across z = 1.
  maps.clear();
  tank->mirrorMaps(Vec3r(0.5f, 0.5f, 0.99f), 0.1f, 0, maps);
  EXPECT_TRUE(maps.empty());
  EXPECT_TRUE(tank->isInside(Vec3r(0.5f, 0.5f, -0.1f)));
  EXPECT_FALSE(tank->isInside(Vec3r(0.5f, 0.5f, 3.0f)));  // above the open top is not a wall
}

// In a tank narrower than twice the mirror range (a flume's slab) a particle lies within
// range of both side walls, and the images it needs across the floor's edges are those of
// both: the product with the far wall is not the product with the near one. Every image
// is checked against the reflections across each subset of the walls within range that
// takes at most one wall of an axis, and nothing else is imaged.
TEST(BoxBoundary, NarrowTankImagesTheEdgesAndCornersOfBothSideWalls) {
  const Vec3r size(1, 0.04f, 1);
  auto tank = BoxBoundary::tank(Vec3r(0, 0, 0), size);
  const Real range = 0.1f;
  for (const Vec3r& x : {Vec3r(0.5f, 0.03f, 0.02f), Vec3r(0.02f, 0.012f, 0.03f), Vec3r(0.97f, 0.025f, 0.05f)}) {
    std::vector<MirrorMap> maps;
    tank->mirrorMaps(x, range, 0, maps);
    // The walls within range, per axis: (axis, side) with the wall at 0 (side 0) or size.
    std::vector<std::vector<int>> near(3);
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side) {
        const Real distance = side ? size[axis] - x[axis] : x[axis];
        if (distance < range && !(axis == 2 && side == 1)) near[std::size_t(axis)].push_back(side);
      }
    std::vector<Vec3r> expected;
    for (int sx = -1; sx < int(near[0].size()); ++sx)
      for (int sy = -1; sy < int(near[1].size()); ++sy)
        for (int sz = -1; sz < int(near[2].size()); ++sz) {
          if (sx < 0 && sy < 0 && sz < 0) continue;
          Vec3r image = x;
          const int chosen[3] = {sx, sy, sz};
          for (int axis = 0; axis < 3; ++axis)
            if (chosen[axis] >= 0)
              image[axis] = near[std::size_t(axis)][std::size_t(chosen[axis])] ? 2 * size[axis] - image[axis] : -image[axis];
          expected.push_back(image);
        }
    ASSERT_EQ(maps.size(), expected.size()) << x.transpose();
    for (const Vec3r& image : expected) {
      const bool found = std::any_of(maps.begin(), maps.end(),
                                     [&](const MirrorMap& m) { return m.apply(x).isApprox(image, 1e-5f); });
      EXPECT_TRUE(found) << "no image at " << image.transpose() << " of " << x.transpose();
    }
  }
  // The first point: walls y = 0, y = 0.04 and the floor, and their two edges: 5 images.
  // Before, the edge with the floor was that of the first wall in range, y = 0, the
  // farther one: 4 images, and none across the corner next to the particle.
  std::vector<MirrorMap> maps;
  tank->mirrorMaps(Vec3r(0.5f, 0.03f, 0.02f), range, 0, maps);
  EXPECT_EQ(maps.size(), 5u);
}

TEST(BoxBoundary, SolidBlockMirrorsAcrossTheNearestFaceAndEdge) {
  const auto rotation = Transform::rotationFromEulerDegrees(Vec3r(0, 30, 0));
  auto box = BoxBoundary::solid(Vec3r(0, 0, 0), Vec3r(1, 1, 0.1f), rotation);
  const Vec3r top = rotation * Vec3r(0.2f, 0.3f, 0.15f);  // 0.05 above the inclined top face
  std::vector<MirrorMap> maps;
  box->mirrorMaps(top, 0.1f, 0, maps);
  ASSERT_EQ(maps.size(), 1u);
  EXPECT_TRUE(maps[0].apply(top).isApprox(rotation * Vec3r(0.2f, 0.3f, 0.05f), 1e-5f));
  EXPECT_TRUE(box->isInside(rotation * Vec3r(0.5f, 0.5f, 0.0f)));
  EXPECT_FALSE(box->isInside(top));
}

TEST(BoxBoundary, SamplesLeaveNoGapWiderThanAsked) {
  auto tank = BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.3f, 0.2f, 0.1f));
  std::vector<Vec3r> samples;
  const Real gap = 0.01f;
  tank->sampleSurface(gap, samples);
  std::mt19937 random(3);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<Vec3r> probes;  // random points on the floor and on the x = 0 wall
  for (int k = 0; k < 300; ++k) {
    probes.emplace_back(0.3f * u(random), 0.2f * u(random), 0.0f);
    probes.emplace_back(0.0f, 0.2f * u(random), 0.1f * u(random));
  }
  // On a square grid of spacing <= gap, no point is farther than gap / sqrt(2).
  EXPECT_LE(largestHole(samples, probes), gap * 0.7072f);
}

TEST(BoxBoundary, EdgeAndCornerSamplesAppearOnce) {
  // Walls sharing an edge put the same lattice points on it; each must be
  // sampled once (a doubled sample doubles SEED (11)'s force there). The count
  // must equal the full lattices of all walls with coincident points merged.
  const Real gap = 0.013f;
  const auto rotation = Transform::rotationFromEulerDegrees(Vec3r(10, 25, -40));
  const BoundaryPtr boxes[] = {BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.3f, 0.2f, 0.1f)),
                               BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.3f, 0.2f, 0.1f), true),
                               BoxBoundary::solid(Vec3r(0.1f, -0.2f, 0.3f), Vec3r(0.2f, 0.05f, 0.12f), rotation)};
  for (const BoundaryPtr& box : boxes) {
    std::vector<Vec3r> samples;
    box->sampleSurface(gap, samples);
    std::vector<Vec3r> merged = samples;
    removeDuplicateSamples(merged, gap * 0.01f);
    EXPECT_EQ(merged.size(), samples.size()) << box->kind() << ": duplicated edge samples";
    // Every wall's whole lattice, merged: the same count.
    std::vector<Vec3r> lattices;
    const auto* b = static_cast<const BoxBoundary*>(box.get());
    Vec3r lo, hi;
    b->bounds(lo, hi);
    const TriangleMesh mesh = b->surfaceMesh();
    for (std::size_t f = 0; f + 1 < mesh.triangles.size(); f += 2) {
      // each wall is two triangles (corners 0, 1, 2, 3 of a rectangle)
      const Vec3r c0 = mesh.vertices[mesh.triangles[f][0]].cast<Real>();
      const Vec3r c1 = mesh.vertices[mesh.triangles[f][1]].cast<Real>();
      const Vec3r c3 = mesh.vertices[mesh.triangles[f + 1][2]].cast<Real>();
      const Vec3r u = c1 - c0, v = c3 - c0;
      const long nu = rectangleIntervals(Real(0.5) * u.norm(), gap), nv = rectangleIntervals(Real(0.5) * v.norm(), gap);
      for (long j = 0; j <= nv; ++j)
        for (long i = 0; i <= nu; ++i) lattices.push_back(c0 + (Real(i) / Real(nu)) * u + (Real(j) / Real(nv)) * v);
    }
    removeDuplicateSamples(lattices, gap * 0.01f);
    EXPECT_EQ(lattices.size(), samples.size()) << box->kind();
  }
}

TEST(BoundaryParticles, SampleListsAndMirrorMapsEqualAFullScanOnWallsSlopeMeshAndPlane) {
  // Type I lists come from the walls' lattices (plane coordinates) and from a
  // cell grid (mesh samples), both behind a coarse proximity grid that skips the
  // lattices and boundaries out of reach: every list must be exactly the
  // brute-force set of samples within the radius, every particle's mirror maps
  // exactly those of asking every boundary in turn, and the samples exactly the
  // boundaries' samples. Particles also above the open tank's rim and outside it. And
  // the solids the guard asks for a move are all it may enter.
  std::vector<BoundaryPtr> boundaries;
  boundaries.push_back(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.6f, 0.3f, 0.3f)));
  boundaries.push_back(BoxBoundary::solid(Vec3r(0.2f, 0.15f, 0.08f), Vec3r(0.15f, 0.1f, 0.02f),
                                          Transform::rotationFromEulerDegrees(Vec3r(0, 20, 10))));
  const auto cubePath = writeTemp("cube_lists.obj", kCubeObj);
  MeshObstacleOptions options;
  options.transform.scale = 0.1f;
  options.transform.translation = Vec3r(0.4f, 0.1f, 0.0f);
  boundaries.push_back(MeshBoundary::load(cubePath, options));
  std::filesystem::remove(cubePath);
  boundaries.push_back(PlaneBoundary::infinite(Vec3r(0, 0, 0.25f), Vec3r(0, 0, -1), 0.1f));  // mirrors everywhere
  // A shelf high above the tank: the proximity grid then reaches over the rim, where the
  // open tank's cells are marked by its own test (Boundary::mayMirrorNear).
  boundaries.push_back(BoxBoundary::solid(Vec3r(0.3f, 0.15f, 0.7f), Vec3r(0.05f, 0.05f, 0.01f),
                                          Eigen::Matrix<Real, 3, 3>::Identity()));
  const Real gap = 0.006f, radius = 0.011f, mirrorRange = 0.02f;
  BoundaryParticles virtualParticles;
  virtualParticles.sample(boundaries, gap, radius);
  const std::vector<Vec3r>& samples = virtualParticles.samplePositions();
  std::size_t expected = 0;
  for (const BoundaryPtr& b : boundaries) {
    std::vector<Vec3r> own;
    b->sampleSurface(gap, own);
    expected += own.size();
  }
  EXPECT_EQ(samples.size(), expected);
  const std::vector<std::size_t> perBoundary = virtualParticles.samplesPerBoundary(boundaries.size());
  EXPECT_GT(perBoundary[2], 0u);

  Particles particles;
  std::mt19937 random(11);
  std::uniform_real_distribution<float> u(-0.02f, 1.02f);
  for (std::uint32_t k = 0; k < 3000; ++k)
    particles.add(Vec3r(0.6f * u(random), 0.3f * u(random), 0.33f * u(random)), Vec3r::Zero(), k);
  // Spray far above the open tank's rim, next to its side walls (which mirror at any height).
  std::uniform_real_distribution<float> high(0.35f, 0.6f), wall(-0.005f, 0.015f);
  for (std::uint32_t k = 0; k < 300; ++k)
    particles.add(Vec3r(wall(random), 0.3f * u(random), high(random)), Vec3r::Zero(), std::uint32_t(particles.size()));
  // Some exactly on a wall lattice and on mesh samples.
  for (std::size_t k = 0; k < samples.size(); k += samples.size() / 50)
    particles.add(samples[k], Vec3r::Zero(), std::uint32_t(particles.size()));
  virtualParticles.update(particles, boundaries, radius, mirrorRange, true, true);
  std::size_t withMaps = 0, junctions = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    std::vector<MirrorMap> expectedMaps;
    for (std::uint32_t b = 0; b < boundaries.size(); ++b)
      boundaries[b]->mirrorMaps(particles.position[i], mirrorRange, b, expectedMaps);
    const std::size_t own = expectedMaps.size();
    addJunctionMaps(particles.position[i], mirrorRange, boundaries, expectedMaps, 0);
    junctions += expectedMaps.size() - own;
    ASSERT_EQ(virtualParticles.mirrorCount(i), expectedMaps.size()) << "particle " << i;
    for (std::size_t m = 0; m < expectedMaps.size(); ++m) {
      const MirrorMap& found = virtualParticles.mirrors()[virtualParticles.mirrorOffsets()[i] + m];
      EXPECT_EQ(found.boundary, expectedMaps[m].boundary);
      EXPECT_EQ(found.linear, expectedMaps[m].linear);
      EXPECT_EQ(found.offset, expectedMaps[m].offset);
    }
    withMaps += expectedMaps.empty() ? 0 : 1;
  }
  EXPECT_GT(withMaps, 500u);
  EXPECT_GT(junctions, 10u);  // the cube on the floor
  const NeighborLists& lists = virtualParticles.sampleNeighbors();
  std::size_t nonEmpty = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    std::vector<std::uint32_t> found(lists.begin(i), lists.end(i)), brute;
    for (std::uint32_t k = 0; k < samples.size(); ++k)
      if (squaredDistance(particles.position[i], samples[k]) <= radius * radius) brute.push_back(k);
    std::sort(found.begin(), found.end());
    ASSERT_EQ(found, brute) << "particle " << i << " at " << particles.position[i].transpose();
    nonEmpty += brute.empty() ? 0 : 1;
  }
  EXPECT_GT(nonEmpty, 100u);

  // The guard (Simulation::keepOutOfSolids) asks only the solids marked where a move
  // ends, for moves shorter than the proximity's reach: every solid such a move enters
  // must be marked there.
  const Real reach = virtualParticles.proximityReach();
  ASSERT_GT(reach, 0);
  std::uniform_real_distribution<float> direction(-1.0f, 1.0f), length(0.0f, 0.99f);
  std::size_t entries = 0;
  for (std::size_t i = 0; i < particles.size(); ++i)
    for (int move = 0; move < 4; ++move) {
      Vec3r d(direction(random), direction(random), direction(random));
      if (d.norm() < 1e-3f) continue;
      const Vec3r from = particles.position[i], to = from + (reach * length(random) / d.norm()) * d;
      for (std::uint32_t b = 0; b < boundaries.size(); ++b) {
        Vec3r exit, normal;
        if (!boundaries[b]->penetrated(from, to, 0.001f, exit, normal)) continue;
        ++entries;
        EXPECT_TRUE((virtualParticles.boundariesNear(to) >> b) & 1u)
            << "a move into boundary " << b << " ends at " << to.transpose();
      }
    }
  EXPECT_GT(entries, 200u);
}

TEST(BoundaryParticles, SolidsMeetingAtRightAnglesMirrorAcrossBoth) {
  // A paddle (a mesh box) standing half a millimetre off a tank's floor and side wall, as
  // a flume's: a particle in the corner before it sees the floor's, the wall's and the
  // tank edge's maps, the paddle face's, and their three products, whose images are the
  // reflections across all their planes; the products image only the water in front of
  // the paddle. Lifted 2 cm off the floor, the paddle meets the wall alone.
  std::vector<BoundaryPtr> boundaries;
  boundaries.push_back(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.5f, 0.06f, 0.3f)));
  const auto cubePath = writeTemp("paddle_corner.obj", kCubeObj);
  MeshObstacleOptions options;
  options.transform.scale = 0.02f;  // a 2 cm cube, its front face at x = 0.05
  options.transform.translation = Vec3r(0.03f, 0.0005f, 0.0005f);
  boundaries.push_back(MeshBoundary::load(cubePath, options));
  const Real range = 0.03f;
  const Vec3r x(0.055f, 0.005f, 0.004f);
  const auto reflect = [](Vec3r p, int axis, Real plane) {
    p[axis] = 2 * plane - p[axis];
    return p;
  };
  std::vector<MirrorMap> maps;
  for (std::uint32_t b = 0; b < boundaries.size(); ++b) boundaries[b]->mirrorMaps(x, range, b, maps);
  ASSERT_EQ(maps.size(), 4u);  // floor, wall, their edge; the paddle's face
  addJunctionMaps(x, range, boundaries, maps, 0);
  ASSERT_EQ(maps.size(), 7u);
  const Vec3r paddle = reflect(x, 0, 0.05f);
  const Vec3r expected[3] = {reflect(paddle, 1, 0), reflect(paddle, 2, 0), reflect(reflect(paddle, 1, 0), 2, 0)};
  for (const Vec3r& image : expected) {
    bool found = false;
    for (std::size_t m = 4; m < maps.size(); ++m)
      if (maps[m].apply(x).isApprox(image, 1e-5f)) {
        found = true;
        EXPECT_EQ(maps[m].boundary, 1u);  // the paddle's
        EXPECT_TRUE(maps[m].frontOnly);
        EXPECT_FALSE(maps[m].behind(x, Vec3r(0.07f, 0.01f, 0.01f)));  // water in front of the paddle
        EXPECT_TRUE(maps[m].behind(x, Vec3r(0.02f, 0.01f, 0.01f)));   // water behind it
      }
    EXPECT_TRUE(found) << "no map images the corner particle at " << image.transpose();
  }
  // Lifted off the floor: its face and the floor still meet at right angles, but not there.
  options.transform.translation = Vec3r(0.03f, 0.0005f, 0.02f);
  boundaries[1] = MeshBoundary::load(cubePath, options);
  std::filesystem::remove(cubePath);
  const Vec3r beside(0.055f, 0.005f, 0.025f);
  maps.clear();
  for (std::uint32_t b = 0; b < boundaries.size(); ++b) boundaries[b]->mirrorMaps(beside, range, b, maps);
  ASSERT_EQ(maps.size(), 4u);
  addJunctionMaps(beside, range, boundaries, maps, 0);
  ASSERT_EQ(maps.size(), 5u);  // with the wall only
  EXPECT_TRUE(maps[4].apply(beside).isApprox(reflect(reflect(beside, 0, 0.05f), 1, 0), 1e-5f));
}

TEST(TriangleBand, ClosestPointEqualsAScanOverAllTriangles) {
  // The scan bunny (900 triangles, 0.2 m): the band's answer within the range
  // must be the scan's (same triangle, lowest index on ties; none beyond range).
  auto bunny = loadScanBunny();
  ASSERT_TRUE(bunny);
  const TriangleMesh& mesh = bunny->mesh();
  std::vector<Vec3d> a, b, c;
  for (const auto& t : mesh.triangles) {
    a.push_back(mesh.vertices[t[0]].cast<double>());
    b.push_back(mesh.vertices[t[1]].cast<double>());
    c.push_back(mesh.vertices[t[2]].cast<double>());
  }
  const double range = 0.02;
  const TriangleBand band(a, b, c, range);
  Vec3r lo, hi;
  bunny->bounds(lo, hi);
  std::mt19937 random(13);
  std::uniform_real_distribution<double> u(-0.1, 1.1);
  std::size_t hits = 0;
  for (int k = 0; k < 4000; ++k) {
    const Vec3d p(lo.x() + u(random) * (hi.x() - lo.x()), lo.y() + u(random) * (hi.y() - lo.y()),
                  lo.z() + u(random) * (hi.z() - lo.z()));
    double best = range * range;
    long bestTriangle = -1;
    for (std::size_t t = 0; t < a.size(); ++t) {
      const double d2 = (closestOnTriangle(p, a[t], b[t], c[t]) - p).squaredNorm();
      if (d2 < best) best = d2, bestTriangle = long(t);
    }
    Vec3d point;
    ASSERT_EQ(band.closest(p, point), bestTriangle) << "at " << p.transpose();
    hits += bestTriangle >= 0;
  }
  EXPECT_GT(hits, 500u);
}

TEST(MeshSampling, ScanBunnySeamsAreSampledOnce) {
  // The filled scan has vertices at equal positions on both sides of seams:
  // each position must still give one sample (a doubled sample doubles SEED (11)).
  auto bunny = loadScanBunny();
  ASSERT_TRUE(bunny);
  const Real gap = 0.004f;
  const std::vector<Vec3r> samples = sampleTriangles(bunny->mesh(), gap);
  std::vector<Vec3r> merged = samples;
  removeDuplicateSamples(merged, gap * 1e-3f);
  EXPECT_EQ(merged.size(), samples.size());
}

TEST(MeshSampling, SevenPointsPerTriangleSharedOnce) {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {0.01f, 0, 0}, {0, 0.01f, 0}, {0.01f, 0.01f, 0}};
  mesh.triangles = {{0, 1, 2}};
  EXPECT_EQ(sampleTriangles(mesh, 0.01f).size(), 7u);
  mesh.triangles.push_back({1, 3, 2});
  // 4 vertices + 5 edge midpoints + 2 centroids
  EXPECT_EQ(sampleTriangles(mesh, 0.01f).size(), 11u);
}

/// Samples per area / gap^2 of a mesh's sampling.
double areaRatio(std::size_t samples, const TriangleMesh& mesh, Real gap) {
  return double(samples) * double(gap) * double(gap) / surfaceArea(mesh);
}

/// Every sample once (a doubled sample doubles SEED (11) there).
void expectEachSampleOnce(const std::vector<Vec3r>& samples, Real gap, const std::string& what) {
  std::vector<Vec3r> merged = samples;
  removeDuplicateSamples(merged, gap * 1e-3f);
  EXPECT_EQ(merged.size(), samples.size()) << what;
}

TEST(MeshSampling, LargeTrianglesAreSampledAreaTrue) {
  // The 1-to-4 subdivision sampled a thin triangle as if it were square (the 1:50
  // strip below got ~80x its area's samples); rows keep the count at area / gap^2 plus
  // the edges' share for any shape, with no point of the surface farther than the
  // gap from a sample (a square wall: gap / sqrt 2, as the walls' lattices).
  const Real gap = 0.01f;
  struct Case {
    const char* name;
    TriangleMesh mesh;
    double maxRatio, maxHole;
  };
  std::vector<Case> cases;
  const auto add = [&](const char* name, std::vector<Eigen::Vector3f> vertices,
                       std::vector<std::array<std::uint32_t, 3>> triangles, double maxRatio, double maxHole) {
    TriangleMesh mesh;
    mesh.vertices = std::move(vertices);
    mesh.triangles = std::move(triangles);
    cases.push_back({name, std::move(mesh), maxRatio, maxHole});
  };
  // edges (perimeter / gap) are a large share of a one-triangle mesh's area / gap^2 (here 0.2 of it)
  add("right triangle 1 x 1 m", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, 1.1, 0.75);
  add("square 1 x 1 m", {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 2, 3}}, 1.06, 0.72);
  add("strip 2.5 x 0.05 m (1:50)", {{0, 0, 0}, {2.5f, 0, 0}, {2.5f, 0.05f, 0}, {0, 0.05f, 0}}, {{0, 1, 2}, {0, 2, 3}},
      1.3, 0.9);
  add("triangle 5 x 0.1 m (1:50)", {{0, 0, 0}, {5, 0, 0}, {1.5f, 0.1f, 0}}, {{0, 1, 2}}, 1.25, 0.9);
  for (const Case& c : cases) {
    std::size_t rowSampled = 0;
    const std::vector<Vec3r> samples = sampleTriangles(c.mesh, gap, &rowSampled);
    EXPECT_EQ(rowSampled, c.mesh.triangles.size()) << c.name;
    expectEachSampleOnce(samples, gap, c.name);
    const double ratio = areaRatio(samples.size(), c.mesh, gap);
    EXPECT_GE(ratio, 1.0) << c.name;
    EXPECT_LE(ratio, c.maxRatio) << c.name;
    EXPECT_LE(largestHole(samples, randomPointsOnTriangles(c.mesh, 4000, 11)), c.maxHole * gap) << c.name;
  }
}

TEST(MeshSampling, NeighboursOfDifferentSizesShareEdgePointsOnce) {
  // A long thin triangle sampled by rows next to a small one (the SEED's 7 points)
  // across a shared edge: the edge is sampled once, from its length alone (0.015 m at
  // gap 0.01: its midpoint), every point appears once, and no gap exceeds the limit.
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {0.2f, 0, 0}, {0, 0.015f, 0}, {-0.01f, 0.0075f, 0}};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  const Real gap = 0.01f;
  std::size_t rowSampled = 0;
  const std::vector<Vec3r> samples = sampleTriangles(mesh, gap, &rowSampled);
  EXPECT_EQ(rowSampled, 1u);
  expectEachSampleOnce(samples, gap, "two triangles");
  // On the shared edge x = 0: its end vertices and its midpoint, nothing else.
  const long onSharedEdge = std::count_if(samples.begin(), samples.end(), [](const Vec3r& s) {
    return std::abs(s.x()) < 1e-6f && std::abs(s.z()) < 1e-6f;
  });
  EXPECT_EQ(onSharedEdge, 3);
  EXPECT_LE(largestHole(samples, randomPointsOnTriangles(mesh, 2000, 7)), gap);
}

TEST(MeshSampling, ShippedMeshesAreAreaTrueAtProductionGaps) {
  // The tower at the production tower's gap (1.35 mm) had 20.8x its area's samples,
  // the bunny at the production bunny scene's scale and gap (1.25 mm) several times.
  struct Mesh {
    std::string name;
    std::unique_ptr<MeshBoundary> boundary;
    Real gap;
  };
  std::vector<Mesh> meshes;
  meshes.push_back({"tower", MeshBoundary::load(std::string(CASCADE_SOURCE_DIR) + "/scenes/assets/tower.obj", {}), 0.00135f});
  {
    MeshObstacleOptions options;
    options.targetTriangles = 900;
    options.transform.scale = 1.926825f;
    meshes.push_back(
        {"bunny", MeshBoundary::load(std::string(CASCADE_SOURCE_DIR) + "/scenes/assets/bunny_res3.ply", options), 0.00125f});
  }
  for (const Mesh& m : meshes) {
    const TriangleMesh& mesh = m.boundary->mesh();
    const std::vector<Vec3r> samples = sampleTriangles(mesh, m.gap);
    expectEachSampleOnce(samples, m.gap, m.name);
    const double ratio = areaRatio(samples.size(), mesh, m.gap);
    EXPECT_GE(ratio, 1.0) << m.name;
    EXPECT_LE(ratio, 1.5) << m.name;
    EXPECT_LE(largestHole(samples, randomPointsOnTriangles(mesh, int(4 * mesh.triangles.size()), 5)), m.gap) << m.name;
  }
}

TEST(MeshBoundary, CubeInsideTestMirrorsAndTransform) {
  const auto path = writeTemp("cube.obj", kCubeObj);
  MeshObstacleOptions options;
  options.transform.scale = 2;
  options.transform.translation = Vec3r(1, 0, 0);
  auto cube = MeshBoundary::load(path, options);
  EXPECT_EQ(cube->triangleCount(), 12u);
  EXPECT_TRUE(cube->isInside(Vec3r(2, 1, 1)));
  EXPECT_FALSE(cube->isInside(Vec3r(0.9f, 1, 1)));
  EXPECT_FALSE(cube->isInside(Vec3r(2, 1, 2.1f)));
  EXPECT_NEAR(cube->windingNumber(Vec3r(2.5f, 0.5f, 1.5f)), 1.0, 1e-6);
  std::vector<MirrorMap> maps;
  cube->mirrorMaps(Vec3r(2, 1, 2.05f), 0.1f, 4, maps);  // 0.05 above the top face z = 2
  ASSERT_EQ(maps.size(), 1u);
  EXPECT_TRUE(maps[0].apply(Vec3r(2, 1, 2.05f)).isApprox(Vec3r(2, 1, 1.95f), 1e-5f));
  maps.clear();
  cube->mirrorMaps(Vec3r(2, 1, 1), 0.1f, 4, maps);  // inside: no mirror
  EXPECT_TRUE(maps.empty());
  std::filesystem::remove(path);
}

// The guard after each step (Simulation::keepOutOfSolids): a move that enters the
// solid (ends inside, or passes through) is reported with an exit point outside,
// clearance off where it entered, and that face's outward normal; moves that stay
// outside, or start inside, are not.
TEST(MeshBoundary, PenetratedGivesAnExitOffTheFaceCrossed) {
  const auto path = writeTemp("cube.obj", kCubeObj);
  auto cube = MeshBoundary::load(path, MeshObstacleOptions());  // [0, 1]^3
  const Real clearance = 0.01f;
  Vec3r exit, normal;
  // Into the top face z = 1 at y = 0.48 (0.4 of the way).
  ASSERT_TRUE(cube->penetrated(Vec3r(0.5f, 0.5f, 1.02f), Vec3r(0.5f, 0.45f, 0.97f), clearance, exit, normal));
  EXPECT_TRUE(normal.isApprox(Vec3r(0, 0, 1), 1e-6f)) << normal.transpose();
  EXPECT_TRUE(exit.isApprox(Vec3r(0.5f, 0.48f, 1.01f), 1e-5f)) << exit.transpose();
  EXPECT_FALSE(cube->isInside(exit));
  // Through the side x = 0, from farther than the step's length: still found.
  ASSERT_TRUE(cube->penetrated(Vec3r(-0.3f, 0.5f, 0.5f), Vec3r(0.1f, 0.5f, 0.5f), clearance, exit, normal));
  EXPECT_TRUE(normal.isApprox(Vec3r(-1, 0, 0), 1e-6f)) << normal.transpose();
  EXPECT_TRUE(exit.isApprox(Vec3r(-clearance, 0.5f, 0.5f), 1e-5f)) << exit.transpose();
  // Through the whole cube in one move (a thin part): entered through the top.
  ASSERT_TRUE(cube->penetrated(Vec3r(0.3f, 0.3f, 1.2f), Vec3r(0.3f, 0.3f, -0.2f), clearance, exit, normal));
  EXPECT_TRUE(exit.isApprox(Vec3r(0.3f, 0.3f, 1.01f), 1e-5f)) << exit.transpose();
  EXPECT_FALSE(cube->penetrated(Vec3r(0.5f, 0.5f, 1.05f), Vec3r(0.5f, 0.5f, 1.001f), clearance, exit, normal));
  EXPECT_FALSE(cube->penetrated(Vec3r(0.5f, 0.5f, 0.5f), Vec3r(0.5f, 0.5f, 0.6f), clearance, exit, normal));
  EXPECT_FALSE(cube->penetrated(Vec3r(0.5f, 0.5f, 0.5f), Vec3r(0.5f, 0.5f, 1.6f), clearance, exit, normal));
  std::filesystem::remove(path);
}

TEST(BoxBoundary, PenetratedFindsMovesThroughASlabAndOutOfATank) {
  const Real clearance = 0.01f;
  Vec3r exit, normal;
  // A 1 cm slab at z = 0.3 (a thin slope), rotated 90 degrees about z: passed through from above.
  Eigen::Matrix<Real, 3, 3> rotation;
  rotation << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  auto slab = BoxBoundary::solid(Vec3r(0.2f, 0.2f, 0.3f), Vec3r(0.15f, 0.1f, 0.005f), rotation);
  ASSERT_TRUE(slab->penetrated(Vec3r(0.2f, 0.25f, 0.31f), Vec3r(0.2f, 0.25f, 0.29f), clearance, exit, normal));
  EXPECT_TRUE(normal.isApprox(Vec3r(0, 0, 1), 1e-5f)) << normal.transpose();
  EXPECT_TRUE(exit.isApprox(Vec3r(0.2f, 0.25f, 0.315f), 1e-5f)) << exit.transpose();
  // Into its side face (local x = 0.15 is world y = 0.35 after the rotation).
  ASSERT_TRUE(slab->penetrated(Vec3r(0.2f, 0.37f, 0.3f), Vec3r(0.2f, 0.33f, 0.3f), clearance, exit, normal));
  EXPECT_TRUE(normal.isApprox(Vec3r(0, 1, 0), 1e-5f)) << normal.transpose();
  EXPECT_TRUE(exit.isApprox(Vec3r(0.2f, 0.36f, 0.3f), 1e-5f)) << exit.transpose();
  EXPECT_FALSE(slab->penetrated(Vec3r(0.2f, 0.25f, 0.32f), Vec3r(0.2f, 0.25f, 0.306f), clearance, exit, normal));
  EXPECT_FALSE(slab->penetrated(Vec3r(0.2f, 0.2f, 0.3f), Vec3r(0.2f, 0.2f, 0.5f), clearance, exit, normal));
  // A tank: out through the floor and a side wall at once, clamped a clearance inside both.
  auto tank = BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(1, 1, 1));
  ASSERT_TRUE(tank->penetrated(Vec3r(0.02f, 0.5f, 0.01f), Vec3r(-0.01f, 0.5f, -0.01f), clearance, exit, normal));
  EXPECT_TRUE(exit.isApprox(Vec3r(clearance, 0.5f, clearance), 1e-5f)) << exit.transpose();
  EXPECT_TRUE(normal.isApprox(Vec3r(1, 0, 1).normalized(), 1e-5f)) << normal.transpose();
  EXPECT_FALSE(tank->penetrated(Vec3r(0.5f, 0.5f, 0.5f), Vec3r(0.5f, 0.5f, 0.01f), clearance, exit, normal));
  EXPECT_FALSE(tank->penetrated(Vec3r(0.5f, 0.5f, 0.9f), Vec3r(0.5f, 0.5f, 1.5f), clearance, exit, normal));  // open top
}

TEST(MeshBoundary, OpenBoxIsClosedByHoleFilling) {
  // The cube without its top (two triangles): one square hole.
  std::string open = kCubeObj;
  open = open.substr(0, open.find("f 5 6 7")) + "f 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";
  const auto path = writeTemp("open.obj", open);
  EXPECT_GT(countBorderEdges(loadMeshFile(path)), 0u);
  auto box = MeshBoundary::load(path, MeshObstacleOptions());
  EXPECT_EQ(countBorderEdges(box->mesh()), 0u);
  EXPECT_TRUE(box->isInside(Vec3r(0.5f, 0.5f, 0.9f)));
  std::filesystem::remove(path);
}

TEST(MeshBoundary, BadFilesAreInputErrorsNamingTheFile) {
  try {
    MeshBoundary::load("/nonexistent/dir/bunny.ply", MeshObstacleOptions());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/bunny.ply"), std::string::npos);
  }
  const auto empty = writeTemp("empty.obj", "# nothing\n");
  try {
    MeshBoundary::load(empty, MeshObstacleOptions());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(empty.string()), std::string::npos);
  }
  std::filesystem::remove(empty);
  // Found by fuzz_mesh: a PLY header without end_header crashed assimp's reader
  // (out-of-bounds read); PLY obstacles are read by Cascade's own reader.
  const auto broken = writeTemp("broken.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 3\n"
                                              "property float x\nproperty float y\nproperty float z\n"
                                              "   vertex 0 1 1\n  endloop\n endfacet\n");
  try {
    MeshBoundary::load(broken, MeshObstacleOptions());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(broken.string()), std::string::npos) << e.what();
  }
  std::filesystem::remove(broken);
  // The same cube as OBJ and as ASCII PLY (polygons as quads) loads the same.
  std::string ply = "ply\nformat ascii 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
                    "property float z\nelement face 6\nproperty list uchar int vertex_indices\nend_header\n"
                    "0 0 0\n1 0 0\n1 1 0\n0 1 0\n0 0 1\n1 0 1\n1 1 1\n0 1 1\n"
                    "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n";
  const auto cubePly = writeTemp("cube.ply", ply);
  const auto cubeObj = writeTemp("cube.obj", kCubeObj);
  const TriangleMesh fromPly = loadMeshFile(cubePly), fromObj = loadMeshFile(cubeObj);
  EXPECT_EQ(fromPly.vertices.size(), 8u);
  EXPECT_EQ(fromPly.triangles.size(), 12u);
  EXPECT_EQ(countBorderEdges(fromPly), 0u);
  EXPECT_NEAR(surfaceArea(fromPly), surfaceArea(fromObj), 1e-6);
  std::filesystem::remove(cubePly);
  std::filesystem::remove(cubeObj);
}

namespace {
void checkBunny(const std::string& path) {
  MeshObstacleOptions options;
  options.targetTriangles = 900;
  std::ostringstream log;
  auto bunny = MeshBoundary::load(path, options, &log);
  std::cout << log.str();
  EXPECT_LE(bunny->triangleCount(), 900u);
  EXPECT_GE(bunny->triangleCount(), 850u);
  EXPECT_EQ(countBorderEdges(bunny->mesh()), 0u);
  // Outward orientation: the winding number far away is 0 and inside the body 1.
  Vec3r lo, hi;
  bunny->bounds(lo, hi);
  EXPECT_NEAR(bunny->windingNumber(hi + (hi - lo)), 0.0, 1e-6);
  const Vec3r centre = Real(0.5) * (lo + hi);  // inside the body
  EXPECT_TRUE(bunny->isInside(centre));
  EXPECT_NEAR(bunny->windingNumber(centre), 1.0, 1e-3);
  EXPECT_FALSE(bunny->isInside(hi + Vec3r::Constant(0.01f)));
}
} // namespace

TEST(MeshBoundary, BunnySimplifiesTo900ClosedTriangles) {
  // The scene's asset: the closed full-resolution scan.
  const std::string path = std::string(CASCADE_SOURCE_DIR) + "/scenes/assets/bunny_full.obj";
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " missing";
  checkBunny(path);
}

TEST(MeshBoundary, BunnyWithHolesIsClosedThenSimplified) {
  // The 3,851-triangle scan has holes in its base and cracks: filled, then simplified.
  const std::string path = std::string(CASCADE_SOURCE_DIR) + "/tests/solver/data/bunny_res3.ply";
  ASSERT_TRUE(std::filesystem::exists(path)) << path << " missing";
  checkBunny(path);
}

} // namespace cascade
