#include "libsph/scene/SceneSetup.h"

#include "libsph/Errors.h"
#include "libsph/bodies/DeformingMesh.h"
#include "libsph/bodies/MassProperties.h"
#include "libsph/bodies/MovingBoundary.h"
#include "libsph/boundary/BoxBoundary.h"
#include "libsph/boundary/MeshBoundary.h"
#include "libsph/boundary/PlaneBoundary.h"
#include "libsph/scene/FluidSources.h"
#include "libsph/solver/TimeStepDFSPH.h"
#include "libsph/solver/TimeStepWCSPH.h"

#include <Eigen/Geometry>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <ostream>
#include <unordered_map>

namespace cascade::scene {

namespace {
Vec3r toVec(const Vec3& v) { return Vec3r(Real(v[0]), Real(v[1]), Real(v[2])); }

/// How far an infinite plane's type I samples reach around its point: the scene's
/// extent (its domain's largest side, at least 1 m).
double planeExtent(const Boundaries& b) {
  double extent = 1.0;
  if (b.domain)
    for (int k = 0; k < 3; ++k) extent = std::max(extent, b.domain->max[k] - b.domain->min[k]);
  return extent;
}

Eigen::Matrix<Real, 3, 3> slopeRotation(const Slope& slope) {
  const Eigen::Vector3d axis = Eigen::Vector3d(slope.axis[0], slope.axis[1], slope.axis[2]).normalized();
  const double radians = slope.angle * M_PI / 180.0;
  return Eigen::AngleAxisd(radians, axis).toRotationMatrix().cast<Real>();
}

/// Lowest z any boundary or fluid source reaches (for the free-fall speed).
double lowestZ(const Scene& scene) {
  double low = 1e30;
  for (const FluidBlock& block : scene.fluid.blocks) low = std::min(low, block.box.min[2]);
  for (const Emitter& emitter : scene.fluid.emitters) low = std::min(low, emitter.center[2]);
  if (scene.boundaries.tank) low = std::min(low, scene.boundaries.tank->min[2]);
  for (const Plane& plane : scene.boundaries.planes) low = std::min(low, plane.point[2]);
  for (const Slope& slope : scene.boundaries.slopes) {
    const double reach = 0.5 * std::sqrt(slope.size[0] * slope.size[0] + slope.size[1] * slope.size[1] +
                                         slope.size[2] * slope.size[2]);
    low = std::min(low, slope.center[2] - reach);
  }
  return low;
}
/// The mesh solids' type I samples (SEED 7-point sampling at a gap of radius / 2) in a
/// hash grid of cell `radius`: near(x) is true if a sample lies within `radius` of x.
class MeshSampleGrid {
public:
  MeshSampleGrid(const Simulation& simulation, Real radius) : mRadius(radius) {
    for (std::size_t b = 0; b < simulation.boundaryCount(); ++b) {
      const Boundary& solid = simulation.boundary(b);
      if (solid.kind().find("mesh") == std::string::npos) continue;
      std::vector<Vec3r> samples;
      solid.sampleSurface(radius / 2, samples);
      for (const Vec3r& s : samples) mCells[key(cellOf(s))].push_back(s);
    }
  }
  bool near(const Vec3r& x) const {
    if (mCells.empty()) return false;
    const std::array<long, 3> c = cellOf(x);
    for (long dz = -1; dz <= 1; ++dz)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dx = -1; dx <= 1; ++dx) {
          const auto found = mCells.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (found == mCells.end()) continue;
          for (const Vec3r& s : found->second)
            if ((s - x).squaredNorm() < mRadius * mRadius) return true;
        }
    return false;
  }

private:
  std::array<long, 3> cellOf(const Vec3r& x) const {
    return {long(std::floor(x.x() / mRadius)), long(std::floor(x.y() / mRadius)), long(std::floor(x.z() / mRadius))};
  }
  static std::uint64_t key(const std::array<long, 3>& c) {
    return (std::uint64_t(c[0] & 0x1FFFFF) << 42) | (std::uint64_t(c[1] & 0x1FFFFF) << 21) | std::uint64_t(c[2] & 0x1FFFFF);
  }
  Real mRadius;
  std::unordered_map<std::uint64_t, std::vector<Vec3r>> mCells;
};
} // namespace

SimulationSettings simulationSettings(const Scene& scene) {
  SimulationSettings settings;
  settings.fluid.spacing = Real(scene.fluid.spacing);
  settings.fluid.restDensity = Real(scene.fluid.density);
  settings.fluid.viscosity = Real(scene.fluid.viscosity);

  const Solver& s = scene.solver;
  SolverSettings& solver = settings.solver;
  solver.type = s.type;
  solver.supportRadiusFactor = Real(s.supportFactor);
  solver.equationOfState = s.eos == "tait" ? EquationOfState::Tait : EquationOfState::Linear;
  solver.taitExponent = Real(s.taitExponent);
  solver.stiffness = Real(s.stiffness);
  solver.clampNegativePressure = s.clampNegativePressure;
  solver.kernels = s.kernels == "mueller2003"    ? KernelPair::Mueller2003
                   : s.kernels == "cubic_spline" ? KernelPair::CubicSpline
                   : s.kernels == "wendland_c2"  ? KernelPair::WendlandC2
                                                 : KernelPair::Automatic;
  solver.pressureForce = s.pressureForce == "symmetric"      ? PressureForce::Symmetric
                         : s.pressureForce == "mueller_half" ? PressureForce::MuellerHalf
                                                             : PressureForce::Hamiltonian;
  solver.surfaceLayerPressure = s.surfaceLayerPressure;
  solver.density = s.density == "continuity" ? DensityEvolution::Continuity : DensityEvolution::Summation;
  solver.densityDiffusion = Real(s.densityDiffusion);
  solver.velocityFilter = Real(s.velocityFilter);
  solver.artificialViscosity = Real(s.artificialViscosity);
  solver.artificialViscosityAllPairs = s.artificialViscosityAllPairs;
  solver.expectedSpeed = Real(s.expectedSpeed);
  solver.instabilitySpeedFactor = Real(s.instabilitySpeedFactor);
  solver.densityTolerance = Real(s.densityTolerance);
  solver.divergenceTolerance = Real(s.divergenceTolerance);
  solver.twoLevelPreconditioner = s.preconditioner == "two_level";
  solver.particleToleranceShare = Real(s.particleToleranceShare);
  solver.maxIterations = int(s.maxIterations);
  solver.cflFactor = Real(s.cfl);
  solver.minTimeStep = Real(s.dtMin);
  solver.maxTimeStep = Real(s.dtMax);
  solver.gravity = toVec(scene.gravity);
  solver.neighborSearch = s.neighborSearch;
  solver.reorderInterval = int(s.reorderInterval);

  if (solver.expectedSpeed == 0 && !scene.fluid.emitters.empty()) {
    // Emitted particles do not exist when the solver derives its constants:
    // the fastest a particle can get is its launch speed plus the free fall
    // from the highest source to the lowest point of the scene.
    const double g = std::sqrt(scene.gravity[0] * scene.gravity[0] + scene.gravity[1] * scene.gravity[1] +
                               scene.gravity[2] * scene.gravity[2]);
    const double low = lowestZ(scene);
    double fastest = 0;
    for (const Emitter& e : scene.fluid.emitters) {
      const double drop = std::max(0.0, e.center[2] - low);
      fastest = std::max(fastest, std::sqrt(e.speed * e.speed + 2 * g * drop));
    }
    for (const FluidBlock& block : scene.fluid.blocks) {
      const double drop = std::max(0.0, block.box.max[2] - low);
      const Vec3r v = toVec(block.velocity);
      fastest = std::max(fastest, std::sqrt(double(v.squaredNorm()) + 2 * g * drop));
    }
    solver.expectedSpeed = Real(fastest);
  }

  BoundarySettings& boundary = settings.boundary;
  boundary.repulsionParticles = s.repulsionParticles;
  boundary.mirrorParticles = s.mirrorParticles;
  boundary.mirrorHydrostatic = s.mirrorHydrostatic;
  boundary.repulsionStrength = Real(s.repulsion);
  boundary.repulsionRadius = Real(s.repulsionRadius);
  boundary.sampleGap = Real(s.sampleGap);
  boundary.slip = s.slip == "no"        ? MirrorSlip::NoSlip
                  : s.slip == "laminar" ? MirrorSlip::LaminarWallShear
                                        : MirrorSlip::FreeSlip;
  boundary.kappa = Real(s.kappa);

  if (scene.boundaries.domain) {
    settings.domain.enabled = true;
    settings.domain.min = toVec(scene.boundaries.domain->min);
    settings.domain.max = toVec(scene.boundaries.domain->max);
  }
  return settings;
}

void setUpSimulation(const Scene& scene, Simulation& simulation, std::ostream* log) {
  const Boundaries& b = scene.boundaries;
  if (b.tank) {
    BoundaryPtr tank = BoxBoundary::tank(toVec(b.tank->min), toVec(b.tank->max));
    tank->setName("tank");
    simulation.addBoundary(std::move(tank));
  }
  for (std::size_t i = 0; i < b.planes.size(); ++i) {
    // Type I samples of an infinite plane cover the scene's extent around its point.
    BoundaryPtr plane = PlaneBoundary::infinite(toVec(b.planes[i].point), toVec(b.planes[i].normal).normalized(),
                                                Real(planeExtent(b)));
    plane->setName("plane" + std::to_string(i + 1));
    simulation.addBoundary(std::move(plane));
  }
  for (const Slope& slope : b.slopes) {
    const Vec3r half(Real(0.5 * slope.size[0]), Real(0.5 * slope.size[1]), Real(0.5 * slope.size[2]));
    BoundaryPtr solid = BoxBoundary::solid(toVec(slope.center), half, slopeRotation(slope));
    solid->setName(slope.name);
    simulation.addBoundary(std::move(solid));
  }
  std::vector<std::size_t> moving;  // boundary indices of the moving obstacles
  for (std::size_t k = 0; k < b.obstacles.size(); ++k) {
    const Obstacle& obstacle = b.obstacles[k];
    const std::string path = "boundaries.obstacles[" + std::to_string(k) + "]";
    MeshObstacleOptions options;
    options.transform.translation = toVec(obstacle.translate);
    options.transform.rotation = Transform::rotationFromEulerDegrees(toVec(obstacle.rotate));
    options.transform.scale = Real(obstacle.scale);
    if (obstacle.isSequence()) {
      MeshSequence sequence = loadMeshSequence(obstacle.mesh, scene.output.frameCount(), scene.output.fps,
                                               options.transform, path + ".mesh");
      auto solid = std::make_unique<DeformingMeshBoundary>(std::move(sequence));
      solid->setName(obstacle.name);
      if (log)
        *log << obstacle.name << ": deforming mesh sequence, frames " << solid->sequence().firstFrame << "-"
             << solid->sequence().lastFrame() << ", " << solid->sequence().triangles.size()
             << " triangles, fastest surface point " << solid->maxMotionSpeed() << " m/s\n";
      moving.push_back(simulation.addBoundary(std::move(solid)));
      continue;
    }
    options.targetTriangles = std::size_t(obstacle.triangles);
    // A body's mass from its volume needs the mesh as given: no silently filled holes.
    const bool massFromVolume = obstacle.dynamic && !(obstacle.dynamic->mass > 0);
    if (massFromVolume) options.requireClosed = false;
    std::unique_ptr<MeshBoundary> mesh = MeshBoundary::load(obstacle.mesh, options, log);
    mesh->setName(obstacle.name);
    if (obstacle.dynamic) {
      const Dynamic& dynamic = *obstacle.dynamic;
      if (const std::size_t open = countBorderEdges(mesh->mesh()); open > 0)
        throw InputError(obstacle.mesh + ": " + path + ".dynamic: the mesh is not closed (" + std::to_string(open) +
                         " open edges), so its volume and mass are unknown: give \"mass\"");
      MassProperties properties =
          massPropertiesOfMesh(mesh->mesh(), massFromVolume ? dynamic.density : 1.0, obstacle.mesh + ": " + path);
      if (!massFromVolume) properties = withMass(properties, dynamic.mass);
      if (log)
        *log << obstacle.name << ": rigid body, mass " << properties.mass << " kg, volume " << properties.volume
             << " m^3, centre of mass (" << properties.centerOfMass.x() << ", " << properties.centerOfMass.y() << ", "
             << properties.centerOfMass.z() << ")\n";
      moving.push_back(simulation.addBoundary(std::make_unique<MovingBoundary>(
          std::move(mesh), RigidBody(properties, dynamic.friction, dynamic.restitution))));
    } else if (obstacle.motion) {
      const Vec3d origin(obstacle.translate[0], obstacle.translate[1], obstacle.translate[2]);
      KinematicMotion motion = obstacle.motion->piston ? KinematicMotion::piston(*obstacle.motion->piston, origin)
                                                       : KinematicMotion::fromKeyframes(obstacle.motion->keyframes, origin);
      moving.push_back(simulation.addBoundary(std::make_unique<MovingBoundary>(std::move(mesh), std::move(motion))));
    } else {
      simulation.addBoundary(std::move(mesh));
    }
  }
  // A moving solid may not start inside another solid: its hull points, and the
  // other solids' hull points (meshes) inside it.
  for (const std::size_t m : moving) {
    const Boundary& solid = simulation.boundary(m);
    const std::vector<Eigen::Vector3f> hull = solid.surfaceMesh().vertices;  // at t = 0
    for (std::size_t other = 0; other < simulation.boundaryCount(); ++other) {
      if (other == m) continue;
      const Boundary& them = simulation.boundary(other);
      bool overlap = false;
      for (const Eigen::Vector3f& p : hull)
        if (them.isInside(p.cast<Real>())) overlap = true;
      if (!overlap && them.kind() != "tank" && them.kind() != "plane")
        for (const Eigen::Vector3f& v : them.surfaceMesh().vertices)
          if (solid.isInside(v)) overlap = true;
      if (overlap) {
        const std::size_t k = m - (simulation.boundaryCount() - b.obstacles.size());
        throw InputError(b.obstacles[k].mesh + ": boundaries.obstacles[" + std::to_string(k) +
                         "]: starts overlapping the solid \"" + them.name() + "\"; move it clear at t = 0");
      }
    }
  }
  // A block that reaches into a solid (an obstacle, or past the tank's walls) fills only
  // the space around it: particles inside a solid would stay trapped there. Blocks fill
  // their union once: a block leaves out its lattice points within half a spacing of an
  // earlier block's box, which that block fills (its lattice lies at least half a
  // spacing inside its faces, so no two particles start closer than a spacing there).
  const double margin = 0.5 * scene.fluid.spacing;
  // Nor closer than 0.45 spacing to a mesh's surface samples: a lattice point just
  // outside a mesh sat deep in the r^-13 layer of SEED (11) and was thrown off at
  // hundreds of m/s in the first steps (WCSPH, the bunny floating in a pool). Flat
  // solids (tank, planes, slopes) keep their first layer half a spacing off the wall.
  const MeshSampleGrid meshSamples(simulation, Real(0.45 * scene.fluid.spacing));
  for (std::size_t k = 0; k < scene.fluid.blocks.size(); ++k) {
    const FluidBlock& block = scene.fluid.blocks[k];
    const Vec3r velocity = toVec(block.velocity);
    const std::vector<Vec3r> positions = blockPositions(block, scene.fluid.spacing);
    std::size_t insideSolids = 0, overlapping = 0;
    for (const Vec3r& p : positions) {
      bool earlier = false;
      for (std::size_t j = 0; j < k && !earlier; ++j) {
        const Box& box = scene.fluid.blocks[j].box;
        earlier = true;
        for (int axis = 0; axis < 3; ++axis)
          earlier = earlier && double(p[axis]) >= box.min[axis] - margin && double(p[axis]) <= box.max[axis] + margin;
      }
      bool inside = false;
      for (std::size_t b = 0; b < simulation.boundaryCount() && !inside && !earlier; ++b)
        inside = simulation.boundary(b).isInside(p);
      if (!inside && !earlier) inside = meshSamples.near(p);
      if (earlier)
        ++overlapping;
      else if (inside)
        ++insideSolids;
      else
        simulation.addParticle(p, velocity);
    }
    if (insideSolids > 0 && log)
      *log << "fluid block " << k + 1 << ": " << insideSolids << " of its " << positions.size()
           << " particles lie inside solids (or within 0.45 spacing of a mesh) and are left out\n";
    if (overlapping > 0 && log)
      *log << "fluid block " << k + 1 << ": " << overlapping << " of its " << positions.size()
           << " particles overlap earlier blocks, which fill that space\n";
  }
  if (const int layers = deepestFluidLayers(scene); log && scene.solver.type == "dfsph" && layers > kDfsphStillWaterLayers)
    *log << "warning: a fluid block stacks " << layers << " particle layers; DFSPH is measured to hold resting water "
            "still up to "
         << kDfsphStillWaterLayers
         << " (docs/dfsph-deep-water.md), deeper is untested: check the first frames, or use solver.type=wcsph "
            "or a coarser fluid.spacing\n";
  // A tank narrower than the support radius less a spacing: particles a layer apart see
  // each other across both side walls at once (an image translated by twice the width,
  // from W + s away), which the tank's mirror maps, one reflection or one product of
  // walls of different axes, do not make (docs/moving-solids.md, "A slab's far wall").
  if (log && scene.boundaries.tank) {
    const double h = double(simulation.constants().supportRadius), s = scene.fluid.spacing;
    for (int axis = 0; axis < 2; ++axis) {
      const double width = scene.boundaries.tank->max[axis] - scene.boundaries.tank->min[axis];
      if (width + s < h * (1 - 1e-9))
        *log << "warning: the tank is " << width << " m across " << "xy"[axis] << ", less than the support radius "
             << h << " m less a spacing: the mirror images across both walls at once are missing and the water "
                "there packs wrongly; widen the tank to at least "
             << h - s << " m or lower solver.support_factor\n";
    }
  }
  // Continuity density at a support beyond about 2.2 spacings: still water is unstable, a
  // particle-scale motion grows from round-off and drains waves (docs/solvers.md, "Still
  // water set for waves"); the velocity filter holds it down.
  if (log && scene.solver.type == "wcsph" && scene.solver.density == "continuity" && scene.solver.velocityFilter <= 0) {
    const double factor = double(simulation.constants().supportRadius) / scene.fluid.spacing;
    if (factor > kWcsphStableContinuitySupport)
      *log << "warning: continuity density at solver.support_factor " << factor
           << " with no solver.velocity_filter: resting water there is unstable (a particle-scale motion grows from "
              "round-off and drains waves); set solver.velocity_filter (0.12) or a support_factor of at most "
           << kWcsphStableContinuitySupport << "\n";
  }
  const Real cap = scene.solver.type == "dfsph" ? kDfsphMaxCfl : kWcsphMaxCfl;
  if (log && scene.solver.cfl > double(cap))
    *log << "warning: solver.cfl " << scene.solver.cfl << " is above the " << cap << " " << scene.solver.type
         << " holds (faster steps carry particles into obstacles or gain energy; docs/solvers.md): "
            "steps use "
         << cap << "\n";
}

MemoryEstimate estimateBakeMemory(const Scene& scene) {
  MemoryEstimate estimate;
  const double s = scene.fluid.spacing;
  for (const FluidBlock& block : scene.fluid.blocks) {
    double count = 1;
    for (int k = 0; k < 3; ++k) count *= std::max(1.0, std::floor((block.box.max[k] - block.box.min[k]) / s));
    estimate.fluidParticles += count;
  }
  for (const Emitter& emitter : scene.fluid.emitters) {
    const double area = emitter.shape == "disk" ? 3.14159265358979 * emitter.radius * emitter.radius
                                                : emitter.size[0] * emitter.size[1];
    const double rate = emitter.rate > 0 ? emitter.rate : emitter.speed * area / (s * s * s);
    double count = rate * std::max(0.0, std::min(emitter.end, scene.output.endTime) - emitter.start);
    if (emitter.maxCount > 0) count = std::min(count, double(emitter.maxCount));
    estimate.fluidParticles += count;
  }
  // Type I samples half a spacing apart on the flat solids.
  const double perArea = 1.0 / (0.25 * s * s);
  const auto boxArea = [](const Vec3& size) { return 2 * (size[0] * size[1] + size[1] * size[2] + size[0] * size[2]); };
  const Boundaries& b = scene.boundaries;
  if (b.tank) {
    const Vec3 size{b.tank->max[0] - b.tank->min[0], b.tank->max[1] - b.tank->min[1], b.tank->max[2] - b.tank->min[2]};
    estimate.boundarySamples += perArea * (boxArea(size) - size[0] * size[1]);
  }
  for (const Slope& slope : b.slopes) estimate.boundarySamples += perArea * boxArea(slope.size);
  estimate.boundarySamples += perArea * planeExtent(b) * planeExtent(b) * double(b.planes.size());
  estimate.bytes = kBytesPerFluidParticle * estimate.fluidParticles + kBytesPerBoundarySample * estimate.boundarySamples;
  return estimate;
}

double availableMemory() {
  std::ifstream meminfo("/proc/meminfo");
  std::string key;
  double kilobytes = 0;
  std::string unit;
  while (meminfo >> key >> kilobytes >> unit)
    if (key == "MemAvailable:") return kilobytes * 1024.0;
  const long pages = ::sysconf(_SC_PHYS_PAGES), pageSize = ::sysconf(_SC_PAGE_SIZE);
  return pages > 0 && pageSize > 0 ? double(pages) * double(pageSize) : 0.0;
}

int deepestFluidLayers(const Scene& scene) {
  const Vec3d gravity(scene.gravity[0], scene.gravity[1], scene.gravity[2]);
  if (!(gravity.norm() > 0)) return 0;
  const Vec3d down = gravity.normalized();
  int deepest = 0;
  for (const FluidBlock& block : scene.fluid.blocks) {
    double extent = 0;  // of the box along gravity
    for (int k = 0; k < 3; ++k) extent += std::abs(down[k]) * (block.box.max[k] - block.box.min[k]);
    deepest = std::max(deepest, int(std::floor(extent / scene.fluid.spacing + 1e-6)));
  }
  return deepest;
}

} // namespace cascade::scene
