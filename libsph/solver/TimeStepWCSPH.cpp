#include "libsph/solver/TimeStepWCSPH.h"

#include "libsph/Kernels.h"
#include "libsph/boundary/BoundaryParticles.h"
#include "libsph/solver/EquationOfState.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <chrono>
#include <cmath>

namespace cascade {

namespace {

using Clock = std::chrono::steady_clock;
double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

/// The pairwise terms shared by fluid and mirror neighbours.
struct PairTerms {
  KernelSpiky spiky;
  KernelViscosity viscosity;
  Real supportRadius2;
  Real mass;
  Real viscosityCoeff;       // mu m
  Real artificialCoeff;      // alpha h c (Monaghan 1992)
  Real epsilon2;             // 0.01 h^2
  Real pressureFactor;       // (1 or 1/2 as printed) / C (lattice gradient correction)

  explicit PairTerms(const StepContext& c)
      : spiky(c.constants.supportRadius), viscosity(c.constants.supportRadius),
        supportRadius2(c.constants.supportRadius * c.constants.supportRadius),
        mass(c.constants.particleMass),
        viscosityCoeff(c.settings.fluid.viscosity * c.constants.particleMass),
        artificialCoeff(c.settings.solver.artificialViscosity * c.constants.supportRadius *
                        c.constants.speedOfSound),
        epsilon2(Real(0.01) * c.constants.supportRadius * c.constants.supportRadius),
        pressureFactor((c.settings.solver.pressureForce == PressureForce::MuellerHalf ? Real(0.5) : Real(1)) *
                       c.constants.gradientCorrection) {}

  /// Acceleration of i (times rho_i for the pressure/viscosity parts) from one neighbour j.
  /// Returns the contribution to a_i.
  inline Vec3r operator()(const Vec3r& r, Real r2, Real pressureI, Real densityI, const Vec3r& velocityI,
                          Real pressureJ, Real densityJ, const Vec3r& velocityJ) const {
    const Real len = std::sqrt(r2);
    const Real diff = spiky.supportRadius - len;
    // grad W_spiky = -45/(pi h^6) (h - r)^2 r/|r|  (SEED (8))
    const Vec3r gradient = (spiky.gradientCoeff * diff * diff / len) * r;
    // SEED (5) / rho_i: -m (p_i + p_j) / (rho_j rho_i) grad W (times 1/2 as printed)
    Real scalar = -mass * pressureFactor * (pressureI + pressureJ) / (densityJ * densityI);
    const Vec3r relativeVelocity = velocityI - velocityJ;
    if (artificialCoeff > 0) {
      const Real vr = relativeVelocity.dot(r);
      if (vr < 0) {
        // Monaghan 1992: Pi_ij = -alpha h c (v_ij . r_ij) / (rho_avg (r^2 + 0.01 h^2))
        const Real pi = -artificialCoeff * vr / (Real(0.5) * (densityI + densityJ) * (r2 + epsilon2));
        scalar -= mass * pi;
      }
    }
    Vec3r acceleration = scalar * gradient;
    if (viscosityCoeff > 0) {
      // SEED (6) / rho_i: mu m (v_j - v_i) / (rho_j rho_i) lap W_visc
      acceleration += (viscosityCoeff * viscosity.laplacianCoeff * diff / (densityJ * densityI)) *
                      (-relativeVelocity);
    }
    return acceleration;
  }
};

} // namespace

namespace wcsph {

void computeFluidDensity(StepContext& c) {
  Particles& particles = c.particles;
  const KernelPoly6 poly6(c.constants.supportRadius);
  const Real mass = c.constants.particleMass;
  const Real self = poly6.valueFromSquared(0);
  const NeighborLists& nl = c.neighbors;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 512), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3r xi = particles.position[i];
      Real sum = self;
      for (const std::uint32_t* j = nl.begin(i); j != nl.end(i); ++j)
        sum += poly6.valueFromSquared(squaredDistance(xi, particles.position[*j]));
      particles.density[i] = mass * sum;  // SEED (4)
    }
  });
}

void addMirrorDensity(StepContext& c) {
  const BoundaryParticles& boundary = c.boundary;
  if (boundary.mirrors().empty()) return;
  Particles& particles = c.particles;
  const KernelPoly6 poly6(c.constants.supportRadius);
  const Real mass = c.constants.particleMass;
  const Real h2 = c.constants.supportRadius * c.constants.supportRadius;
  const NeighborLists& nl = c.neighbors;
  const std::vector<std::uint32_t>& layer = boundary.layer();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, layer.size(), 256), [&](const auto& range) {
    for (std::size_t k = range.begin(); k != range.end(); ++k) {
      const std::uint32_t i = layer[k];
      const Vec3r xi = particles.position[i];
      Real sum = 0;
      for (std::uint32_t m = boundary.mirrorOffsets()[i]; m < boundary.mirrorOffsets()[i + 1]; ++m) {
        const MirrorMap& map = boundary.mirrors()[m];
        // mirror of i itself, then of each neighbour
        Real r2 = squaredDistance(xi, map.apply(xi));
        if (r2 < h2) sum += poly6.valueFromSquared(r2);
        for (const std::uint32_t* j = nl.begin(i); j != nl.end(i); ++j) {
          r2 = squaredDistance(xi, map.apply(particles.position[*j]));
          if (r2 < h2) sum += poly6.valueFromSquared(r2);
        }
      }
      particles.density[i] += mass * sum;
    }
  });
}

void computePressure(StepContext& c) {
  PressureModel model;
  model.equation = c.settings.solver.equationOfState;
  model.restDensity = c.settings.fluid.restDensity;
  model.stiffness = c.constants.stiffness;
  model.exponent = c.settings.solver.taitExponent;
  model.clampNegative = c.settings.solver.clampNegativePressure;
  Particles& particles = c.particles;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, particles.size(), 2048), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) particles.pressure[i] = model(particles.density[i]);
  });
}

void computeFluidAcceleration(StepContext& c) {
  const Particles& particles = c.particles;
  const PairTerms terms(c);
  const NeighborLists& nl = c.neighbors;
  const Vec3r gravity = c.settings.solver.gravity;
  std::vector<Vec3r>& acceleration = c.acceleration;
  const std::size_t n = particles.size();
  acceleration.resize(n);
  // 1 / rho once per particle, so the pair loop has one division (and one sqrt).
  static thread_local std::vector<Real> inverseDensity;
  inverseDensity.resize(n);
  // The calling thread's buffer: inside the lambda `inverseDensity` would name
  // each TBB worker's own (empty) thread_local vector.
  Real* const inverseDensityOut = inverseDensity.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) inverseDensityOut[i] = Real(1) / particles.density[i];
  });
  const Real h = terms.spiky.supportRadius, h2 = terms.supportRadius2;
  const Real gradientCoeff = terms.spiky.gradientCoeff;
  const Real pressureCoeff = -terms.mass * terms.pressureFactor;  // SEED (5) / rho_i
  const Real artificialCoeff = Real(2) * terms.mass * terms.artificialCoeff;
  const Real viscosityCoeff = terms.viscosityCoeff * terms.viscosity.laplacianCoeff;
  const Real* invRho = inverseDensity.data();
  const Vec3r* x = particles.position.data();
  const Vec3r* v = particles.velocity.data();
  const Real* p = particles.pressure.data();
  const Real* rho = particles.density.data();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      const Vec3r xi = x[i], vi = v[i];
      const Real pi = p[i], rhoi = rho[i], invRhoi = invRho[i];
      Vec3r a = Vec3r::Zero(), viscous = Vec3r::Zero();
      for (const std::uint32_t* jp = nl.begin(i); jp != nl.end(i); ++jp) {
        const std::uint32_t j = *jp;
        const Vec3r r = xi - x[j];
        const Real r2 = r.squaredNorm();
        if (r2 >= h2 || r2 <= Real(0)) continue;
        const Real len = std::sqrt(r2);
        const Real diff = h - len;
        // grad W_spiky = -45/(pi h^6) (h - r)^2 r/|r|  (SEED (8)); scalar part over |r|
        const Real invRhoj = invRho[j];
        Real scalar = pressureCoeff * (pi + p[j]) * invRhoi * invRhoj;
        const Vec3r relativeVelocity = vi - v[j];
        const Real vr = relativeVelocity.dot(r);
        if (vr < 0 && artificialCoeff > 0)  // Monaghan 1992
          scalar += artificialCoeff * vr / ((rhoi + rho[j]) * (r2 + terms.epsilon2));
        a += (scalar * gradientCoeff * diff * diff / len) * r;
        if (viscosityCoeff > 0) viscous -= (diff * invRhoj) * relativeVelocity;  // SEED (6)
      }
      acceleration[i] = gravity + a + (viscosityCoeff * invRhoi) * viscous;
    }
  });
}

void addBoundaryAcceleration(StepContext& c) {
  const BoundaryParticles& boundary = c.boundary;
  const Particles& particles = c.particles;
  const std::vector<std::uint32_t>& layer = boundary.layer();
  const std::size_t boundaryCount = c.obstacleForce.size();
  std::fill(c.obstacleForce.begin(), c.obstacleForce.end(), Vec3d::Zero());
  if (layer.empty()) return;
  const PairTerms terms(c);
  const NeighborLists& nl = c.neighbors;
  const bool noSlip = c.settings.boundary.slip == MirrorSlip::NoSlip;
  const Real r0 = c.constants.repulsionRadius, r02 = r0 * r0;
  const Real strength = c.constants.repulsionStrength;
  const Real minR2 = Real(0.04) * r02;  // SEED (11) is singular at r = 0; cap at r = 0.2 r0
  const std::vector<Vec3r>& samples = boundary.samplePositions();
  const std::vector<std::uint32_t>& owners = boundary.sampleOwners();
  const NeighborLists& sampleLists = boundary.sampleNeighbors();
  const Real mass = c.constants.particleMass;

  // Fixed chunks so the per-boundary force sums are the same in every run.
  constexpr std::size_t kChunk = 256;
  const std::size_t chunks = (layer.size() + kChunk - 1) / kChunk;
  std::vector<Vec3d> chunkForce(chunks * boundaryCount, Vec3d::Zero());
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t chunk) {
    Vec3d* force = chunkForce.data() + chunk * boundaryCount;
    const std::size_t end = std::min(layer.size(), (chunk + 1) * kChunk);
    for (std::size_t k = chunk * kChunk; k < end; ++k) {
      const std::uint32_t i = layer[k];
      const Vec3r xi = particles.position[i], vi = particles.velocity[i];
      const Real pi = particles.pressure[i], rhoi = particles.density[i];
      Vec3r total = Vec3r::Zero();
      // Type II: mirror particles of i and its neighbours.
      for (std::uint32_t m = boundary.mirrorOffsets()[i]; m < boundary.mirrorOffsets()[i + 1]; ++m) {
        const MirrorMap& map = boundary.mirrors()[m];
        Vec3r a = Vec3r::Zero();
        auto visit = [&](std::uint32_t j) {
          const Vec3r r = xi - map.apply(particles.position[j]);
          const Real r2 = r.squaredNorm();
          if (r2 >= terms.supportRadius2 || r2 <= Real(0)) return;
          const Vec3r& vj = particles.velocity[j];
          const Vec3r mirroredVelocity = noSlip ? Vec3r(-vj) : Vec3r(map.linear * vj);
          a += terms(r, r2, pi, rhoi, vi, particles.pressure[j], particles.density[j], mirroredVelocity);
        };
        visit(i);
        for (const std::uint32_t* j = nl.begin(i); j != nl.end(i); ++j) visit(*j);
        total += a;
        if (map.boundary < boundaryCount) force[map.boundary] -= (mass * a).cast<double>();
      }
      // Type I: SEED (11) f = D [(r0/r)^12 - (r0/r)^4] r / r^2, for r < r0.
      if (strength > 0) {
        for (const std::uint32_t* s = sampleLists.begin(i); s != sampleLists.end(i); ++s) {
          const Vec3r r = xi - samples[*s];
          const Real r2 = r.squaredNorm();
          if (r2 >= r02) continue;
          const Real q2 = r02 / std::max(r2, minR2);
          const Real q4 = q2 * q2, q12 = q4 * q4 * q4;
          const Vec3r a = (strength * (q12 - q4) / std::max(r2, minR2)) * r;
          total += a;
          const std::uint32_t owner = owners[*s];
          if (owner < boundaryCount) force[owner] -= (mass * a).cast<double>();
        }
      }
      c.acceleration[i] += total;
    }
  });
  for (std::size_t chunk = 0; chunk < chunks; ++chunk)
    for (std::size_t b = 0; b < boundaryCount; ++b) c.obstacleForce[b] += chunkForce[chunk * boundaryCount + b];
}

Real integrateSymplecticEuler(StepContext& c, Real dt) {
  Particles& particles = c.particles;
  const std::vector<Vec3r>& acceleration = c.acceleration;
  const Real maxA2 = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, particles.size(), 4096), Real(0),
      [&](const auto& range, Real m) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Vec3r& a = acceleration[i];
          m = std::max(m, a.squaredNorm());
          particles.velocity[i] += dt * a;                      // SEED (13)
          particles.position[i] += dt * particles.velocity[i];  // SEED (14)
        }
        return m;
      },
      [](Real a, Real b) { return std::max(a, b); });
  return std::sqrt(maxA2);
}

} // namespace wcsph

void TimeStepWCSPH::advance(StepContext& c, Real dt) {
  auto start = Clock::now();
  wcsph::computeFluidDensity(c);
  c.timings.density += millisecondsSince(start);

  start = Clock::now();
  wcsph::addMirrorDensity(c);
  c.timings.boundary += millisecondsSince(start);

  start = Clock::now();
  wcsph::computePressure(c);
  c.timings.density += millisecondsSince(start);

  start = Clock::now();
  wcsph::computeFluidAcceleration(c);
  c.timings.forces += millisecondsSince(start);

  start = Clock::now();
  wcsph::addBoundaryAcceleration(c);
  c.timings.boundary += millisecondsSince(start);

  start = Clock::now();
  c.maxAcceleration = wcsph::integrateSymplecticEuler(c, dt);
  c.timings.integrate += millisecondsSince(start);
}

} // namespace cascade
