#include "render/MeshPrimitives.h"

#include <cmath>
#include <map>
#include <utility>

namespace cascade::render {

TriangleMesh makeIcosphere(const Eigen::Vector3f& center, float radius, int subdivisions) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  std::vector<Eigen::Vector3f> unit = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0},
                                       {0, -1, t}, {0, 1, t}, {0, -1, -t}, {0, 1, -t},
                                       {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : unit) v.normalize();
  std::vector<std::array<std::uint32_t, 3>> faces = {
      {0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},  {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      auto found = midpoints.find(key);
      if (found != midpoints.end()) return found->second;
      unit.push_back((unit[a] + unit[b]).normalized());
      const auto index = std::uint32_t(unit.size() - 1);
      midpoints.emplace(key, index);
      return index;
    };
    std::vector<std::array<std::uint32_t, 3>> finer;
    finer.reserve(faces.size() * 4);
    for (const auto& f : faces) {
      const std::uint32_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.push_back({f[0], ab, ca});
      finer.push_back({f[1], bc, ab});
      finer.push_back({f[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    faces = std::move(finer);
  }
  TriangleMesh mesh;
  mesh.vertices.reserve(unit.size());
  for (const auto& v : unit) mesh.vertices.push_back(center + radius * v);
  mesh.normals = unit;
  mesh.triangles = std::move(faces);
  return mesh;
}

TriangleMesh makeLatLongSphere(const Eigen::Vector3f& center, float radius, int rings, int segments,
                               float waviness) {
  const float pi = 3.14159265358979f;
  TriangleMesh mesh;
  auto wavyRadius = [&](float theta, float phi) {
    return radius * (1.0f + waviness * (0.6f * std::sin(3 * theta) * std::cos(4 * phi) +
                                        0.3f * std::sin(7 * theta + 1.0f) * std::sin(5 * phi) +
                                        0.15f * std::cos(13 * theta) * std::sin(11 * phi + 0.5f)));
  };
  auto point = [&](float theta, float phi) {
    const Eigen::Vector3f direction(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    return Eigen::Vector3f(center + wavyRadius(theta, phi) * direction);
  };
  // Poles, then (rings - 1) rows of `segments` vertices.
  mesh.vertices.push_back(point(0, 0));
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) mesh.vertices.push_back(point(pi * r / rings, 2 * pi * s / segments));
  mesh.vertices.push_back(point(pi, 0));
  const std::uint32_t south = std::uint32_t(mesh.vertices.size() - 1);
  auto at = [&](int r, int s) { return std::uint32_t(1 + (r - 1) * segments + (s % segments)); };
  for (int s = 0; s < segments; ++s) mesh.triangles.push_back({0, at(1, s), at(1, s + 1)});
  for (int r = 1; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      mesh.triangles.push_back({at(r, s), at(r + 1, s), at(r + 1, s + 1)});
      mesh.triangles.push_back({at(r, s), at(r + 1, s + 1), at(r, s + 1)});
    }
  for (int s = 0; s < segments; ++s) mesh.triangles.push_back({south, at(rings - 1, s + 1), at(rings - 1, s)});
  // Area-weighted normals.
  mesh.normals.assign(mesh.vertices.size(), Eigen::Vector3f::Zero());
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3f area = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
    for (int k = 0; k < 3; ++k) mesh.normals[t[k]] += area;
  }
  for (auto& n : mesh.normals) n.normalize();
  return mesh;
}

TriangleMesh makeBox(const Eigen::Vector3f& min, const Eigen::Vector3f& max, const std::string& name) {
  TriangleMesh mesh;
  // Each face: outward normal axis and sign; four corners counter-clockwise from outside.
  for (int axis = 0; axis < 3; ++axis)
    for (int sign = -1; sign <= 1; sign += 2) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[axis] = float(sign);
      const std::uint32_t base = std::uint32_t(mesh.vertices.size());
      const float du[4] = {0, 1, 1, 0}, dv[4] = {0, 0, 1, 1};
      for (int k = 0; k < 4; ++k) {
        Eigen::Vector3f p;
        p[axis] = sign > 0 ? max[axis] : min[axis];
        p[u] = du[k] > 0 ? max[u] : min[u];
        p[v] = dv[k] > 0 ? max[v] : min[v];
        mesh.vertices.push_back(p);
        mesh.normals.push_back(normal);
      }
      // (u, v) corners are counter-clockwise seen from +axis.
      if (sign > 0) {
        mesh.triangles.push_back({base, base + 1, base + 2});
        mesh.triangles.push_back({base, base + 2, base + 3});
      } else {
        mesh.triangles.push_back({base, base + 2, base + 1});
        mesh.triangles.push_back({base, base + 3, base + 2});
      }
    }
  mesh.groups.push_back({name, 0, mesh.triangles.size()});
  return mesh;
}

void appendMesh(TriangleMesh& target, const TriangleMesh& source) {
  const std::uint32_t offset = std::uint32_t(target.vertices.size());
  const std::size_t triangleOffset = target.triangles.size();
  const bool normals = target.normals.size() == target.vertices.size() &&
                       source.normals.size() == source.vertices.size();
  target.vertices.insert(target.vertices.end(), source.vertices.begin(), source.vertices.end());
  if (normals) target.normals.insert(target.normals.end(), source.normals.begin(), source.normals.end());
  else target.normals.clear();
  for (const auto& t : source.triangles) target.triangles.push_back({t[0] + offset, t[1] + offset, t[2] + offset});
  for (const auto& g : source.groups)
    target.groups.push_back({g.name, g.begin + triangleOffset, g.end + triangleOffset});
}

} // namespace cascade::render
