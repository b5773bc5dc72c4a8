// WCSPH kernel pairs (SolverSettings::kernels) and pressure forces: each pair's
// density is normalised on the rest lattice, and the AVX2 pair loops compute
// the same terms as the scalar fallback.
#include "SolverTestScenes.h"

#include "libsph/boundary/BoundaryParticles.h"
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/boundary/MeshBoundary.h"
#include "libsph/solver/TimeStepWCSPH.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace cascade::test {

namespace {

const KernelPair kPairs[] = {KernelPair::Mueller2003, KernelPair::CubicSpline, KernelPair::WendlandC2};

std::string pairName(KernelPair pair) {
  switch (pair) {
    case KernelPair::Mueller2003: return "mueller2003";
    case KernelPair::CubicSpline: return "cubic_spline";
    case KernelPair::WendlandC2: return "wendland_c2";
    case KernelPair::Automatic: return "auto";
  }
  return "?";
}

/// Restores the vector pair loops when a test ends (also on failure).
struct VectorLoopsGuard {
  ~VectorLoopsGuard() {
    wcsph::allowVectorPairLoops(true);
    wcsph::allowAvx512PairLoops(true);
  }
};

/// The pair loops' comparison case: the Martin & Moyce column at a / 10 with the given
/// kernels and pressure force, after `steps` steps.
auto damBreakAfter(KernelPair pair, PressureForce force, int steps) {
  SimulationSettings settings = damBreakSettings(kMartinMoyceA / 10);
  settings.solver.kernels = pair;
  settings.solver.pressureForce = force;
  auto sim = makeDamBreak(settings);
  for (int step = 0; step < steps; ++step) sim->step();
  return sim;
}

} // namespace

// A closed box filled with the rest lattice of the fluid spacing, no gravity:
// every particle (the wall layers completed by their mirror images) has rho_0
// (to float rounding), so the pressure is zero and nothing moves: a density
// error of 1e-4 would give ~1e-3 m/s after the first step (c = 10 m/s here),
// rounding gives ~1e-6.
TEST(WcsphKernels, RestLatticeHasRestDensityForEveryPair) {
  for (const KernelPair pair : kPairs) {
    SimulationSettings settings;
    settings.fluid.spacing = Real(0.01);
    settings.solver.kernels = pair;
    settings.solver.gravity = Vec3r::Zero();
    settings.solver.expectedSpeed = Real(1);
    Simulation sim(settings);
    const Real side = Real(0.08);
    sim.addBoundary(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(side, side, side), /*closedTop=*/true));
    sim.addFluidBox(Vec3r(0, 0, 0), Vec3r(side, side, side));
    sim.step();
    Real worstDensity = 0, worstSpeed = 0;
    for (std::size_t i = 0; i < sim.particles().size(); ++i) {
      worstDensity = std::max(worstDensity, std::abs(sim.particles().density[i] / Real(1000) - Real(1)));
      worstSpeed = std::max(worstSpeed, sim.particles().velocity[i].norm());
    }
    EXPECT_LT(worstDensity, 1e-4) << pairName(pair);
    EXPECT_LT(worstSpeed, 1e-5) << pairName(pair);
  }
}

// The same dam break, 40 steps with the AVX2 pair loops and with the scalar
// ones, for every kernel pair and pressure force: the sums differ only in the
// order of float additions, so the particles stay within 1e-5 m (a spacing is
// 5.7e-3 m) and the densities within 1e-4 relative.
TEST(WcsphKernels, VectorAndScalarPairLoopsAgree) {
  VectorLoopsGuard guard;
  if (!wcsph::allowVectorPairLoops(true)) GTEST_SKIP() << "no AVX2 on this processor";
  for (const KernelPair pair : kPairs)
    for (const PressureForce force : {PressureForce::Hamiltonian, PressureForce::Symmetric}) {
      std::vector<Vec3r> positions[2];
      std::vector<Real> densities[2];
      for (int scalar = 0; scalar < 2; ++scalar) {
        wcsph::allowVectorPairLoops(scalar == 0);
        const auto sim = damBreakAfter(pair, force, 40);
        positions[scalar] = sim->particles().position;
        densities[scalar] = sim->particles().density;
      }
      ASSERT_EQ(positions[0].size(), positions[1].size());
      Real worstPosition = 0, worstDensity = 0;
      for (std::size_t i = 0; i < positions[0].size(); ++i) {
        worstPosition = std::max(worstPosition, (positions[0][i] - positions[1][i]).norm());
        worstDensity = std::max(worstDensity, std::abs(densities[0][i] / densities[1][i] - Real(1)));
      }
      EXPECT_LT(worstPosition, 1e-5) << pairName(pair) << " force " << int(force);
      EXPECT_LT(worstDensity, 1e-4) << pairName(pair) << " force " << int(force);
    }
}

// The force loop's AVX-512VL build (32 registers) runs the AVX2 build's operations in
// the same order: the same dam break, with the mirrors, type I layer and artificial
// viscosity, is the same bit for bit after 60 steps, for every kernel pair and
// pressure force.
TEST(WcsphKernels, Avx512RegisterBuildGivesTheAvx2BuildsBits) {
  VectorLoopsGuard guard;
  if (!wcsph::allowVectorPairLoops(true) || !wcsph::allowAvx512PairLoops(true))
    GTEST_SKIP() << "no AVX-512VL on this processor";
  for (const KernelPair pair : kPairs)
    for (const PressureForce force : {PressureForce::Hamiltonian, PressureForce::Symmetric}) {
      std::vector<Vec3r> positions[2], velocities[2];
      for (int build = 0; build < 2; ++build) {
        wcsph::allowAvx512PairLoops(build == 0);
        const auto sim = damBreakAfter(pair, force, 60);
        positions[build] = sim->particles().position;
        velocities[build] = sim->particles().velocity;
      }
      ASSERT_EQ(positions[0].size(), positions[1].size());
      std::size_t moved = 0;
      for (std::size_t i = 0; i < positions[0].size(); ++i) {
        ASSERT_EQ(positions[0][i], positions[1][i]) << pairName(pair) << " force " << int(force) << " particle " << i;
        ASSERT_EQ(velocities[0][i], velocities[1][i]) << pairName(pair) << " force " << int(force) << " particle " << i;
        moved += velocities[0][i].norm() > Real(0.01);
      }
      EXPECT_GT(moved, positions[0].size() / 10);  // the column is collapsing: the forces did work
    }
}

// The mirror pairs the density pass keeps for the force pass (Workspace::mirrorNeighbors):
// for every map of every boundary-layer particle, exactly the neighbours whose image lies
// within h (and in front of a front-only map), in the order of the neighbour list. A pair
// within h that is missing takes its force away; one beyond it costs time only, so the
// check allows the 1e-4 h^2 margin and nothing more. The same lists from the vector and
// the scalar loops and from collectMirrorNeighbors. Particles in a tank's corner region,
// around a rotated solid box (edge and corner maps made per particle) and a mesh cube
// (front-only maps).
TEST(WcsphMirrorPairs, AreTheNeighboursWhoseImageLiesWithinTheSupport) {
  VectorLoopsGuard guard;
  SimulationSettings settings;
  settings.fluid.spacing = Real(0.01);
  settings.solver.kernels = KernelPair::WendlandC2;
  DerivedConstants constants;
  constants.supportRadius = Real(0.02);
  constants.particleMass = Real(0.001);
  const Real h = constants.supportRadius;
  std::vector<BoundaryPtr> boundaries;
  boundaries.push_back(BoxBoundary::tank(Vec3r(0, 0, 0), Vec3r(0.3f, 0.2f, 0.2f)));
  boundaries.push_back(BoxBoundary::solid(Vec3r(0.1f, 0.1f, 0.06f), Vec3r(0.04f, 0.03f, 0.02f),
                                          Transform::rotationFromEulerDegrees(Vec3r(0, 20, 10))));
  boundaries.push_back(MeshBoundary::fromMesh(
      BoxBoundary::solid(Vec3r(0.22f, 0.1f, 0.06f), Vec3r(0.03f, 0.03f, 0.03f), Eigen::Matrix<Real, 3, 3>::Identity())
          ->surfaceMesh(),
      "cube"));
  Particles particles;
  std::mt19937 random(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (std::uint32_t k = 0; k < 6000; ++k)
    particles.add(Vec3r(0.3f * u(random), 0.2f * u(random), 0.12f * u(random)), Vec3r::Zero(), k);
  NeighborLists neighbors;
  makeNeighborSearch("grid")->findNeighbors(particles.position.data(), particles.size(), h, neighbors);
  BoundaryParticles boundary;
  boundary.sample(boundaries, Real(0.0025), Real(0.005));
  boundary.update(particles, boundaries, Real(0.005), h, true, true);
  std::vector<Vec3r> acceleration;
  std::vector<Vec3d> force(boundaries.size()), reported(boundaries.size()), moment(boundaries.size());
  StepTimings timings;
  StepContext context{particles, neighbors, boundary, settings, constants, acceleration, force, reported, moment, timings};

  const auto mirrorPairs = [&](bool vector, bool collectOnly) {
    wcsph::allowVectorPairLoops(vector);
    wcsph::Workspace workspace;
    if (collectOnly) {
      wcsph::gatherPairInputs(context, workspace);
      wcsph::collectMirrorNeighbors(context, workspace);
    } else {
      wcsph::computeFluidDensity(context, workspace);
    }
    std::vector<std::vector<std::uint32_t>> lists(boundary.mirrors().size());
    for (std::size_t m = 0; m < lists.size(); ++m)
      lists[m].assign(workspace.mirrorList(m), workspace.mirrorList(m) + workspace.mirrorCount[m]);
    return lists;
  };
  const std::vector<std::vector<std::uint32_t>> kept = mirrorPairs(true, false);
  std::size_t maps = 0, frontOnly = 0, candidates = 0, pairs = 0;
  const double h2 = double(h) * double(h);
  for (std::uint32_t i : boundary.layer()) {
    const Vec3d xi = particles.position[i].cast<double>();
    for (std::uint32_t m = boundary.mirrorOffsets()[i]; m < boundary.mirrorOffsets()[i + 1]; ++m) {
      const MirrorMap& map = boundary.mirrors()[m];
      ++maps;
      frontOnly += map.frontOnly ? 1 : 0;
      const std::vector<std::uint32_t>& list = kept[m];
      pairs += list.size();
      // In list order: a subsequence of i's neighbours.
      const std::uint32_t* next = neighbors.begin(i);
      for (std::uint32_t j : list) {
        next = std::find(next, neighbors.end(i), j);
        ASSERT_NE(next, neighbors.end(i)) << "particle " << i << " map " << m << ": " << j << " out of order";
        ++next;
      }
      for (const std::uint32_t* j = neighbors.begin(i); j != neighbors.end(i); ++j) {
        ++candidates;
        const bool listed = std::find(list.begin(), list.end(), *j) != list.end();
        if (map.behind(particles.position[i], particles.position[*j])) {
          EXPECT_FALSE(listed) << "particle " << i << " map " << m << ": " << *j << " is behind";
          continue;
        }
        const Vec3d image = map.linear.cast<double>() * particles.position[*j].cast<double>() + map.offset.cast<double>();
        const double r2 = (xi - image).squaredNorm();
        if (r2 < h2 * (1 - 1e-5)) {
          EXPECT_TRUE(listed) << "particle " << i << " map " << m << ": " << *j;
        } else if (r2 > h2 * (1 + 2e-4)) {
          EXPECT_FALSE(listed) << "particle " << i << " map " << m << ": " << *j;
        }
      }
    }
  }
  EXPECT_GT(maps, 1000u);
  EXPECT_GT(frontOnly, 100u);
  EXPECT_LT(double(pairs), 0.5 * double(candidates));  // what the force pass no longer visits
  EXPECT_GT(pairs, 0u);
  EXPECT_EQ(mirrorPairs(true, true), kept);
  EXPECT_EQ(mirrorPairs(false, false), kept);
  EXPECT_EQ(mirrorPairs(false, true), kept);
}

} // namespace cascade::test
