#include "libsph/probes/Probes.h"

#include "libsph/Kernels.h"
#include "libsph/NeighborSearch.h"
#include "libsph/solver/Simulation.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <unordered_map>

namespace cascade {

namespace {

/// Points hashed into cubic cells of edge `cell`; visit points within `radius` (<= cell).
class CellHash {
public:
  CellHash(const std::vector<Vec3r>& points, Real cell) : mPoints(points), mInverse(Real(1) / cell) {
    mCells.reserve(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) mCells[key(cellOf(points[i]))].push_back(std::uint32_t(i));
  }

  template <typename F>
  void forEachWithin(const Vec3r& q, Real radius, F&& visit) const {
    const std::array<std::int64_t, 3> c = cellOf(q);
    const Real radius2 = radius * radius;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          auto it = mCells.find(key({c[0] + dx, c[1] + dy, c[2] + dz}));
          if (it == mCells.end()) continue;
          for (std::uint32_t j : it->second)
            if (squaredDistance(q, mPoints[j]) <= radius2) visit(j);
        }
  }

private:
  std::array<std::int64_t, 3> cellOf(const Vec3r& p) const {
    return {std::int64_t(std::floor(p.x() * mInverse)), std::int64_t(std::floor(p.y() * mInverse)),
            std::int64_t(std::floor(p.z() * mInverse))};
  }
  static std::uint64_t key(const std::array<std::int64_t, 3>& c) {
    return (std::uint64_t(c[0]) & 0x1fffff) | ((std::uint64_t(c[1]) & 0x1fffff) << 21) |
           ((std::uint64_t(c[2]) & 0x1fffff) << 42);
  }
  const std::vector<Vec3r>& mPoints;
  Real mInverse;
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> mCells;
};

} // namespace

std::vector<char> bulkParticles(const std::vector<Vec3r>& positions, Real radius, int minNeighbors) {
  std::vector<char> bulk(positions.size(), 0);
  if (positions.empty()) return bulk;
  std::vector<std::size_t> valid;
  const CellHash hash(positions, radius);
  tbb::parallel_for(std::size_t(0), positions.size(), [&](std::size_t i) {
    if (!positions[i].allFinite()) return;
    int count = -1;  // the particle itself is within the radius
    hash.forEachWithin(positions[i], radius, [&](std::uint32_t) { ++count; });
    bulk[i] = count >= minNeighbors ? 1 : 0;
  });
  return bulk;
}

double surgeFront(const std::vector<Vec3r>& positions, const Vec3r& direction, Real spacing,
                  int minNeighbors) {
  const Vec3r d = direction.normalized();
  const std::vector<char> bulk = bulkParticles(positions, 2 * spacing, minNeighbors);
  double front = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (bulk[i]) front = std::max(front, double(positions[i].dot(d)));
  if (!std::isfinite(front)) return std::numeric_limits<double>::quiet_NaN();
  return front + 0.5 * double(spacing);
}

double waterHeight(const std::vector<Vec3r>& positions, double x, double y, Real spacing,
                   int minNeighbors) {
  // Only particles in the column matter; find the bulk among those near it.
  std::vector<Vec3r> column;
  const double reach = 3.0 * spacing;
  for (const Vec3r& p : positions)
    if (std::abs(p.x() - x) <= reach && std::abs(p.y() - y) <= reach) column.push_back(p);
  const std::vector<char> bulk = bulkParticles(column, 2 * spacing, minNeighbors);
  double top = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < column.size(); ++i) {
    const double dx = column[i].x() - x, dy = column[i].y() - y;
    if (bulk[i] && dx * dx + dy * dy <= double(spacing) * spacing) top = std::max(top, double(column[i].z()));
  }
  if (!std::isfinite(top)) return std::numeric_limits<double>::quiet_NaN();
  return top + 0.5 * double(spacing);
}

namespace {
/// Calls visit(j, w_j) for the listed particles within h of the point (all if the list
/// is null), w_j = V_j W_poly6; returns the sum of the weights.
template <typename F>
double forEachWeighted(const Particles& particles, const Vec3r& point, Real supportRadius, const std::uint32_t* begin,
                       const std::uint32_t* end, F&& visit) {
  const KernelPoly6 poly6(supportRadius);
  const Real h2 = supportRadius * supportRadius;
  double weights = 0;
  const std::size_t count = begin ? std::size_t(end - begin) : particles.size();
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t j = begin ? begin[k] : k;
    const Real r2 = squaredDistance(point, particles.position[j]);
    if (r2 >= h2) continue;
    const double w = double(particles.mass) / double(particles.density[j]) * double(poly6.valueFromSquared(r2));
    visit(j, w);
    weights += w;
  }
  return weights;
}
} // namespace

double pressureAt(const Particles& particles, const Vec3r& point, Real supportRadius, const Vec3r& gravity) {
  return pressureAt(particles, point, supportRadius, gravity, nullptr, nullptr);
}

double pressureAt(const Particles& particles, const Vec3r& point, Real supportRadius, const Vec3r& gravity,
                  const std::uint32_t* begin, const std::uint32_t* end) {
  double weighted = 0;
  const double weights = forEachWeighted(particles, point, supportRadius, begin, end, [&](std::size_t j, double w) {
    // p at the point = p_j + rho_j g . (point - x_j)  (hydrostatic extrapolation,
    // Adami et al. 2012 eq. 27: deeper points get more pressure)
    const double p = double(particles.pressure[j]) +
                     double(particles.density[j]) * double(gravity.dot(point - particles.position[j]));
    weighted += w * p;
  });
  return weights > 0 ? weighted / weights : 0.0;
}

double pressureOverDisc(const Particles& particles, const Vec3r& center, const Vec3r& normal, Real radius,
                        Real supportRadius, const Vec3r& gravity, const std::uint32_t* begin, const std::uint32_t* end) {
  if (!(radius > 0)) return pressureAt(particles, center, supportRadius, gravity, begin, end);
  // Two unit vectors spanning the face.
  const Vec3r n = normal.normalized();
  const Vec3r helper = std::abs(n.x()) < Real(0.9) ? Vec3r::UnitX() : Vec3r::UnitY();
  const Vec3r u = n.cross(helper).normalized(), v = n.cross(u);
  double sum = 0.25 * pressureAt(particles, center, supportRadius, gravity, begin, end);
  const Real ring = radius * Real(std::sqrt(2.0 / 3.0));
  for (int k = 0; k < 6; ++k) {
    const double angle = k * M_PI / 3.0;
    const Vec3r point = center + ring * (Real(std::cos(angle)) * u + Real(std::sin(angle)) * v);
    sum += 0.125 * pressureAt(particles, point, supportRadius, gravity, begin, end);
  }
  return sum;
}

bool velocityAt(const Particles& particles, const Vec3r& point, Real supportRadius, const std::uint32_t* begin,
                const std::uint32_t* end, Vec3d& velocity) {
  Vec3d weighted = Vec3d::Zero();
  const double weights = forEachWeighted(particles, point, supportRadius, begin, end, [&](std::size_t j, double w) {
    weighted += w * particles.velocity[j].cast<double>();
  });
  if (!(weights > 0)) return false;
  velocity = weighted / weights;
  return true;
}

NeighborLists probeNeighborhoods(const Particles& particles, const std::vector<Vec3r>& points, Real radius) {
  NeighborLists lists;
  if (particles.empty() || points.empty()) {
    lists.offsets.assign(points.size() + 1, 0);
    return lists;
  }
  const std::unique_ptr<NeighborSearch> grid = makeNeighborSearch("grid");
  grid->build(particles.position.data(), particles.size(), radius);
  grid->query(points.data(), points.size(), nullptr, false, lists);
  return lists;
}

Vec3d obstacleForce(const Simulation& simulation, const std::string& obstacle) {
  const long index = simulation.findBoundary(obstacle);
  if (index < 0) throw std::invalid_argument("unknown obstacle '" + obstacle + "'");
  return simulation.obstacleForce(std::size_t(index));
}

} // namespace cascade
