// Validation of two-way coupling, for both solvers:
// - a cube held still at its draft carries the weight of the water it displaces;
// - Archimedes: closed cubes of density 500 and 800 (and a raft) released at the
//   surface of still water come to rest at a draft of rho_body / rho_water x height,
//   and a cube released a spacing off its draft returns to it;
// - a solid held still by a keyframe gives the fluid the same result as the
//   same static obstacle;
// - action and reaction: the impulse a thrown body receives from the fluid is
//   minus the impulse the fluid receives from it.
// (Exact restarts with a body: tests/bake/test_bake_bodies.cpp.) For studies, the
// floating cases read CASCADE_FLOAT_SPACING, _EDGE, _SIDE, _DEPTH, _TIME, _DENSITY
// (held cube), _NO_REPULSION, _NO_SURFACE_LAYER, _NO_SLIP, _ALPHA (artificial
// viscosity), _KERNELS (wendland_c2 or cubic_spline), _SYMMETRIC (pressure force),
// _SUPPORT (support radius over spacing), _STIFFNESS and _WCSPH_DENSITY;
// CASCADE_TEST_VERBOSE prints the time series.
#include "BodyTestScenes.h"
#include "TestEnvironment.h"

#include "libsph/probes/Probes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <sstream>

namespace cascade::test {

namespace {

struct FloatCase {
  std::string solver;
  double density;
  double height = 1;     ///< body height over its edge: 1 a cube, 0.6 a raft
  bool checkDraft = true;   ///< displaced fraction within 3 %
  bool checkUpright = true; ///< mean drift under 1 % of the edge, mean tilt under 2 degrees
  /// 0: released with its lower face at the surface. Else released this far (m) below
  /// its draft (negative: above), in lattice water at rest around it.
  double offset = 0;
};

void PrintTo(const FloatCase& c, std::ostream* out) {
  *out << c.solver << ", density " << c.density << ", height " << c.height << " x edge";
  if (c.offset != 0) *out << ", released " << c.offset << " m below its draft";
}

std::string caseName(const ::testing::TestParamInfo<FloatCase>& info) {
  const double mm = info.param.offset * 1000;
  return info.param.solver + "_" + (info.param.height == 1 ? "cube" : "raft") + "_" +
         std::to_string(int(info.param.density)) +
         (mm > 0 ? "_" + std::to_string(int(mm)) + "mm_deep" : mm < 0 ? "_" + std::to_string(int(-mm)) + "mm_high" : "");
}

/// Water at rest `depth` deep in a square tank `side` wide, on the cubic lattice of
/// `spacing` (no hydrostatic compression), without the lattice points inside a solid
/// (`solid(p)` true).
template <typename Solid>
void addLatticeWater(Simulation& sim, double side, double depth, double spacing, const Solid& solid) {
  const long n = std::lround(side / spacing), layers = std::lround(depth / spacing);
  for (long k = 0; k < layers; ++k)
    for (long j = 0; j < n; ++j)
      for (long i = 0; i < n; ++i) {
        const Vec3r p = Real(spacing) * Vec3r(Real(i + 0.5), Real(j + 0.5), Real(k + 0.5));
        if (!solid(p)) sim.addParticle(p, Vec3r::Zero());
      }
}

/// Resting water `depth` deep in a square tank `side` wide, and a box `edge` x `edge`
/// x `height` (centred) with its lower face at the water surface.
struct FloatScene {
  std::unique_ptr<Simulation> sim;
  std::size_t body = 0;
  Vec3r lo, hi;        ///< the body's box where it starts (its reference)
  double surface = 0;  ///< initial free surface, m
};

FloatScene makeFloatScene(const std::string& solver, double density, double spacing, double side, double depth,
                          double edge, double height, double startDraft = 0) {
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.type = solver;
  if (std::getenv("CASCADE_FLOAT_NO_REPULSION")) settings.boundary.repulsionParticles = false;
  if (std::getenv("CASCADE_FLOAT_NO_SURFACE_LAYER")) settings.solver.surfaceLayerPressure = false;
  if (const char* v = std::getenv("CASCADE_FLOAT_ALPHA")) settings.solver.artificialViscosity = Real(std::atof(v));
  if (std::getenv("CASCADE_FLOAT_NO_SLIP")) settings.boundary.slip = MirrorSlip::NoSlip;
  if (const char* v = std::getenv("CASCADE_FLOAT_KERNELS"))
    settings.solver.kernels = std::string(v) == "wendland_c2" ? KernelPair::WendlandC2 : KernelPair::CubicSpline;
  if (std::getenv("CASCADE_FLOAT_SYMMETRIC")) settings.solver.pressureForce = PressureForce::Symmetric;
  if (const char* v = std::getenv("CASCADE_FLOAT_SUPPORT")) settings.solver.supportRadiusFactor = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_FLOAT_STIFFNESS")) settings.solver.stiffness = Real(std::atof(v));
  if (const char* v = std::getenv("CASCADE_FLOAT_WCSPH_DENSITY"); v && std::string(v) == "summation")
    settings.solver.density = DensityEvolution::Summation;
  else if (v && std::string(v) == "continuity")
    settings.solver.density = DensityEvolution::Continuity;
  FloatScene scene;
  scene.sim = std::make_unique<Simulation>(settings);
  scene.sim->addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(2.5 * depth))));
  // startDraft > 0: the body starts with its lower face that deep in lattice water (no
  // hydrostatic compression, as HeldCube's), not at the surface.
  scene.surface = depth;
  const Vec3r bottom(Real(side / 2), Real(side / 2), Real(depth - startDraft));
  const Vec3r half(Real(edge / 2), Real(edge / 2), 0);
  scene.lo = bottom - half;
  scene.hi = bottom + half + Vec3r(0, 0, Real(height));
  if (startDraft > 0) {
    addLatticeWater(*scene.sim, side, depth, spacing, [&](const Vec3r& p) {
      return (p.array() > scene.lo.array()).all() && (p.array() < scene.hi.array()).all();
    });
  } else {
    scene.sim->addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(depth)));
  }
  auto mesh = boxObstacle(scene.lo, scene.hi, "body");
  const MassProperties properties = massPropertiesOfMesh(mesh->mesh(), density, "body");
  scene.body = scene.sim->addBoundary(std::make_unique<MovingBoundary>(std::move(mesh), RigidBody(properties, 0.4, 0.0)));
  return scene;
}

/// Fraction of the body's volume below the plane z = level: its reference box [lo, hi]
/// placed by the body's pose, as n^2 columns along the box's own z, each cut exactly by
/// the plane (exact for an upright box; O(1 / n^2) tilted). Orientation-independent: it
/// is Archimedes' displaced volume whether the body floats upright or tilted.
double submergedFraction(const MovingBoundary& body, const Vec3r& lo, const Vec3r& hi, double level, int n = 200) {
  const RigidPose pose = body.pose();
  const Vec3d size = (hi - lo).cast<double>();
  const double slope = pose.rotation(2, 2) * size.z();  // world z gained over a column's length
  double below = 0;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const Vec3d base = lo.cast<double>() + Vec3d((i + 0.5) / n * size.x(), (j + 0.5) / n * size.y(), 0);
      const double z0 = pose.apply(base).z();
      // fraction w in [0, 1] of the column with z0 + slope w < level
      double f;
      if (std::abs(slope) < 1e-15) f = z0 < level ? 1 : 0;
      else if (slope > 0) f = std::clamp((level - z0) / slope, 0.0, 1.0);
      else f = 1 - std::clamp((level - z0) / slope, 0.0, 1.0);
      below += f;
    }
  return below / (double(n) * n);
}

/// The water level in the tank from the water's volume: the particles' rest volume
/// (N spacing^3) plus what the body displaces below the level, over the tank's area
/// (a fixed point: the body's share of the area is below 1). Exact for water at rest
/// and rest density; the top particle layer's height (farSurface) scatters by a few
/// tenths of a spacing between the solvers.
double volumeLevel(const Simulation& sim, const MovingBoundary* body, const Vec3r& lo, const Vec3r& hi, double side,
                   double spacing);

/// The free surface far from the body: the mean height of the top particles within one
/// spacing of the tank's corners (probes.h waterHeight at the four corners).
double farSurface(const Simulation& sim, double side, double spacing) {
  double sum = 0;
  for (const double x : {1.5 * spacing, side - 1.5 * spacing})
    for (const double y : {1.5 * spacing, side - 1.5 * spacing})
      sum += waterHeight(sim.particles().position, x, y, Real(spacing));
  return sum / 4;
}

double volumeLevel(const Simulation& sim, const MovingBoundary* body, const Vec3r& lo, const Vec3r& hi, double side,
                   double spacing) {
  const double water = double(sim.particles().size()) * spacing * spacing * spacing;
  const Vec3r size = hi - lo;
  const double volume = double(size.x()) * size.y() * size.z();
  double level = water / (side * side);
  for (int iteration = 0; iteration < 50; ++iteration) {
    const double displaced = body ? submergedFraction(*body, lo, hi, level, 64) * volume : 0.0;
    level = (water + displaced) / (side * side);
  }
  return level;
}

} // namespace

// A box floating upright is stable when its metacentric height GM = a^2 / (12 d) -
// (h - d) / 2 is positive (d = rho h the draft). A cube is only for rho < 0.211 or
// rho > 0.789: at 500 (GM = -a / 12) it tips over, as it should, so the cube at 500
// checks the displaced volume only, and a raft (h = 0.6 a, GM = +0.128 a at 500)
// checks that no spurious torque or drift moves a body that floats upright. Drift and
// tilt are of the mean position and orientation over the last second: the drop sets
// the small tank sloshing, and the body rides the sloshing as it should.
class Archimedes : public ::testing::TestWithParam<FloatCase> {};

TEST_P(Archimedes, ABodyFloatsAtItsDraft) {
  const FloatCase c = GetParam();
  const double spacing = envOr("CASCADE_FLOAT_SPACING", 0.01);
  const double edge = envOr("CASCADE_FLOAT_EDGE", 0.1), side = envOr("CASCADE_FLOAT_SIDE", 0.24),
               depth = envOr("CASCADE_FLOAT_DEPTH", 0.12);
  const double duration = envOr("CASCADE_FLOAT_TIME", 3.0);
  const double startDraft = c.offset != 0 ? c.density / 1000.0 * c.height * edge + c.offset : 0.0;
  FloatScene scene = makeFloatScene(c.solver, c.density, spacing, side, depth, edge, c.height * edge, startDraft);
  Simulation& sim = *scene.sim;
  const MovingBoundary& body = *sim.movingSolid(scene.body);
  const double x0 = body.center().x(), y0 = body.center().y();
  const bool verbose = std::getenv("CASCADE_TEST_VERBOSE") != nullptr;
  Vec3d meanCenter = Vec3d::Zero(), meanUp = Vec3d::Zero();  // over the last second
  // The last second: the mean displaced fraction and its spread, the drift and the tilt.
  double sum = 0, sum2 = 0;
  int samples = 0;
  for (double t = 0.05; t <= duration + 1e-9; t += 0.05) {
    sim.advanceTo(t);
    const double surface = volumeLevel(sim, &body, scene.lo, scene.hi, side, spacing);
    const double fraction = submergedFraction(body, scene.lo, scene.hi, surface);
    if (t > duration - 1.0) {  // at rest: the last second (the tank's sloshing averages out)
      meanCenter += body.center();
      meanUp += body.pose().rotation.col(2);
    }
    if (verbose)
      std::cout << "t " << t << " submerged " << fraction << " level " << surface << " top layer "
                << farSurface(sim, side, spacing) << " vz " << body.velocity().linear.z()
                << " up " << body.pose().rotation.col(2).transpose() << " steps " << sim.stepCount() << "\n";
    if (t > duration - 1.0) {
      sum += fraction;
      sum2 += fraction * fraction;
      ++samples;
    }
  }
  if (verbose) {
    std::size_t inside = 0;
    for (const Vec3r& x : sim.particles().position) inside += body.isInside(x) ? 1 : 0;
    std::cout << "particles inside the body " << inside << ", kept out " << sim.keptOutCount() << ", surface next to it "
              << waterHeight(sim.particles().position, double(scene.hi.x()) + 0.01, side / 2, Real(spacing))
              << " far " << farSurface(sim, side, spacing) << "\n";
  }
  const double drift = std::hypot(meanCenter.x() / samples - x0, meanCenter.y() / samples - y0);
  const double tilt = std::acos(std::clamp(meanUp.normalized().z(), -1.0, 1.0)) * 180 / M_PI;
  const double fraction = sum / samples;
  const double spread = std::sqrt(std::max(0.0, sum2 / samples - fraction * fraction));
  const double expected = c.density / 1000.0;
  std::cout << c.solver << (c.height == 1 ? " cube" : " raft") << " of density " << c.density
            << ": submerged fraction " << fraction << " (expected " << expected << ", error "
            << 100 * (fraction / expected - 1) << " %, spread " << spread << " over the last second; draft "
            << fraction * c.height * edge << " m), mean drift " << drift << " m, mean tilt " << tilt << " deg, "
            << sim.stepCount() << " steps, " << sim.particles().size() << " particles\n";
  if (c.checkDraft) {
    EXPECT_NEAR(fraction / expected, 1.0, 0.03);
  }
  if (c.checkUpright) {
    EXPECT_LT(drift, 0.01 * edge);
    EXPECT_LT(tilt, 2.0);
  }
}

// Two binaries share this file (tests/bodies/CMakeLists.txt): test_floating (the default
// run) and test_floating_long (CASCADE_FLOATING_LONG, label long: the cases that add
// minutes without a new kind of check).
// Measured at 1 cm (10 spacings per edge), 3 s (docs/moving-solids.md):
// - DFSPH: cube 800 -1.7 % (drift 0.4 mm, tilt 1.3 degrees; upright within the bounds,
//   narrowly: at 800 its metacentric height is 0.004 a, a restoring torque of 0.003 N m
//   per radian that a spurious torque of 1e-4 N m tilts by 2 degrees), cube 500 -2.5 %
//   (tipped over, 44 degrees), raft 500 drift 0.95 mm, tilt 0.6 degrees (its draft, 3
//   spacings, is 1.1 mm short: -3.6 %);
// - WCSPH (cubic spline kernels, chosen automatically when a body floats, at 2.15
//   spacings): cube 800 -0.5 %, cube 500 -0.1 %, raft 500 -0.4 % (drift 0.98 mm, tilt
//   0.3 degrees). At 2 spacings: -1.8 %, -1.9 % and -4.6 % (drift 1.24 mm: the raft failed
//   the drift bound).
#ifndef CASCADE_FLOATING_LONG
INSTANTIATE_TEST_SUITE_P(Dfsph, Archimedes, ::testing::Values(FloatCase{"dfsph", 800, 1, true, true}), caseName);
INSTANTIATE_TEST_SUITE_P(Wcsph, Archimedes,
                         ::testing::Values(FloatCase{"wcsph", 800, 1, true, false}, FloatCase{"wcsph", 500, 1, true, false}),
                         caseName);
#else
INSTANTIATE_TEST_SUITE_P(Dfsph, Archimedes,
                         ::testing::Values(FloatCase{"dfsph", 500, 1, true, false}, FloatCase{"dfsph", 500, 0.6, false, true}),
                         caseName);
INSTANTIATE_TEST_SUITE_P(Wcsph, Archimedes, ::testing::Values(FloatCase{"wcsph", 500, 0.6, true, true}), caseName);
// The draft is an equilibrium the body returns to, not one it sticks near: released 1 cm
// (a spacing) deeper or higher than its draft in water at rest, it is back within 3 %
// over the last of 3 s (WCSPH: +1.8 % from 1 cm deep, +0.6 % from 1 cm high). With
// WCSPH's Wendland C2 kernels (the still-water default) the resting lattice holds it by
// a static shear: at 2 spacings 7-8 % off, on the side it started; at 2.15, +3.4 % from
// 1 cm deep.
INSTANTIATE_TEST_SUITE_P(ReturnsToItsDraft, Archimedes,
                         ::testing::Values(FloatCase{"wcsph", 800, 1, true, false, 0.01},
                                           FloatCase{"wcsph", 800, 1, true, false, -0.01},
                                           FloatCase{"dfsph", 800, 1, true, false, 0.01},
                                           FloatCase{"dfsph", 800, 1, true, false, -0.01}),
                         caseName);
#endif

} // namespace cascade::test

namespace cascade::test {

// The force the solvers put on a body, isolated from its motion: a cube held still
// at a draft d in resting water carries rho g a^2 d (the weight of the water it
// displaces), measured on the surface after the water has settled.
class HeldCube : public ::testing::TestWithParam<FloatCase> {};

TEST_P(HeldCube, CarriesTheWeightOfTheWaterItDisplaces) {
  const FloatCase c = GetParam();
  const double spacing = envOr("CASCADE_FLOAT_SPACING", 0.01), edge = envOr("CASCADE_FLOAT_EDGE", 0.1);
  const double side = envOr("CASCADE_FLOAT_SIDE", 0.24), depth = envOr("CASCADE_FLOAT_DEPTH", 0.12);
  const double draft = envOr("CASCADE_FLOAT_DENSITY", c.density) / 1000.0 * edge;
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.type = c.solver;
  Simulation sim(settings);
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(2.5 * depth))));
  const Vec3r lo(Real(side / 2 - edge / 2), Real(side / 2 - edge / 2), Real(depth - draft));
  const std::size_t cube = sim.addBoundary(boxObstacle(lo, lo + Vec3r(Real(edge), Real(edge), Real(edge)), "cube"));
  addLatticeWater(sim, side, depth, spacing, [&](const Vec3r& p) { return sim.boundary(cube).isInside(p); });
  // Time averages over the last second: the impulses of every step (the instantaneous
  // force of a weakly compressible fluid rings with its sound waves), and the surface.
  const double duration = envOr("CASCADE_FLOAT_TIME", 2.5), window = 1.0;
  sim.advanceTo(duration - window);
  double impulse = 0, tankImpulse = 0, surfaceSum = 0;
  int samples = 0;
  const double start = sim.time();
  while (sim.time() < duration) {
    const double dt = sim.step();
    impulse += dt * sim.obstacleForce(cube).z();
    tankImpulse += dt * sim.obstacleForce(0).z();
    if (sim.stepCount() % 10 == 0) {
      surfaceSum += farSurface(sim, side, spacing);
      ++samples;
    }
  }
  const double elapsed = sim.time() - start;
  const double sum = impulse / elapsed, tankSum = tankImpulse / elapsed;
  const double force = sum, topLayer = surfaceSum / samples;
  // The level from the water's volume (volumeLevel, for a box held still): (V_w - a^2 z_b) / (A - a^2).
  const double water = double(sim.particles().size()) * spacing * spacing * spacing;
  const double surface = (water - edge * edge * double(lo.z())) / (side * side - edge * edge);
  const double submerged = surface - double(lo.z());
  const double expected = 1000.0 * 9.81 * edge * edge * submerged;
  std::cout << c.solver << " cube held at draft " << draft << ": level " << surface << " (top layer " << topLayer
            << "; submerged "
            << submerged << " m), F_z " << force << " N, rho g V " << expected << " N, error "
            << 100 * (force / expected - 1) << " %; tank F_z " << tankSum << " N, weight "
            << double(sim.particleMass()) * double(sim.particles().size()) * 9.81 << " N, kept out " << sim.keptOutCount() << "\n";
  EXPECT_NEAR(force / expected, 1.0, 0.03);
}

#ifndef CASCADE_FLOATING_LONG
INSTANTIATE_TEST_SUITE_P(BothSolvers, HeldCube, ::testing::Values(FloatCase{"wcsph", 800}, FloatCase{"dfsph", 800}),
                         caseName);
#else
INSTANTIATE_TEST_SUITE_P(BothSolvers, HeldCube, ::testing::Values(FloatCase{"wcsph", 500}, FloatCase{"dfsph", 500}),
                         caseName);
#endif

#ifndef CASCADE_FLOATING_LONG
// A solid held still by a keyframe is the same static obstacle: the same mirrors (the
// identity pose conjugates them exactly) and the same type I samples (placed by the
// identity), found in another order (its own grid), so the same fluid up to the
// round-off of that order (WCSPH, a cube half in resting water, 400 steps).
TEST(HeldByAKeyframe, GivesTheStaticObstaclesFluid) {
  const double spacing = 0.01, side = 0.16, depth = 0.08, edge = 0.06;
  const auto run = [&](bool keyframed) {
    SimulationSettings settings;
    settings.fluid.spacing = Real(spacing);
    auto sim = std::make_unique<Simulation>(settings);
    sim->addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(2 * depth))));
    const Vec3r lo(Real(side / 2 - edge / 2), Real(side / 2 - edge / 2), Real(depth - edge / 2));
    auto mesh = boxObstacle(lo, lo + Vec3r::Constant(Real(edge)), "cube");
    if (keyframed)
      sim->addBoundary(std::make_unique<MovingBoundary>(std::move(mesh),
                                                        KinematicMotion::fromKeyframes({scene::Keyframe()}, Vec3d::Zero())));
    else
      sim->addBoundary(std::move(mesh));
    addLatticeWater(*sim, side, depth, spacing, [&](const Vec3r& p) { return sim->boundary(1).isInside(p); });
    for (int step = 0; step < 400; ++step) sim->step();
    return sim;
  };
  const auto fixed = run(false), held = run(true);
  ASSERT_EQ(fixed->particles().size(), held->particles().size());
  EXPECT_EQ(fixed->stepCount(), held->stepCount());
  // Both are reordered (Morton) by their own positions: compare by id.
  std::vector<std::size_t> slot(fixed->particles().size());
  for (std::size_t i = 0; i < held->particles().size(); ++i) slot[held->particles().id[i]] = i;
  double worst = 0, moved = 0;
  for (std::size_t i = 0; i < fixed->particles().size(); ++i) {
    const std::size_t k = slot[fixed->particles().id[i]];
    worst = std::max(worst, double((fixed->particles().position[i] - held->particles().position[k]).norm()));
    moved = std::max(moved, double(fixed->particles().velocity[i].norm()));
  }
  std::cout << "held by a keyframe vs static, 400 steps: largest position difference " << worst / spacing
            << " spacings (largest speed " << moved << " m/s), force " << held->obstacleForce(1).z() << " vs "
            << fixed->obstacleForce(1).z() << " N\n";
  EXPECT_LT(worst, 1e-4 * spacing);
  EXPECT_NEAR(held->obstacleForce(1).z(), fixed->obstacleForce(1).z(), 1e-3 * std::abs(fixed->obstacleForce(1).z()));
  EXPECT_GT(moved, 1e-3);  // the water did move: the cube pushed it around
}

// Action and reaction over a drop: the impulse the body receives from the fluid (the
// sum of F dt over the steps) equals minus the impulse the fluid receives from the body,
// measured as the fluid's momentum change less gravity's impulse and the tank's.
class ActionReaction : public ::testing::TestWithParam<std::string> {};

TEST_P(ActionReaction, TheBodysImpulseIsMinusTheFluids) {
  const std::string solver = GetParam();
  const double spacing = 0.01, side = 0.24, depth = 0.1, edge = 0.08;
  SimulationSettings settings;
  settings.fluid.spacing = Real(spacing);
  settings.solver.type = solver;
  Simulation sim(settings);
  sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(0.3))));
  sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(Real(side), Real(side), Real(depth)));
  const Vec3r lo(Real(side / 2 - edge / 2), Real(side / 2 - edge / 2), Real(depth + 0.05));
  auto mesh = boxObstacle(lo, lo + Vec3r::Constant(Real(edge)), "cube");
  const MassProperties properties = massPropertiesOfMesh(mesh->mesh(), 800, "cube");
  auto body = std::make_unique<MovingBoundary>(std::move(mesh), RigidBody(properties, 0.4, 0.0));
  body->body()->setVelocity(Vec3d(0.3, 0.1, -0.5), Vec3d(0, 2, 0));  // thrown in at an angle, spinning
  const std::size_t cube = sim.addBoundary(std::move(body));
  const auto momentum = [&]() {
    double p[3] = {0, 0, 0};
    for (const Vec3r& v : sim.particles().velocity)
      for (int a = 0; a < 3; ++a) p[a] += double(v[a]);
    const double m = double(sim.particleMass());
    return Vec3d(m * p[0], m * p[1], m * p[2]);
  };
  sim.nextTimeStep();
  const Vec3d before = momentum();
  Vec3d onBody = Vec3d::Zero(), onTank = Vec3d::Zero();
  double elapsed = 0;
  while (sim.time() < 0.4) {
    const double dt = sim.step();
    onBody += dt * sim.exchangedForce(cube);
    onTank += dt * sim.exchangedForce(0);
    elapsed += dt;
  }
  const double mass = double(sim.particleMass()) * double(sim.particles().size());
  const Vec3d gravity = sim.settings().solver.gravity.cast<double>();
  const Vec3d fromBody = momentum() - before - mass * elapsed * gravity + onTank;  // the fluid's, from the body
  std::cout << solver << ": impulse on the body " << onBody.transpose() << " N s, on the fluid from the body "
            << fromBody.transpose() << " N s, kept out " << sim.keptOutCount() << "\n";
  ASSERT_GT(onBody.norm(), 0.1);  // the body did hit the water
  EXPECT_LT((onBody + fromBody).norm(), 0.01 * onBody.norm());
}

INSTANTIATE_TEST_SUITE_P(BothSolvers, ActionReaction, ::testing::Values("wcsph", "dfsph"));
#endif

} // namespace cascade::test
