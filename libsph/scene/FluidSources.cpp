#include "libsph/scene/FluidSources.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <cmath>
#include <functional>

namespace cascade::scene {

namespace {
Vec3d toVec(const Vec3& v) { return Vec3d(v[0], v[1], v[2]); }

/// Orthonormal nozzle frame: e1, e2 span the nozzle plane, n is its normal;
/// e2 is the emitter's `up` projected onto the plane.
void nozzleFrame(const Emitter& emitter, Vec3d& e1, Vec3d& e2, Vec3d& n) {
  n = toVec(emitter.normal).normalized();
  Vec3d up = toVec(emitter.up);
  up -= up.dot(n) * n;
  if (up.norm() < 1e-9) {  // up parallel to the normal: any perpendicular
    up = std::abs(n.x()) < 0.9 ? Vec3d(1, 0, 0) : Vec3d(0, 1, 0);
    up -= up.dot(n) * n;
  }
  e2 = up.normalized();
  e1 = e2.cross(n).normalized();
}

/// Lattice points of `spacing` that fit in `extent` (at least one).
int latticeCount(double extent, double spacing) { return std::max(1, int(std::floor(extent / spacing + 1e-6))); }
} // namespace

std::vector<Vec3r> blockPositions(const FluidBlock& block, double spacing) {
  int count[3];
  double first[3];
  for (int k = 0; k < 3; ++k) {
    const double extent = block.box.max[k] - block.box.min[k];
    count[k] = latticeCount(extent, spacing);
    first[k] = block.box.min[k] + 0.5 * (extent - (count[k] - 1) * spacing);
  }
  std::vector<Vec3r> positions;
  positions.reserve(std::size_t(count[0]) * count[1] * count[2]);
  for (int k = 0; k < count[2]; ++k)
    for (int j = 0; j < count[1]; ++j)
      for (int i = 0; i < count[0]; ++i)
        positions.emplace_back(Real(first[0] + i * spacing), Real(first[1] + j * spacing),
                               Real(first[2] + k * spacing));
  return positions;
}

std::vector<Vec3r> emitterLayer(const Emitter& emitter, double spacing) {
  Vec3d e1, e2, n;
  nozzleFrame(emitter, e1, e2, n);
  const Vec3d center = toVec(emitter.center);
  std::vector<Vec3r> layer;
  if (emitter.shape == "rectangle") {
    const int nu = latticeCount(emitter.size[0], spacing);
    const int nv = latticeCount(emitter.size[1], spacing);
    for (int j = 0; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        const Vec3d p = center + ((i - 0.5 * (nu - 1)) * spacing) * e1 + ((j - 0.5 * (nv - 1)) * spacing) * e2;
        layer.push_back(p.cast<Real>());
      }
  } else {
    const double radius = emitter.radius;
    const int reach = int(std::ceil(radius / spacing)) + 1;
    for (int j = -reach; j <= reach; ++j)
      for (int i = -reach; i <= reach; ++i) {
        // Lattice offset by half a spacing so the disk is symmetric.
        const double u = (i + 0.5) * spacing, v = (j + 0.5) * spacing;
        if (u * u + v * v <= radius * radius) layer.push_back((center + u * e1 + v * e2).cast<Real>());
      }
    if (layer.empty()) layer.push_back(center.cast<Real>());
  }
  return layer;
}

double emitterLayerRate(const Emitter& emitter, double spacing) {
  if (emitter.rate > 0) {
    const double perLayer = double(emitterLayer(emitter, spacing).size());
    return emitter.rate / perLayer;
  }
  return emitter.speed / spacing;
}

std::size_t emitUntil(const Emitter& emitter, const std::vector<Vec3r>& layer, double spacing,
                      double time, EmitterState& state,
                      const std::function<void(const Vec3r&, const Vec3r&)>& add) {
  if (time < emitter.start) return 0;
  const double layerRate = emitterLayerRate(emitter, spacing);
  const double until = std::min(time, emitter.end);
  const std::int64_t due = std::int64_t(std::floor((until - emitter.start) * layerRate + 1e-9)) + 1;
  const Vec3d n = toVec(emitter.normal).normalized();
  const Vec3r velocity = (emitter.speed * n).cast<Real>();
  std::size_t added = 0;
  for (; state.layers < due; ++state.layers) {
    const double releasedAt = emitter.start + double(state.layers) / layerRate;
    const Vec3r offset = (emitter.speed * (time - releasedAt) * n).cast<Real>();
    for (const Vec3r& p : layer) {
      if (emitter.maxCount > 0 && state.emitted >= emitter.maxCount) break;
      add(p + offset, velocity);
      ++state.emitted;
      ++added;
    }
  }
  return added;
}

std::size_t holdInflow(const Emitter& emitter, double spacing, double time, const EmitterState& state,
                       Particles& particles, double bufferLayers) {
  if (time < emitter.start || time > emitter.end) return 0;
  // After the last particle the nozzle is closed: the jet flows freely.
  if (emitter.maxCount > 0 && state.emitted >= emitter.maxCount) return 0;
  Vec3d e1, e2, n;
  nozzleFrame(emitter, e1, e2, n);
  const Vec3d center = toVec(emitter.center);
  const Vec3r velocity = (emitter.speed * n).cast<Real>();
  const bool rectangle = emitter.shape == "rectangle";
  // The footprint of the layer lattice (emitterLayer), half a spacing wider.
  double halfU = 0, halfV = 0, radius = 0;
  if (rectangle) {
    const int nu = latticeCount(emitter.size[0], spacing);
    const int nv = latticeCount(emitter.size[1], spacing);
    halfU = 0.5 * nu * spacing;
    halfV = 0.5 * nv * spacing;
  } else {
    radius = std::max(emitter.radius, 0.5 * spacing) + 0.5 * spacing;
  }
  const double behind = -spacing, ahead = bufferLayers * spacing;
  // Every step, over all particles: in parallel.
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, particles.size(), 8192), std::size_t(0),
      [&](const tbb::blocked_range<std::size_t>& range, std::size_t held) {
        for (std::size_t i = range.begin(); i != range.end(); ++i) {
          const Vec3d offset = particles.position[i].cast<double>() - center;
          const double d = offset.dot(n);
          if (d < behind || d > ahead) continue;
          const double u = offset.dot(e1), v = offset.dot(e2);
          const bool inside =
              rectangle ? (std::abs(u) <= halfU && std::abs(v) <= halfV) : (u * u + v * v <= radius * radius);
          if (!inside) continue;
          particles.velocity[i] = velocity;
          ++held;
        }
        return held;
      },
      std::plus<std::size_t>());
}

std::size_t flagLeavingParticles(const Boundaries& boundaries, const Particles& particles,
                                 std::vector<char>& flags) {
  flags.assign(particles.size(), 0);
  std::size_t count = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const Vec3r& p = particles.position[i];
    bool leave = false;
    if (boundaries.domain) {
      const Box& d = *boundaries.domain;
      for (int k = 0; k < 3; ++k) leave = leave || p[k] < d.min[k] || p[k] > d.max[k];
    }
    for (const Box& kill : boundaries.kill) {
      bool inside = true;
      for (int k = 0; k < 3; ++k) inside = inside && p[k] >= kill.min[k] && p[k] <= kill.max[k];
      leave = leave || inside;
    }
    if (leave) flags[i] = 1, ++count;
  }
  return count;
}

} // namespace cascade::scene
