// Validation of deforming mesh sequences in the water:
// - a sequence that only translates a cube gives the fluid what the same motion
//   given as keyframes gives (the rigid path), for both solvers;
// - a cube that grows under water raises the free surface by its volume change over
//   the tank's area, and no water stays inside it.
// CASCADE_TEST_VERBOSE prints the time series.
#include "DeformingTestSequences.h"
#include "TestTempDir.h"

#include "libsph/bodies/KinematicMotion.h"
#include "libsph/probes/Probes.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <iostream>

namespace cascade::test {

namespace {

bool verbose() { return std::getenv("CASCADE_TEST_VERBOSE") != nullptr; }

std::filesystem::path scratch(const std::string& name) {
  static const std::filesystem::path base = freshTempDir("deforming");
  const std::filesystem::path dir = base / name;
  std::filesystem::create_directories(dir);
  return dir;
}

} // namespace

class DeformingInWater : public ::testing::TestWithParam<std::string> {};

TEST_P(DeformingInWater, ATranslatingSequenceMatchesTheSameKeyframedMotion) {
  // A 6 cm cube pushed through 12 cm of water at 0.25 m/s along x, from t = 0: once as
  // keyframes (a rigid motion), once as an OBJ sequence at 30 fps with a frame 0.
  const double spacing = 0.01, fps = 30, speed = 0.25, end = 0.3;
  const Vec3r lo(0.1f, 0.07f, 0.02f), hi = lo + Vec3r::Constant(0.06f);
  const std::string pattern =
      writeBoxSequence(scratch("translate_" + GetParam()), "cube", 0, int(end * fps) + 1, [&](int k, Vec3r& a, Vec3r& b) {
        const Vec3r shift(Real(speed * k / fps), 0, 0);
        a = lo + shift;
        b = hi + shift;
      });
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.type = GetParam();
  const auto makeScene = [&](bool sequence) {
    auto sim = std::make_unique<Simulation>(settings);
    sim->addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.4f, 0.2f, 0.3f)));
    sim->addFluidBox(Vec3r(0, 0, 0), Vec3r(0.4f, 0.2f, 0.12f));
    if (sequence) {
      auto solid = std::make_unique<DeformingMeshBoundary>(loadMeshSequence(pattern, int(end * fps) + 1, fps, Transform(), "cube"));
      sim->addBoundary(std::move(solid));
    } else {
      std::vector<scene::Keyframe> keys(2);
      keys[1].t = 1.0;
      keys[1].translate = {speed, 0, 0};
      sim->addBoundary(std::make_unique<MovingBoundary>(boxObstacle(lo, hi, "cube"),
                                                        KinematicMotion::fromKeyframes(keys, Vec3d::Zero())));
    }
    return sim;
  };
  auto keyed = makeScene(false), sequenced = makeScene(true);
  // Before the first step the sequence's fluid set-up equals the keyframed one's.
  ASSERT_EQ(keyed->particles().size(), sequenced->particles().size());
  Vec3d impulseKeyed = Vec3d::Zero(), impulseSequenced = Vec3d::Zero();
  for (int k = 1; k <= 30; ++k) {
    const double t = end * k / 30;
    while (keyed->time() < t - 1e-12) {
      const double dt = keyed->step();
      impulseKeyed += dt * keyed->exchangedForce(1);
    }
    while (sequenced->time() < t - 1e-12) {
      const double dt = sequenced->step();
      impulseSequenced += dt * sequenced->exchangedForce(1);
    }
    if (verbose())
      std::cout << GetParam() << " t " << t << " impulse keyed " << impulseKeyed.transpose() << " sequence "
                << impulseSequenced.transpose() << " kept out " << keyed->keptOutCount() << " "
                << sequenced->keptOutCount() << " steps " << keyed->stepCount() << " " << sequenced->stepCount() << "\n";
  }
  // The drag's impulse on the cube (against the motion): the same within 1 % (the two
  // placements differ by round-off, which the flow grows), and clearly not zero.
  EXPECT_LT(impulseKeyed.x(), -0.2);
  EXPECT_NEAR(impulseSequenced.x(), impulseKeyed.x(), 0.01 * std::abs(impulseKeyed.x()));
  EXPECT_NEAR(impulseSequenced.z(), impulseKeyed.z(), 0.01 * impulseKeyed.norm());
  // The water: mean particle position the same to 1 % of a spacing.
  Vec3d meanKeyed = Vec3d::Zero(), meanSequenced = Vec3d::Zero();
  for (const Vec3r& p : keyed->particles().position) meanKeyed += p.cast<double>();
  for (const Vec3r& p : sequenced->particles().position) meanSequenced += p.cast<double>();
  const double n = double(keyed->particles().size());
  EXPECT_LT((meanKeyed - meanSequenced).norm() / n, 0.01 * spacing);
  if (verbose()) std::cout << "mean position difference " << (meanKeyed - meanSequenced).norm() / n << " m\n";
}

TEST_P(DeformingInWater, AGrowingCubeRaisesTheWaterByItsVolume) {
  // A cube centred 0.1 m above the floor of a 0.3 x 0.3 m tank, under 0.22 m of water,
  // grows from 6 to 15 cm over 0.3 s (frames 1-10 at 30 fps), then holds. The water's
  // volume is kept, so the surface far from it rises by (0.15^3 - 0.06^3) / 0.09 m^2 =
  // 35.1 mm (within 3 %: the boundary model keeps water about as far off the cube's
  // walls as off the tank's, 0.1 spacing more would be 4 %), and no water stays inside.
  const double spacing = 0.012, side = 0.3, depth = 0.22, fps = 30;
  const Vec3r centre(0.15f, 0.15f, 0.10f);
  const auto edgeOf = [](int k) { return 0.06 + 0.01 * std::clamp(k - 1, 0, 9); };
  const std::string pattern =
      writeBoxSequence(scratch("grow_" + GetParam()), "cube", 1, 24, [&](int k, Vec3r& a, Vec3r& b) {
        const Vec3r half = Vec3r::Constant(Real(edgeOf(k) / 2));
        a = centre - half;
        b = centre + half;
      });
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.type = GetParam();
  Simulation sim(settings);
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), 0.4f)));
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(depth)));
  const std::size_t cube =
      sim.addBoundary(std::make_unique<DeformingMeshBoundary>(loadMeshSequence(pattern, 24, fps, Transform(), "cube")));
  // As scene set-up does: no water inside the cube, nor within 0.45 spacing of its surface.
  {
    const auto first = MeshBoundary::fromMesh(sim.boundary(cube).surfaceMesh(), "cube");
    std::vector<char> out(sim.particles().size(), 0);
    for (std::size_t i = 0; i < out.size(); ++i) {
      const Vec3r& p = sim.particles().position[i];
      Vec3d point;
      out[i] = first->isInside(p) || first->closestTriangle(p.cast<double>(), 0.45 * spacing, point) >= 0;
    }
    sim.removeParticles(out);
  }
  // The level far from the cube by volume: the rest volume of the particles (spacing^3
  // each) over the ring of cells along the walls (5 x 5 cells of 5 spacings, on the
  // lattice the water starts on; the ring is clear of the grown cube) over the ring's
  // area. Sloshing modes, which a growth in the middle excites, and the top layer's
  // arrangement (a lattice or not) do not bias it.
  const auto level = [&] {
    const double cell = side / 5;
    std::size_t count = 0;
    for (const Vec3r& p : sim.particles().position) {
      const int i = std::clamp(int(double(p.x()) / cell), 0, 4), j = std::clamp(int(double(p.y()) / cell), 0, 4);
      if (i == 0 || i == 4 || j == 0 || j == 4) ++count;
    }
    return double(count) * spacing * spacing * spacing / (16 * cell * cell);
  };
  const auto meanLevel = [&](double from, double to) {
    double sum = 0;
    int count = 0;
    for (double t = from; t <= to + 1e-9; t += 0.01) {
      sim.advanceTo(t);
      sum += level();
      ++count;
    }
    return sum / count;
  };
  const double before = meanLevel(0.0, 0.03);  // frame 1 holds until 1 / 30 s
  const double after = meanLevel(0.7, 0.8);
  const double rise = after - before;
  const double expected = (std::pow(edgeOf(10), 3) - std::pow(edgeOf(1), 3)) / (side * side);
  if (verbose())
    std::cout << GetParam() << ": level " << before << " -> " << after << " m, rise " << rise << " m, expected "
              << expected << " m\n";
  EXPECT_NEAR(rise, expected, 0.03 * expected);
  std::size_t inside = 0;
  for (const Vec3r& p : sim.particles().position) inside += sim.boundary(cube).isInside(p) ? 1 : 0;
  EXPECT_EQ(inside, 0u);
}

INSTANTIATE_TEST_SUITE_P(Solvers, DeformingInWater, ::testing::Values("wcsph", "dfsph"),
                         [](const auto& info) { return info.param; });

} // namespace cascade::test
