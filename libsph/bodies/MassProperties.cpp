/// @file MassProperties.cpp
/// @brief Volume, centre of mass and inertia of a closed triangle mesh by the
///        divergence theorem (Mirtich 1996; Eberly, "Polyhedral mass
///        properties (revisited)"), with a closedness check first.
#include "libsph/bodies/MassProperties.h"

#include "libsph/Errors.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <tuple>
#include <vector>

namespace cascade {

namespace {

/// Eberly's subexpressions for one coordinate w of a triangle's corners: f1, f2, f3 are the sums of all
/// monomials of degree 1, 2, 3 in (w0, w1, w2); g_i = f2 + w_i (f1 + w_i).
struct Subexpressions {
  double f1, f2, f3, g0, g1, g2;
  Subexpressions(double w0, double w1, double w2) {
    const double temp0 = w0 + w1;
    const double temp1 = w0 * w0;
    const double temp2 = temp1 + w1 * temp0;
    f1 = temp0 + w2;
    f2 = temp2 + w2 * f1;
    f3 = w0 * temp1 + w1 * temp2 + w2 * f2;
    g0 = f2 + w0 * (f1 + w0);
    g1 = f2 + w1 * (f1 + w1);
    g2 = f2 + w2 * (f1 + w2);
  }
};

/// The number of undirected edges whose uses in one direction do not cancel those in the other, after
/// vertices at exactly equal positions are merged. Zero exactly when the triangles form a closed,
/// consistently oriented surface (a 2-cycle), which is when the divergence-theorem integrals are the
/// integrals over the enclosed solid whatever the origin.
std::size_t countUnmatchedEdges(const TriangleMesh& mesh) {
  const auto& v = mesh.vertices;
  std::vector<std::uint32_t> order(v.size());
  std::iota(order.begin(), order.end(), 0u);
  const auto less = [&](std::uint32_t a, std::uint32_t b) {
    return std::make_tuple(v[a].x(), v[a].y(), v[a].z()) < std::make_tuple(v[b].x(), v[b].y(), v[b].z());
  };
  std::sort(order.begin(), order.end(), less);
  std::vector<std::uint32_t> canonical(v.size());
  for (std::size_t i = 0; i < order.size(); ++i)
    canonical[order[i]] = (i > 0 && !less(order[i - 1], order[i])) ? canonical[order[i - 1]] : order[i];

  struct Edge {
    std::uint32_t low, high;
    int direction;  ///< +1 traversed low -> high, -1 high -> low
  };
  std::vector<Edge> edges;
  edges.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = canonical[t[k]], b = canonical[t[(k + 1) % 3]];
      if (a == b) continue;  // degenerate edge: no contribution
      edges.push_back(a < b ? Edge{a, b, +1} : Edge{b, a, -1});
    }
  }
  std::sort(edges.begin(), edges.end(),
            [](const Edge& x, const Edge& y) { return std::tie(x.low, x.high) < std::tie(y.low, y.high); });
  std::size_t unmatched = 0;
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    int sum = 0;
    for (; j < edges.size() && edges[j].low == edges[i].low && edges[j].high == edges[i].high; ++j)
      sum += edges[j].direction;
    if (sum != 0) ++unmatched;
    i = j;
  }
  return unmatched;
}

} // namespace

MassProperties massPropertiesOfMesh(const TriangleMesh& mesh, double density, const std::string& context) {
  if (mesh.triangles.empty()) throw InputError(context + ": mesh has no triangles");
  if (!(std::isfinite(density) && density > 0))
    throw InputError(context + ": density must be positive and finite (got " + std::to_string(density) + ")");
  const std::size_t vertexCount = mesh.vertices.size();
  for (const auto& t : mesh.triangles)
    for (std::uint32_t i : t)
      if (i >= vertexCount)
        throw InputError(context + ": triangle vertex index " + std::to_string(i) + " out of range (" +
                         std::to_string(vertexCount) + " vertices)");

  // Reference point: the mean of the vertices (the integrals are about it, for accuracy far from the
  // origin). Only vertices that triangles use count, so stray unused vertices do not shift it.
  std::vector<char> used(vertexCount, 0);
  for (const auto& t : mesh.triangles)
    for (std::uint32_t i : t) used[i] = 1;
  Vec3d reference = Vec3d::Zero();
  Vec3d lowest = Vec3d::Constant(INFINITY), highest = Vec3d::Constant(-INFINITY);
  std::size_t usedCount = 0;
  for (std::size_t i = 0; i < vertexCount; ++i) {
    if (!used[i]) continue;
    const Vec3d p = mesh.vertices[i].cast<double>();
    if (!p.allFinite()) throw InputError(context + ": mesh vertex " + std::to_string(i) + " is not finite");
    reference += p;
    lowest = lowest.cwiseMin(p);
    highest = highest.cwiseMax(p);
    ++usedCount;
  }
  reference /= double(usedCount);

  const std::size_t unmatched = countUnmatchedEdges(mesh);
  if (unmatched != 0)
    throw InputError(context + ": mesh is not closed (" + std::to_string(unmatched) +
                     " edges without a matching opposite edge: holes or inconsistently oriented triangles); "
                     "a body must bound a volume");

  // Integrals of 1, x, y, z, x^2, y^2, z^2, xy, yz, zx over the solid, in coordinates relative to
  // `reference`, each times 6, 24, 24, 24, 60, 60, 60, 120, 120, 120 (Eberly's formulation).
  std::array<double, 10> integral{};
  for (const auto& t : mesh.triangles) {
    const Vec3d p0 = mesh.vertices[t[0]].cast<double>() - reference;
    const Vec3d p1 = mesh.vertices[t[1]].cast<double>() - reference;
    const Vec3d p2 = mesh.vertices[t[2]].cast<double>() - reference;
    const Vec3d d = (p1 - p0).cross(p2 - p0);  // twice the area times the outward normal
    const Subexpressions x(p0.x(), p1.x(), p2.x());
    const Subexpressions y(p0.y(), p1.y(), p2.y());
    const Subexpressions z(p0.z(), p1.z(), p2.z());
    integral[0] += d.x() * x.f1;
    integral[1] += d.x() * x.f2;
    integral[2] += d.y() * y.f2;
    integral[3] += d.z() * z.f2;
    integral[4] += d.x() * x.f3;
    integral[5] += d.y() * y.f3;
    integral[6] += d.z() * z.f3;
    integral[7] += d.x() * (p0.y() * x.g0 + p1.y() * x.g1 + p2.y() * x.g2);
    integral[8] += d.y() * (p0.z() * y.g0 + p1.z() * y.g1 + p2.z() * y.g2);
    integral[9] += d.z() * (p0.x() * z.g0 + p1.x() * z.g1 + p2.x() * z.g2);
  }
  const double volume = integral[0] / 6.0;
  const Vec3d first = Vec3d(integral[1], integral[2], integral[3]) / 24.0;  // int x, y, z dV
  const Vec3d second = Vec3d(integral[4], integral[5], integral[6]) / 60.0;  // int x^2, y^2, z^2 dV
  const Vec3d mixed = Vec3d(integral[7], integral[8], integral[9]) / 120.0;  // int xy, yz, zx dV

  // "Not positive" up to rounding: a flat (zero-volume) closed surface sums to a few ulps of extent^3.
  const double extent = (highest - lowest).norm();
  if (!(volume > 1e-12 * extent * extent * extent))
    throw InputError(context + ": mesh encloses no positive volume (signed volume " + std::to_string(volume) +
                     " m^3); is it inward-facing or flat?");

  MassProperties result;
  result.volume = volume;
  result.mass = density * volume;
  const Vec3d c = first / volume;  // centre of mass relative to `reference`
  result.centerOfMass = reference + c;
  // Inertia about the reference point, then moved to the centre of mass (parallel axis theorem),
  // per unit density; second moments about the centre: S = int r r^T dV - V c c^T.
  Mat3d s;
  s(0, 0) = second.x();
  s(1, 1) = second.y();
  s(2, 2) = second.z();
  s(0, 1) = s(1, 0) = mixed.x();  // xy
  s(1, 2) = s(2, 1) = mixed.y();  // yz
  s(0, 2) = s(2, 0) = mixed.z();  // zx
  s -= volume * c * c.transpose();
  // I = tr(S) Id - S.
  result.inertia = density * (s.trace() * Mat3d::Identity() - s);
  return result;
}

MassProperties withMass(const MassProperties& properties, double mass) {
  if (!(properties.mass > 0))
    throw std::invalid_argument("withMass: the properties have no positive mass to scale");
  if (!(std::isfinite(mass) && mass > 0))
    throw std::invalid_argument("withMass: mass must be positive and finite (got " + std::to_string(mass) + ")");
  MassProperties result = properties;
  const double factor = mass / properties.mass;
  result.mass = mass;
  result.inertia = properties.inertia * factor;
  return result;
}

} // namespace cascade
