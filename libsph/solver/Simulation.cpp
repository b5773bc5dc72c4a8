#include "libsph/solver/Simulation.h"

#include "libsph/Errors.h"
#include "libsph/Kernels.h"
#include "libsph/bodies/DeformingMesh.h"
#include "libsph/bodies/MovingBoundary.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/BinaryPod.h"
#include "libsph/solver/DomainPartition.h"
#include "libsph/solver/ReactionSums.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <istream>
#include <limits>
#include <ostream>
#include <sstream>
#include <stdexcept>

namespace cascade {

namespace {

using Clock = std::chrono::steady_clock;

/// Largest fraction of the repulsion radius r0 a particle may travel per step
/// (weakly compressible strategies; see computeTimeStep).
constexpr double kBoundaryLayerSteps = 0.5;
double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// Sum of poly6 over the cubic lattice of `spacing` around a lattice point (self included).
double latticeKernelSum(Real spacing, Real supportRadius) {
  const KernelPoly6 poly6(supportRadius);
  const int reach = static_cast<int>(std::ceil(supportRadius / spacing));
  double sum = 0;
  for (int z = -reach; z <= reach; ++z)
    for (int y = -reach; y <= reach; ++y)
      for (int x = -reach; x <= reach; ++x) {
        const Real r2 = spacing * spacing * Real(x * x + y * y + z * z);
        sum += poly6.valueFromSquared(r2);
      }
  return sum;
}

/// C of DerivedConstants::gradientCorrection on the lattice of `spacing`.
double latticeGradientSum(Real spacing, Real supportRadius, double volume) {
  const KernelSpiky spiky(supportRadius);
  const int reach = static_cast<int>(std::ceil(supportRadius / spacing));
  double sum = 0;
  for (int z = -reach; z <= reach; ++z)
    for (int y = -reach; y <= reach; ++y)
      for (int x = -reach; x <= reach; ++x) {
        const Vec3r r = spacing * Vec3r(Real(x), Real(y), Real(z));  // x_i - x_j
        sum += double(r.dot(spiky.gradient(r)));
      }
  return -volume * sum / 3.0;  // (x_j - x_i) . grad W = -r . grad W
}

/// Type I samples with the gap and list radius the strategy needs (TimeStepNeeds),
/// by default the SEED's sampleGap * r0 and r0.
void sampleBoundaries(const TimeStep& timeStep, const SimulationSettings& settings, const DerivedConstants& constants,
                      const std::vector<BoundaryPtr>& boundaries, BoundaryParticles& particles) {
  const TimeStepNeeds needs = timeStep.needs(settings, constants);
  const Real r0 = constants.repulsionRadius;
  const Real gap = needs.sampleGap > 0 ? needs.sampleGap : settings.boundary.sampleGap * r0;
  particles.sample(boundaries, gap, std::max(r0, needs.sampleRadius));
}

/// Each list in order of particle id: the sums over neighbours then do not depend
/// on where particles are stored, so every rank count gives the same bits.
void sortNeighborsById(NeighborLists& lists, const std::vector<ParticleId>& id) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, lists.size(), 256), [&](const auto& range) {
    std::vector<std::uint64_t> keys;
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      std::uint32_t* begin = lists.indices.data() + lists.offsets[i];
      const std::uint32_t count = lists.count(i);
      keys.resize(count);
      for (std::uint32_t k = 0; k < count; ++k) keys[k] = (std::uint64_t(id[begin[k]]) << 32) | begin[k];
      std::sort(keys.begin(), keys.end());
      for (std::uint32_t k = 0; k < count; ++k) begin[k] = std::uint32_t(keys[k]);
    }
  });
}

/// A strategy's per-particle state for particles [0, count), stateWidth() Reals each.
std::vector<Real> packedState(const TimeStep& timeStep, std::size_t count) {
  const std::size_t width = timeStep.stateWidth();
  std::vector<Real> state(count * width);
  for (std::size_t i = 0; i < count && width > 0; ++i) timeStep.packState(i, state.data() + i * width);
  return state;
}

/// Resizes the strategy to the particles `state` holds and gives each its state back.
void unpackState(TimeStep& timeStep, const std::vector<Real>& state, std::size_t count) {
  const std::size_t width = timeStep.stateWidth();
  timeStep.resize(count);
  for (std::size_t i = 0; i < count && width > 0; ++i) timeStep.unpackState(i, state.data() + i * width);
}

constexpr char kMagic[8] = {'C', 'S', 'C', 'D', 'S', 'I', 'M', '2'};  // 2: moving solids' state

template <typename T>
void writePod(std::ostream& out, const T& value) {
  writePodValue(out, value);
}
template <typename T>
void readPod(std::istream& in, T& value) {
  readPodValue(in, value, "data");
}
template <typename T>
void writeArray(std::ostream& out, const std::vector<T>& values) {
  writePod(out, static_cast<std::uint64_t>(values.size()));
  out.write(reinterpret_cast<const char*>(values.data()), std::streamsize(values.size() * sizeof(T)));
}
template <typename T>
void readArray(std::istream& in, std::vector<T>& values, std::uint64_t expected) {
  std::uint64_t count = 0;
  readPod(in, count);
  if (count != expected) throw InputError("checkpoint: inconsistent array size");
  values.resize(count);
  in.read(reinterpret_cast<char*>(values.data()), std::streamsize(count * sizeof(T)));
  if (!in) throw InputError("checkpoint: truncated data");
}

} // namespace

Simulation::Simulation(const SimulationSettings& settings) : mSettings(settings) {
  validateSettings(mSettings, "settings");
  if (mSettings.solver.supportRadiusFactor == 0)
    mSettings.solver.supportRadiusFactor = Real(defaultSupportFactor(mSettings.solver.type));
  try {
    mTimeStep = makeTimeStep(mSettings.solver.type);
  } catch (const std::invalid_argument&) {
    std::string known;
    for (const std::string& t : timeStepTypes()) known += (known.empty() ? "" : ", ") + t;
    throw InputError("settings: solver.type: unknown solver '" + mSettings.solver.type + "' (known: " + known + ")");
  }
  try {
    mSearch = makeNeighborSearch(mSettings.solver.neighborSearch);
    // Exact restarts need the same neighbour order as an uninterrupted run: the
    // grid's incremental rebuild keeps a canonical order within cells, so it may stay on.
  } catch (const std::invalid_argument&) {
    throw InputError("settings: solver.neighbor_search: unknown method '" + mSettings.solver.neighborSearch + "'");
  }
  mConstants.supportRadius = mSettings.solver.supportRadiusFactor * mSettings.fluid.spacing;
  mConstants.particleMass = static_cast<Real>(
      mSettings.fluid.restDensity / latticeKernelSum(mSettings.fluid.spacing, mConstants.supportRadius));
  mParticles.mass = mConstants.particleMass;
  mConstants.gradientCorrection = static_cast<Real>(
      1.0 / latticeGradientSum(mSettings.fluid.spacing, mConstants.supportRadius,
                               double(mConstants.particleMass) / mSettings.fluid.restDensity));
}

Simulation::~Simulation() = default;

Real Simulation::supportRadius() const { return mConstants.supportRadius; }
Real Simulation::particleMass() const { return mConstants.particleMass; }

std::size_t Simulation::addBoundary(BoundaryPtr boundary) {
  if (boundary->name().empty()) boundary->setName(boundary->kind() + std::to_string(mBoundaries.size()));
  mBoundaries.push_back(std::move(boundary));
  mObstacleForce.assign(mBoundaries.size(), Vec3d::Zero());
  mReportedForce.assign(mBoundaries.size(), Vec3d::Zero());
  mObstacleMoment.assign(mBoundaries.size(), Vec3d::Zero());
  if (mStarted) {
    sampleBoundaries(*mTimeStep, mSettings, mConstants, mBoundaries, mBoundaryParticles);
  }
  return mBoundaries.size() - 1;
}

long Simulation::findBoundary(const std::string& name) const {
  for (std::size_t b = 0; b < mBoundaries.size(); ++b)
    if (mBoundaries[b]->name() == name) return static_cast<long>(b);
  return -1;
}

ParticleId Simulation::addParticle(const Vec3r& position, const Vec3r& velocity) {
  const ParticleId id = mNextId++;
  if (mPartition && mStarted && !mPartition->owns(position)) return id;  // its owner adds it
  mParticles.add(position, velocity, id);
  mParticles.density.back() = mSettings.fluid.restDensity;
  mTimeStep->resize(mParticles.size());
  return id;
}

std::size_t Simulation::addFluidBox(const Vec3r& lo, const Vec3r& hi, const Vec3r& velocity) {
  const Real s = mSettings.fluid.spacing;
  long counts[3];
  for (int a = 0; a < 3; ++a) counts[a] = std::max(0L, static_cast<long>(std::floor((hi[a] - lo[a]) / s + Real(1e-3))));
  const std::size_t before = mParticles.size();
  mParticles.reserve(before + std::size_t(counts[0]) * counts[1] * counts[2]);
  for (long z = 0; z < counts[2]; ++z)
    for (long y = 0; y < counts[1]; ++y)
      for (long x = 0; x < counts[0]; ++x) {
        const Vec3r p = lo + s * Vec3r(Real(x) + Real(0.5), Real(y) + Real(0.5), Real(z) + Real(0.5));
        const ParticleId id = mNextId++;
        mParticles.add(p, velocity, id);
        mParticles.density.back() = mSettings.fluid.restDensity;
      }
  mTimeStep->resize(mParticles.size());
  const FluidBoxRecord box{before, mParticles.size() - before};
  if (mStarted) {
    compressHydrostatically(box);
    if (mPartition) keepOwned();
  } else {
    mPendingBoxes.push_back(box);
  }
  return mParticles.size() - before;
}

bool Simulation::hydrostaticColumn(const FluidBoxRecord& box, Real& bottom, Real& depth) const {
  const SolverSettings& solver = mSettings.solver;
  const Real g = solver.gravity.norm();
  if (!solver.hydrostaticStart || solver.type != "wcsph" || box.count == 0 || g <= 0 || mConstants.stiffness <= 0)
    return false;
  const Vec3r up = -solver.gravity / g;
  const Real s = mSettings.fluid.spacing;
  Real top = -std::numeric_limits<Real>::max();
  bottom = std::numeric_limits<Real>::max();
  std::size_t lowest = box.first;
  for (std::size_t i = box.first; i < box.first + box.count; ++i) {
    const Real height = mParticles.position[i].dot(up);
    top = std::max(top, height);
    if (height < bottom) { bottom = height; lowest = i; }
  }
  // Only a box resting on a solid (one spacing below its lowest particle) is
  // hydrostatic; a falling blob has no pressure.
  const Vec3r below = mParticles.position[lowest] - s * up;
  bool resting = false;
  for (const BoundaryPtr& b : mBoundaries) resting = resting || b->isInside(below);
  if (!resting) return false;
  bottom -= Real(0.5) * s;  // the box faces lie half a spacing outside its particles
  depth = top + Real(0.5) * s - bottom;
  return true;
}

Real Simulation::hydrostaticInverseRatio(Real depth) const {
  // rho_0 / rho at depth d: linear 1 / (1 + |g| d / k); Tait (1 + gamma |g| d / k)^(-1/gamma).
  const SolverSettings& solver = mSettings.solver;
  const Real g = solver.gravity.norm(), k = mConstants.stiffness, gamma = solver.taitExponent;
  return solver.equationOfState == EquationOfState::Tait ? std::pow(Real(1) + gamma * g * depth / k, Real(-1) / gamma)
                                                          : Real(1) / (Real(1) + g * depth / k);
}

void Simulation::compressHydrostatically(const FluidBoxRecord& box) {
  // Monaghan (1994), J. Comput. Phys. 110, section 4: start at the hydrostatic
  // density. The density here is summed (SEED (4)), so the lattice itself is
  // compressed along gravity: a particle at height u above the bottom of the
  // box moves to u' = integral_0^u rho_0 / rho(D - z) dz (mass per area kept),
  // rho(d) from the equation of state at p = rho_0 |g| d, D the box height.
  Real bottom = 0, depthTotal = 0;
  if (!hydrostaticColumn(box, bottom, depthTotal)) return;
  const Vec3r up = -mSettings.solver.gravity.normalized();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(box.first, box.first + box.count, 1024), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      Vec3r& x = mParticles.position[i];
      const Real u = x.dot(up) - bottom;
      constexpr int kSteps = 32;  // midpoint rule; the integrand is smooth and within 1 % of 1
      Real compressed = 0;
      for (int q = 0; q < kSteps; ++q) compressed += hydrostaticInverseRatio(depthTotal - (Real(q) + Real(0.5)) * u / kSteps);
      compressed *= u / kSteps;
      x += (compressed - u) * up;
      mParticles.density[i] = mSettings.fluid.restDensity / hydrostaticInverseRatio(depthTotal - u);  // depth by mass above
    }
  });
}

void Simulation::start() {
  // Before the started check: a simulation restored from a checkpoint is started.
  if (mSettings.solver.kernels == KernelPair::Automatic)
    mSettings.solver.kernels = hasCoupledBodies() ? KernelPair::CubicSpline : KernelPair::WendlandC2;
  if (mStarted) return;
  const SolverSettings& solver = mSettings.solver;
  // Expected speed: free fall over the height of the scene, or the fastest particle.
  Real expected = solver.expectedSpeed;
  if (expected <= 0) {
    const Real g = solver.gravity.norm();
    Real speed2 = 0;
    for (const Vec3r& v : mParticles.velocity) speed2 = std::max(speed2, v.squaredNorm());
    Real fall = 0;
    if (g > 0 && !mParticles.empty()) {
      const Vec3r up = -solver.gravity / g;
      Real top = -std::numeric_limits<Real>::max(), bottom = std::numeric_limits<Real>::max();
      for (const Vec3r& p : mParticles.position) {
        top = std::max(top, p.dot(up));
        bottom = std::min(bottom, p.dot(up));
      }
      for (const BoundaryPtr& b : mBoundaries) {
        Vec3r lo, hi;
        b->bounds(lo, hi);
        const auto* moving = dynamic_cast<const MovingBoundary*>(b.get());
        const bool body = moving && moving->isDynamic();  // a body dropped from above the water falls too
        for (int corner = 0; corner < 8; ++corner) {
          const Vec3r c((corner & 1) ? hi.x() : lo.x(), (corner & 2) ? hi.y() : lo.y(), (corner & 4) ? hi.z() : lo.z());
          bottom = std::min(bottom, c.dot(up));
          if (body) top = std::max(top, c.dot(up));
        }
      }
      fall = std::sqrt(Real(2) * g * std::max(Real(0), top - bottom));
    }
    const Real floor = std::sqrt(Real(2) * kStandardGravity * mConstants.supportRadius);
    Real motion = 0;  // prescribed motions, over all time
    for (const BoundaryPtr& b : mBoundaries) motion = std::max(motion, Real(b->maxMotionSpeed()));
    expected = std::max({fall, std::sqrt(speed2), floor, motion});
  }
  mConstants.expectedSpeed = expected;
  mConstants.stiffness = solver.stiffness > 0 ? solver.stiffness : Real(100) * expected * expected;
  mConstants.speedOfSound = std::sqrt(mConstants.stiffness);
  if (!mTimeStep->needs(mSettings, mConstants).speedOfSoundInCfl) mConstants.speedOfSound = 0;  // CFL on v only
  mConstants.repulsionStrength =
      mSettings.boundary.repulsionStrength > 0 ? mSettings.boundary.repulsionStrength : expected * expected;
  // r0 default: half a spacing, where the first layer sits with its mirror images
  // completing the lattice; for a box starting hydrostatic, half the compressed
  // spacing at its bottom, so the first layer starts at r0 where SEED (11) is zero,
  // not inside the repulsion layer (3 g upwards at the default stiffness; 10.7 m/s
  // after the first step of a fluid 100 times softer).
  Real compression = 1;
  for (const FluidBoxRecord& box : mPendingBoxes) {
    Real bottom = 0, depth = 0;
    if (hydrostaticColumn(box, bottom, depth)) compression = std::min(compression, hydrostaticInverseRatio(depth));
  }
  mConstants.repulsionRadius = mSettings.boundary.repulsionRadius > 0 ? mSettings.boundary.repulsionRadius
                                                                      : Real(0.5) * mSettings.fluid.spacing * compression;
  mStarted = true;
  for (const FluidBoxRecord& box : mPendingBoxes) compressHydrostatically(box);
  mPendingBoxes.clear();
  sampleBoundaries(*mTimeStep, mSettings, mConstants, mBoundaries, mBoundaryParticles);
  mObstacleForce.assign(mBoundaries.size(), Vec3d::Zero());
  mReportedForce.assign(mBoundaries.size(), Vec3d::Zero());
  mObstacleMoment.assign(mBoundaries.size(), Vec3d::Zero());
  if (mPartition) distribute();
}

void Simulation::distribute() {
  // The canonical search lattice's anchor: from the scene alone (the domain box, or the
  // solids at rest), so that every rank, and a resumed bake, uses the same one.
  Vec3r anchor = Vec3r::Constant(std::numeric_limits<Real>::max());
  if (mSettings.domain.enabled) {
    anchor = mSettings.domain.min;
  } else {
    for (const BoundaryPtr& b : mBoundaries) {
      if (b->moves()) continue;
      Vec3r blo, bhi;
      b->bounds(blo, bhi);
      if ((blo.array() > Real(-1e6)).all()) anchor = anchor.cwiseMin(blo);
    }
    for (int a = 0; a < 3; ++a)
      if (anchor[a] == std::numeric_limits<Real>::max()) anchor[a] = Real(-1000);
  }
  mLatticeAnchor = anchor - Vec3r::Constant(4 * mConstants.supportRadius);
  Vec3r lo = Vec3r::Constant(std::numeric_limits<Real>::max()), hi = -lo;
  for (const Vec3r& p : mParticles.position) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  for (const BoundaryPtr& b : mBoundaries) {
    Vec3r blo, bhi;
    b->bounds(blo, bhi);
    if ((blo.array() > Real(-1e6)).all() && (bhi.array() < Real(1e6)).all()) lo = lo.cwiseMin(blo), hi = hi.cwiseMax(bhi);
  }
  mPartition->start(mParticles, mConstants.supportRadius, lo, hi, mSettings.solver.gravity);
  keepOwned();
}

void Simulation::setPartition(DomainPartition* partition) {
  if (mStarted) throw std::logic_error("Simulation::setPartition: set it before the first step");
  mPartition = partition;
}

void Simulation::keepOwned() {
  std::vector<char> remove(mParticles.size(), 0);
  bool any = false;
  for (std::size_t i = 0; i < mParticles.size(); ++i)
    if (!mPartition->owns(mParticles.position[i])) {
      remove[i] = 1;
      any = true;
    }
  if (!any) return;
  mParticles.removeIf(remove);
  mTimeStep->removeIf(remove);
  mPendingBoxes.clear();
}

Particles Simulation::gatheredParticles() const {
  return mPartition ? mPartition->gatherToFirst(mParticles) : mParticles;
}

double Simulation::computeTimeStep() const {
  const SolverSettings& solver = mSettings.solver;
  const Real maxSpeed2 = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mParticles.size(), 8192), Real(0),
      [&](const auto& range, Real m) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) m = std::max(m, mParticles.velocity[i].squaredNorm());
        return m;
      },
      [](Real a, Real b) { return std::max(a, b); });
  const double speed2 = mPartition ? mPartition->maxOverRanks(double(maxSpeed2)) : double(maxSpeed2);
  const double h = mConstants.supportRadius;
  // A moving solid's fastest point counts as a particle: the fluid it meets soon moves as fast.
  const double maxSpeed = std::max(std::sqrt(speed2), maxSolidSpeed());
  const TimeStepNeeds needs = mTimeStep->needs(mSettings, mConstants);
  const double cfl = needs.maxCflFactor > 0 ? std::min(solver.cflFactor, needs.maxCflFactor) : solver.cflFactor;
  double dt = cfl * h / (double(mConstants.speedOfSound) + maxSpeed);
  const double nu = mSettings.fluid.viscosity / mSettings.fluid.restDensity;
  if (nu > 0) dt = std::min(dt, 0.125 * h * h / nu);
  dt = std::min(dt, needs.dampingStep);
  const double forceFactor = needs.forceStepFactor;
  // Gravity acts on every particle: a bound on the first step too (before any step's
  // acceleration is known; a 5 ms first step launched a resting 72-layer DFSPH column).
  const double maxAcceleration = std::max(double(mLastMaxAcceleration), double(solver.gravity.norm()));
  if (maxAcceleration > 0) dt = std::min(dt, forceFactor * std::sqrt(h / maxAcceleration));
  double methodBound = mTimeStep->maxTimeStep(mConstants);  // the method's own bound (DFSPH: its stiffness)
  if (mPartition) methodBound = -mPartition->maxOverRanks(-methodBound);
  dt = std::min(dt, methodBound);
  // Boundary layer resolution (weakly compressible strategies with type I particles):
  // no particle may cross more than half the repulsion radius r0 of SEED (11) in one
  // step, or it jumps over the repulsion layer and through the wall. With the default
  // stiffness (c = 10 v) the CFL above is several times smaller; this holds a soft
  // fluid (c of the order of v) or a forced large CFL factor.
  if (mConstants.speedOfSound > 0 && mSettings.boundary.repulsionParticles && mConstants.repulsionStrength > 0 &&
      maxSpeed > 0)
    dt = std::min(dt, kBoundaryLayerSteps * double(mConstants.repulsionRadius) / maxSpeed);
  return std::clamp(dt, double(solver.minTimeStep), double(solver.maxTimeStep));
}

double Simulation::nextTimeStep() {
  start();
  return computeTimeStep();
}

void Simulation::reorder() {
  const std::size_t n = mParticles.size();
  if (n < 2) return;
  // The grid search's own curve (its cells of h, by cell and then index): right after a
  // reorder, particles are stored in the order the search visits them, and the search
  // writes each chunk's lists in that order (search/ListAssembly.h), so the passes over
  // the lists read them front to back.
  const std::vector<std::size_t> order = zOrderPermutation(mParticles.position.data(), n, mConstants.supportRadius);
  mParticles.permute(order);
  mTimeStep->permute(order);
}

double Simulation::step() {
  start();
  const double dt = computeTimeStep();
  mLastTimeStep = dt;
  auto begin = Clock::now();
  const std::size_t interval = static_cast<std::size_t>(mSettings.solver.reorderInterval);
  if (interval > 0 && mStepCount % interval == 0) reorder();
  const Real h = mConstants.supportRadius;
  const std::size_t owned = mParticles.size();
  if (mPartition) {
    mPartition->addGhosts(mParticles, h);  // [owned, size): neighbours from other ranks
    mTimeStep->resize(mParticles.size());
  }
  if (mParticles.empty()) {
    mNeighbors.clear();
  } else {
    // Over ranks the lists go in a canonical order (by cell of a lattice fixed by the
    // scene, then by id), from the search itself where it can, else sorted by id.
    const bool canonical = mPartition && mSearch->setCanonicalOrder(mParticles.id.data(), mLatticeAnchor);
    mSearch->findNeighbors(mParticles.position.data(), mParticles.size(), h, mNeighbors);
    if (mPartition && !canonical) sortNeighborsById(mNeighbors, mParticles.id);
  }
  mTimings.neighbors += millisecondsSince(begin);

  begin = Clock::now();
  const BoundarySettings& bs = mSettings.boundary;
  const TimeStepNeeds needs = mTimeStep->needs(mSettings, mConstants);
  mBoundaryParticles.update(mParticles, mBoundaries, std::max(mConstants.repulsionRadius, needs.sampleRadius),
                            bs.kappa * h, bs.repulsionParticles || needs.alwaysSamples,
                            bs.mirrorParticles && needs.mirrorParticles);
  mTimings.boundary += millisecondsSince(begin);

  mAcceleration.resize(mParticles.size());
  mObstacleForce.assign(mBoundaries.size(), Vec3d::Zero());
  mReportedForce.assign(mBoundaries.size(), Vec3d::Zero());
  mObstacleMoment.assign(mBoundaries.size(), Vec3d::Zero());
  const std::vector<std::uint32_t>& layer = mBoundaryParticles.layer();
  mLayerStart.resize(layer.size());
  for (std::size_t k = 0; k < layer.size(); ++k) mLayerStart[k] = mParticles.position[layer[k]];
  StepContext context{mParticles, mNeighbors, mBoundaryParticles, mSettings, mConstants,
                      mAcceleration, mObstacleForce, mReportedForce, mObstacleMoment, mTimings, mTime, 0,
                      mPartition, owned, hasCoupledBodies()};
  context.step = mStepCount;
  mTimeStep->advance(context, static_cast<Real>(dt));
  // The forces on the solids are every rank's already (ReactionSums.h), the same bits on any rank count.
  if (mPartition) context.maxAcceleration = Real(mPartition->maxOverRanks(double(context.maxAcceleration)));
  begin = Clock::now();
  moveSolids(dt);
  keepOutOfSolids(dt, owned);
  mTimings.boundary += millisecondsSince(begin);
  mTimeStep->finishStep(context, static_cast<Real>(dt), mGuardedMoves);
  begin = Clock::now();
  if (mPartition) {
    mParticles.truncate(owned);  // the ghosts' owners moved them
    mTimeStep->resize(owned);
  }
  mTimings.boundary += millisecondsSince(begin);
  mLastMaxAcceleration = context.maxAcceleration;
  mTime += dt;
  ++mStepCount;
  ++mTimings.steps;

  begin = Clock::now();
  removeOutside();
  checkStability();
  if (mPartition) {
    // The strategy's per-particle state (DFSPH's warm starts) travels with its particle.
    std::vector<Real> state = packedState(*mTimeStep, mParticles.size());
    mPartition->migrate(mParticles, &state, mTimeStep->stateWidth());
    unpackState(*mTimeStep, state, mParticles.size());
  }
  mTimings.integrate += millisecondsSince(begin);
  return dt;
}

void Simulation::advanceTo(double endTime) {
  start();
  while (mTime < endTime) {
    double dt = computeTimeStep();
    if (mTime + dt >= endTime - 1e-12) {
      // Land on endTime exactly: shorten the last step (the settings' minimum does not apply).
      const SolverSettings saved = mSettings.solver;
      mSettings.solver.minTimeStep = std::min(mSettings.solver.minTimeStep, Real(std::max(endTime - mTime, 1e-12)));
      mSettings.solver.maxTimeStep = static_cast<Real>(std::max(endTime - mTime, 1e-12));
      step();
      mSettings.solver = saved;
      mTime = endTime;
      break;
    }
    step();
  }
}

void Simulation::resetNeighborSearch() { mSearch = makeNeighborSearch(mSettings.solver.neighborSearch); }

std::size_t Simulation::removeParticles(const std::vector<char>& remove) {
  const std::size_t removed = mParticles.removeIf(remove);
  if (removed > 0) mTimeStep->removeIf(remove);
  if (removed > 0) mPendingBoxes.clear();  // indices no longer valid
  return removed;
}

void Simulation::removeOutside() {
  if (!mSettings.domain.enabled) return;
  const std::size_t n = mParticles.size();
  std::vector<char> remove(n, 0);
  const Vec3r lo = mSettings.domain.min, hi = mSettings.domain.max;
  const std::size_t outside = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 8192), std::size_t(0),
      [&](const auto& range, std::size_t count) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Vec3r& p = mParticles.position[i];
          if (!((p.array() >= lo.array()).all() && (p.array() <= hi.array()).all()) && p.allFinite()) {
            remove[i] = 1;
            ++count;
          }
        }
        return count;
      },
      std::plus<std::size_t>());
  double removedEverywhere = double(outside);
  if (mPartition) mPartition->sumOverRanks(&removedEverywhere, 1);
  mRemovedCount += std::uint64_t(removedEverywhere);
  if (outside == 0) return;
  mParticles.removeIf(remove);
  mTimeStep->removeIf(remove);
}

/// The boundary models keep particles out of solids only as well as the step resolves
/// the approach (DFSPH: a particle gliding along a mesh crease, 1 in a 10 m/s jet at
/// 5 mm, measured). A particle of the step's boundary layer whose move entered a solid
/// (ended inside it, or passed through a thin part; Boundary::penetrated) goes back
/// out (a quarter spacing off the face where it entered, or where the step started)
/// and loses the part of its velocity into the solid: only energy is taken, and no
/// particle stays in a solid. Where two solids' ways out lie in each other (a gap
/// narrower than the clearance), it stays where the step started.
void Simulation::keepOutOfSolids(double dt, std::size_t owned) {
  constexpr int kGuardPasses = 3;  // a corner of three solids
  const std::vector<std::uint32_t>& layer = mBoundaryParticles.layer();
  mGuardedMoves.clear();
  if (mBoundaries.empty()) return;
  const Real clearance = Real(0.25) * mSettings.fluid.spacing;
  // The velocity the guard takes is the wall's push: a force on it (-m dv / dt), summed
  // the same in every run and on any rank count (ReactionSums.h); a rigid body gets the
  // impulse at once (it has already moved for this step).
  const std::size_t boundaries = mBoundaries.size();
  ReactionSums reactions(layer.size(), boundaries, 2, mPartition);  // impulse, its moment
  std::vector<std::vector<GuardedMove>> chunkMoves(ReactionSums::chunks(layer.size()));
  const double mass = double(mConstants.particleMass);
  const Real reach = mBoundaryParticles.proximityReach(), reach2 = reach * reach;
  const Real invDt = Real(1 / dt);
  tbb::parallel_for(std::size_t(0), chunkMoves.size(), [&](std::size_t chunk) {
    const std::size_t end = std::min(layer.size(), (chunk + 1) * ReactionSums::kChunk);
    for (std::size_t k = chunk * ReactionSums::kChunk; k < end; ++k) {
      const std::uint32_t i = layer[k];
      if (i >= owned) continue;  // a ghost
      const Vec3r from = mLayerStart[k], moved = mParticles.position[i];
      Vec3r& v = mParticles.velocity[i];
      const Vec3r velocity = v;  // the velocity that moved it from `from`
      Vec3r to = moved, exit, normal;
      bool guarded = false, settled = false;
      std::size_t last = 0;  // the solid entered last
      // The impulse j the wall b takes, and its moment about the origin from `at`.
      const auto recordImpulse = [&](std::size_t b, const Vec3d& j, const Vec3r& at) {
        Vec3d* const record = reactions.record(k);
        record[reactions.index(0, b)] += j;
        record[reactions.index(1, b)] += at.cast<double>().cross(j);
      };
      // Every solid is asked, and asked again after one has put the particle back: a move
      // into a corner where two solids meet (a paddle on a tank's floor) enters both, and
      // the way out of one may lie in the other. A particle left inside a solid would
      // never come out (penetrated() sees no entry from inside) and would cross it.
      for (int pass = 0; pass < kGuardPasses; ++pass) {
        // A move that enters a solid crosses its surface, so it ends within the move's
        // length of it: a solid farther than the proximity's reach from `to` cannot have
        // been entered by a shorter move.
        const std::uint64_t near = squaredDistance(from, to) < reach2 ? mBoundaryParticles.boundariesNear(to)
                                                                      : ~std::uint64_t(0);
        bool entered = false;
        for (std::size_t b = 0; b < boundaries; ++b) {
          if (b < 64 && !((near >> b) & 1u)) continue;
          if (!mBoundaries[b]->penetrated(from, to, clearance, exit, normal)) continue;
          const Vec3r change = -std::min((v - mBoundaries[b]->velocityAt(exit)).dot(normal), Real(0)) * normal;
          v += change;  // relative to the wall
          to = exit;
          entered = true;
          last = b;
          recordImpulse(b, -mass * change.cast<double>(), exit);  // on the wall
        }
        if (!entered) {
          settled = true;
          break;
        }
        guarded = true;
      }
      if (!guarded) continue;
      if (!settled) {
        // The solids' ways out disagree (a gap narrower than the clearance, where each
        // solid's exit lies in the other): the particle stays where the step found it,
        // carried by a solid that has moved over that place, at that solid's velocity.
        to = from;
        Vec3r carried = Vec3r::Zero();
        for (std::size_t b = 0; b < boundaries; ++b)
          if (mBoundaries[b]->moves() && mBoundaries[b]->isInside(from)) carried = mBoundaries[b]->velocityAt(from);
        to += carried * Real(dt);
        recordImpulse(last, -mass * (carried - v).cast<double>(), to);  // on the wall
        v = carried;
      }
      mParticles.position[i] = to;
      // Its actual move, from `from` to where the guard left it (TimeStep::finishStep).
      chunkMoves[chunk].push_back(GuardedMove{i, velocity + (to - moved) * invDt});
    }
  });
  for (const std::vector<GuardedMove>& moves : chunkMoves)
    mGuardedMoves.insert(mGuardedMoves.end(), moves.begin(), moves.end());
  mKeptOutCount += mGuardedMoves.size();
  const std::vector<Vec3d> totals = reactions.totals();  // collective over ranks
  for (std::size_t b = 0; b < boundaries; ++b) {
    const Vec3d& j = totals[reactions.index(0, b)];
    const Vec3d& l = totals[reactions.index(1, b)];
    if (j.isZero() && l.isZero()) continue;
    mObstacleForce[b] += j / dt;
    mReportedForce[b] += j / dt;
    mObstacleMoment[b] += l / dt;
    if (auto* moving = dynamic_cast<MovingBoundary*>(mBoundaries[b].get()); moving && moving->isDynamic())
      moving->applyImpulse(j, l - moving->center().cross(j));
  }
}

void Simulation::checkStability() const {
  std::string message = stabilityMessage();
  if (mPartition) message = mPartition->firstMessage(message);
  if (!message.empty()) throw InstabilityError(message);
}

std::string Simulation::stabilityMessage() const {
  const Real limit = mSettings.solver.instabilitySpeedFactor * mConstants.expectedSpeed;
  const Real limit2 = limit * limit;
  const std::size_t n = mParticles.size();
  // The first offending index (deterministic).
  const std::size_t bad = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, 8192), n,
      [&](const auto& range, std::size_t first) {
        for (std::size_t i = range.begin(); i != range.end() && i < first; ++i) {
          const Vec3r& p = mParticles.position[i];
          const Vec3r& v = mParticles.velocity[i];
          if (!p.allFinite() || !v.allFinite() || v.squaredNorm() > limit2) return i;
        }
        return first;
      },
      [](std::size_t a, std::size_t b) { return std::min(a, b); });
  if (bad == n) return "";
  const Vec3r& p = mParticles.position[bad];
  const Vec3r& v = mParticles.velocity[bad];
  std::ostringstream message;
  message << "simulation unstable: particle " << mParticles.id[bad] << " at (" << p.x() << ", " << p.y()
          << ", " << p.z() << "), t = " << mTime << " s: ";
  if (!p.allFinite() || !v.allFinite())
    message << "position or velocity is not a number";
  else
    message << "speed " << v.norm() << " m/s exceeds " << limit << " m/s (" << mSettings.solver.instabilitySpeedFactor
            << " x the scene's expected " << mConstants.expectedSpeed << " m/s)";
  return message.str();
}

Vec3d Simulation::obstacleForce(std::size_t index) const {
  return index < mReportedForce.size() ? mReportedForce[index] : Vec3d::Zero();
}

Vec3d Simulation::exchangedForce(std::size_t index) const {
  return index < mObstacleForce.size() ? mObstacleForce[index] : Vec3d::Zero();
}

Vec3d Simulation::obstacleTorque(std::size_t index, const Vec3d& center) const {
  if (index >= mObstacleMoment.size()) return Vec3d::Zero();
  return mObstacleMoment[index] - center.cross(mObstacleForce[index]);
}

bool Simulation::hasMovingSolids() const {
  for (const BoundaryPtr& b : mBoundaries)
    if (b->moves()) return true;
  return false;
}

bool Simulation::hasCoupledBodies() const {
  for (const BoundaryPtr& b : mBoundaries)
    if (const auto* moving = dynamic_cast<const MovingBoundary*>(b.get()); moving && moving->isDynamic()) return true;
  return false;
}

const MovingBoundary* Simulation::movingSolid(std::size_t index) const {
  return index < mBoundaries.size() ? dynamic_cast<const MovingBoundary*>(mBoundaries[index].get()) : nullptr;
}

double Simulation::maxSolidSpeed() const {
  double speed = 0;
  for (const BoundaryPtr& b : mBoundaries)
    speed = std::max(speed, b->maxSurfaceSpeed());
  return speed;
}

void Simulation::moveSolids(double dt) {
  if (!hasMovingSolids()) return;
  // Contacts of rigid bodies: with the solids at rest (tank, planes, slopes, static meshes).
  std::vector<const Boundary*> atRest;
  for (const BoundaryPtr& b : mBoundaries)
    if (!b->moves()) atRest.push_back(b.get());
  const Vec3d gravity = mSettings.solver.gravity.cast<double>();
  const Real clearance = Real(0.01) * mSettings.fluid.spacing;
  for (std::size_t b = 0; b < mBoundaries.size(); ++b) {
    if (auto* deforming = dynamic_cast<DeformingMeshBoundary*>(mBoundaries[b].get())) deforming->moveTo(mTime + dt);
    auto* moving = dynamic_cast<MovingBoundary*>(mBoundaries[b].get());
    if (moving == nullptr) continue;
    const Vec3d center = moving->center();
    moving->advance(mTime + dt, dt, mObstacleForce[b], obstacleTorque(b, center), gravity, atRest, clearance);
  }
  // Rigid bodies against each other and against the other moving solids: the contacts
  // of every pair (in index order: deterministic), solved as one group with the bodies'
  // contacts with the solids at rest, so that a stack rests on the floor.
  std::vector<ContactConstraint> group;
  std::vector<MovingBoundary*> involved;
  const auto involve = [&](MovingBoundary* body) {
    if (std::find(involved.begin(), involved.end(), body) == involved.end()) involved.push_back(body);
  };
  std::vector<RigidContact> contacts;
  for (std::size_t b = 0; b < mBoundaries.size(); ++b) {
    auto* body = dynamic_cast<MovingBoundary*>(mBoundaries[b].get());
    if (body == nullptr || !body->isDynamic()) continue;
    for (std::size_t other = 0; other < mBoundaries.size(); ++other) {
      if (other == b || !mBoundaries[other]->moves()) continue;
      auto* otherBody = dynamic_cast<MovingBoundary*>(mBoundaries[other].get());
      const bool otherIsBody = otherBody && otherBody->isDynamic();
      if (otherIsBody && other < b) continue;  // that pair was done
      contacts.clear();
      body->contactsWith(*mBoundaries[other], clearance, contacts);
      if (contacts.empty()) continue;
      involve(body);
      if (otherIsBody) involve(otherBody);
      for (const RigidContact& c : contacts)
        group.push_back(otherIsBody ? contactConstraint(*body->body(), otherBody->body(), c)
                                    : contactConstraint(*body->body(), nullptr, c,
                                                        mBoundaries[other]->velocityAt(c.point.cast<Real>()).cast<double>()));
    }
  }
  if (group.empty()) return;
  std::vector<RigidPose> before;
  for (MovingBoundary* body : involved) {
    before.push_back(body->pose());
    for (const RigidContact& c : body->restingContacts()) group.push_back(contactConstraint(*body->body(), nullptr, c));
  }
  solveContacts(group);
  for (std::size_t k = 0; k < involved.size(); ++k) involved[k]->settle(before[k], atRest, clearance);
}

TriangleMesh Simulation::solidsMesh() const {
  TriangleMesh all;
  for (const BoundaryPtr& b : mBoundaries) {
    TriangleMesh mesh = b->surfaceMesh();
    mesh.groups.assign(1, TriangleMesh::Group{b->name(), 0, mesh.triangles.size()});
    all.append(mesh);
  }
  return all;
}

void Simulation::save(std::ostream& out) const {
  // Over ranks: every rank's particles and strategy state on rank 0, which writes them.
  Particles gathered;
  std::unique_ptr<TimeStep> gatheredStep;
  if (mPartition) {
    const std::vector<Real> state = packedState(*mTimeStep, mParticles.size());
    std::vector<Real> allState;
    gathered = mPartition->gatherToFirst(mParticles, &state, mTimeStep->stateWidth(), &allState);
    if (mPartition->rank() != 0) return;
    // A strategy holding every particle: this rank's (its state apart from the particles
    // is the same on every rank), then every rank's per-particle state.
    gatheredStep = makeTimeStep(mTimeStep->name());
    std::stringstream local;
    mTimeStep->save(local);
    gatheredStep->resize(mParticles.size());
    gatheredStep->restore(local);
    unpackState(*gatheredStep, allState, gathered.size());
  }
  const Particles& particles = mPartition ? gathered : mParticles;
  const TimeStep& timeStep = mPartition ? *gatheredStep : *mTimeStep;
  out.write(kMagic, sizeof(kMagic));
  writePod(out, static_cast<std::uint32_t>(sizeof(Real)));
  writePod(out, static_cast<std::uint64_t>(mBoundaries.size()));
  writePod(out, mStarted);
  writePod(out, mTime);
  writePod(out, mLastTimeStep);
  writePod(out, mLastMaxAcceleration);
  writePod(out, mStepCount);
  writePod(out, mRemovedCount);
  writePod(out, mNextId);
  writePod(out, mConstants);
  writePod(out, mParticles.mass);
  const std::uint64_t n = particles.size();
  writePod(out, n);
  writeArray(out, particles.position);
  writeArray(out, particles.velocity);
  writeArray(out, particles.density);
  writeArray(out, particles.pressure);
  writeArray(out, particles.id);
  writeArray(out, mObstacleForce);
  writeArray(out, mReportedForce);
  writeArray(out, mObstacleMoment);
  for (const BoundaryPtr& b : mBoundaries) {
    if (const auto* moving = dynamic_cast<const MovingBoundary*>(b.get())) moving->save(out);
    // A deforming surface is a function of the time it was placed at (the step's end,
    // which may differ from mTime by the round-off advanceTo lands on).
    if (const auto* deforming = dynamic_cast<const DeformingMeshBoundary*>(b.get())) writePod(out, deforming->time());
  }
  timeStep.save(out);
  if (!out) throw std::runtime_error("checkpoint: write failed");
}

void Simulation::restore(std::istream& in) {
  char magic[sizeof(kMagic)];
  in.read(magic, sizeof(magic));
  if (!in || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) throw InputError("checkpoint: not a Cascade solver checkpoint");
  std::uint32_t realSize = 0;
  readPod(in, realSize);
  if (realSize != sizeof(Real)) throw InputError("checkpoint: written with another floating-point precision");
  std::uint64_t boundaries = 0;
  readPod(in, boundaries);
  if (boundaries != mBoundaries.size()) throw InputError("checkpoint: written for a scene with another set of boundaries");
  readPod(in, mStarted);
  mPendingBoxes.clear();  // the checkpoint's particles are already in their state
  readPod(in, mTime);
  readPod(in, mLastTimeStep);
  readPod(in, mLastMaxAcceleration);
  readPod(in, mStepCount);
  readPod(in, mRemovedCount);
  readPod(in, mNextId);
  readPod(in, mConstants);
  readPod(in, mParticles.mass);
  std::uint64_t n = 0;
  readPod(in, n);
  readArray(in, mParticles.position, n);
  readArray(in, mParticles.velocity, n);
  readArray(in, mParticles.density, n);
  readArray(in, mParticles.pressure, n);
  readArray(in, mParticles.id, n);
  readArray(in, mObstacleForce, boundaries);
  readArray(in, mReportedForce, boundaries);
  readArray(in, mObstacleMoment, boundaries);
  for (const BoundaryPtr& b : mBoundaries) {
    if (auto* moving = dynamic_cast<MovingBoundary*>(b.get())) moving->restore(in);
    if (auto* deforming = dynamic_cast<DeformingMeshBoundary*>(b.get())) {
      double placed = 0;
      readPod(in, placed);
      deforming->resetTo(placed);
    }
  }
  mTimeStep->resize(n);
  mTimeStep->restore(in);
  if (mStarted) {
    sampleBoundaries(*mTimeStep, mSettings, mConstants, mBoundaries, mBoundaryParticles);
    if (mPartition) distribute();  // every rank read every particle: each keeps its share
  }
}

void Simulation::save(const std::string& path) const {
  writeFileAtomically(path, [&](const std::filesystem::path& temp) {
    std::ofstream out(temp, std::ios::binary);
    if (!out) throw std::runtime_error(temp.string() + ": cannot write checkpoint");
    save(out);
  });
}

void Simulation::restore(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read checkpoint");
  try {
    restore(in);
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
}

} // namespace cascade
