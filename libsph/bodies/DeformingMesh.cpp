#include "libsph/bodies/DeformingMesh.h"

#include "libsph/Errors.h"
#include "libsph/bodies/RigidBody.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace cascade {

namespace {

/// Barycentric weights of p (on or near the triangle's plane) in triangle (a, b, c).
std::array<double, 3> barycentric(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d e0 = b - a, e1 = c - a, d = p - a;
  const double d00 = e0.dot(e0), d01 = e0.dot(e1), d11 = e1.dot(e1), d20 = d.dot(e0), d21 = d.dot(e1);
  const double det = d00 * d11 - d01 * d01;
  if (!(std::abs(det) > 0)) return {1.0 / 3, 1.0 / 3, 1.0 / 3};  // degenerate: its centre
  const double v = (d11 * d20 - d01 * d21) / det, w = (d00 * d21 - d01 * d20) / det;
  return {1 - v - w, v, w};
}

/// Six times the signed volume the closed surface bounds (positive: outward oriented).
double signedVolume6(const std::vector<Eigen::Vector3f>& x, const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  double sum = 0;
  for (const auto& t : triangles)
    sum += x[t[0]].cast<double>().dot(x[t[1]].cast<double>().cross(x[t[2]].cast<double>()));
  return sum;
}

} // namespace

const std::vector<Eigen::Vector3f>& MeshSequence::frame(long k) const {
  const long index = std::clamp(k - long(firstFrame), 0L, long(frames.size()) - 1);
  return frames[std::size_t(index)];
}

std::string sequenceFramePath(const std::string& pattern, long k) {
  const std::size_t begin = pattern.rfind('#');
  if (begin == std::string::npos) return pattern;
  std::size_t first = begin;
  while (first > 0 && pattern[first - 1] == '#') --first;
  const std::size_t width = begin - first + 1;
  std::string number = std::to_string(k);
  if (number.size() < width) number.insert(0, width - number.size(), '0');
  return pattern.substr(0, first) + number + pattern.substr(begin + 1);
}

int sequenceFirstFrame(const std::string& pattern) {
  std::error_code error;
  return std::filesystem::is_regular_file(sequenceFramePath(pattern, 0), error) ? 0 : 1;
}

MeshSequence loadMeshSequence(const std::string& pattern, int lastFrame, double fps, const Transform& transform,
                              const std::string& context) {
  MeshSequence sequence;
  sequence.fps = fps;
  std::error_code error;
  sequence.firstFrame = sequenceFirstFrame(pattern);
  std::vector<std::uint32_t> canonical;  // first frame's welding, applied to every frame
  std::vector<std::array<std::uint32_t, 3>> fileTriangles;
  std::size_t fileVertices = 0;
  const int last = std::max(lastFrame, sequence.firstFrame);
  for (int k = sequence.firstFrame; k <= last; ++k) {
    const std::string path = sequenceFramePath(pattern, k);
    if (!std::filesystem::is_regular_file(path, error))
      throw InputError(path + ": " + context + ": frame " + std::to_string(k) +
                       " of the mesh sequence is missing (the bake runs to frame " + std::to_string(lastFrame) + ")");
    const TriangleMesh mesh = readObj(path);
    const std::string where = path + ": " + context + ": ";
    if (k == sequence.firstFrame) {
      fileVertices = mesh.vertices.size();
      fileTriangles = mesh.triangles;
      // Weld coincident vertices (seams of the exporter) and drop the triangles that collapse.
      canonical = firstVertexAtSamePosition(mesh.vertices);
      for (const auto& t : mesh.triangles) {
        const std::array<std::uint32_t, 3> welded{canonical[t[0]], canonical[t[1]], canonical[t[2]]};
        if (welded[0] != welded[1] && welded[1] != welded[2] && welded[0] != welded[2]) sequence.triangles.push_back(welded);
      }
      if (sequence.triangles.empty()) throw InputError(where + "the mesh has no triangles");
      TriangleMesh welded;
      welded.vertices = mesh.vertices;
      welded.triangles = sequence.triangles;
      if (const std::size_t open = countBorderEdges(welded); open > 0)
        throw InputError(where + "the mesh is not closed (" + std::to_string(open) +
                         " open edges): a deforming obstacle must bound a volume in every frame");
    } else if (mesh.vertices.size() != fileVertices || mesh.triangles != fileTriangles) {
      throw InputError(where + "frame " + std::to_string(k) + " has " + std::to_string(mesh.vertices.size()) +
                       " vertices and " + std::to_string(mesh.triangles.size()) + " triangles, frame " +
                       std::to_string(sequence.firstFrame) + " " + std::to_string(fileVertices) + " and " +
                       std::to_string(fileTriangles.size()) +
                       " (or other faces): the frames of a deforming sequence share their triangles");
    }
    // Welded vertices must stay together.
    double size = 0;
    for (const Eigen::Vector3f& x : mesh.vertices) size = std::max(size, double(x.cwiseAbs().maxCoeff()));
    for (std::size_t v = 0; v < fileVertices; ++v)
      if (canonical[v] != v && (mesh.vertices[v] - mesh.vertices[canonical[v]]).norm() > 1e-5 * std::max(size, 1e-3))
        throw InputError(where + "vertices " + std::to_string(canonical[v] + 1) + " and " + std::to_string(v + 1) +
                         " coincide in frame " + std::to_string(sequence.firstFrame) + " but part in frame " +
                         std::to_string(k) + ": the surface tears");
    std::vector<Eigen::Vector3f> placed(fileVertices);
    for (std::size_t v = 0; v < fileVertices; ++v)
      placed[v] = transform.apply(mesh.vertices[v].cast<Real>()).cast<float>();
    sequence.frames.push_back(std::move(placed));
  }
  // Outward orientation from the first frame; no frame may turn inside out.
  if (signedVolume6(sequence.frames.front(), sequence.triangles) < 0)
    for (auto& t : sequence.triangles) std::swap(t[1], t[2]);
  for (std::size_t f = 0; f < sequence.frames.size(); ++f)
    if (!(signedVolume6(sequence.frames[f], sequence.triangles) > 0))
      throw InputError(sequenceFramePath(pattern, long(f) + sequence.firstFrame) + ": " + context +
                       ": the mesh bounds no volume or is turned inside out in this frame");
  return sequence;
}

// --- DeformingMeshBoundary --------------------------------------------------

DeformingMeshBoundary::DeformingMeshBoundary(MeshSequence sequence) : mSequence(std::move(sequence)) {
  if (mSequence.frames.empty() || mSequence.triangles.empty())
    throw InputError("deforming mesh: a sequence needs at least one frame with triangles");
  for (long k = mSequence.firstFrame; k < mSequence.lastFrame(); ++k) {
    const auto &a = mSequence.frame(k), &b = mSequence.frame(k + 1);
    for (std::size_t v = 0; v < a.size(); ++v)
      mMaxSpeed = std::max(mMaxSpeed, (b[v] - a[v]).cast<double>().norm() * mSequence.fps);
  }
  resetTo(0.0);
}

DeformingMeshBoundary::~DeformingMeshBoundary() = default;

void DeformingMeshBoundary::intervalAt(double t, long& k, double& weight) const {
  const double u = t * mSequence.fps;
  weight = 0;
  if (u < double(mSequence.firstFrame)) {
    k = mSequence.firstFrame - 1;  // the first frame holds
  } else if (u >= double(mSequence.lastFrame())) {
    k = mSequence.lastFrame();  // the last frame holds
  } else {
    k = std::min(long(std::floor(u)), long(mSequence.lastFrame()) - 1);
    weight = std::clamp(u - double(k), 0.0, 1.0);
  }
}

std::vector<Eigen::Vector3f> DeformingMeshBoundary::verticesAt(long k, double weight) const {
  const auto &a = mSequence.frame(k), &b = mSequence.frame(k + 1);
  std::vector<Eigen::Vector3f> vertices(a.size());
  for (std::size_t v = 0; v < a.size(); ++v)
    vertices[v] = (a[v].cast<double>() + weight * (b[v] - a[v]).cast<double>()).cast<float>();
  return vertices;
}

void DeformingMeshBoundary::resetTo(double t) {
  mInterval = std::numeric_limits<long>::min();
  mCurrent.reset();
  moveTo(t);
  mPreviousVertices.clear();
  mStepReach = 0;
}

void DeformingMeshBoundary::moveTo(double t) {
  long k = 0;
  double weight = 0;
  intervalAt(t, k, weight);
  mPreviousVertices = mCurrent ? mCurrent->mesh().vertices : std::vector<Eigen::Vector3f>();
  if (k != mInterval) {
    // A new frame interval: the surface's search grids are built on its first frame,
    // large enough for every vertex's move to the next (MeshBoundary's slack).
    mInterval = k;
    const auto &a = mSequence.frame(k), &b = mSequence.frame(k + 1);
    const bool holds = holdsIn(k);
    mVertexVelocity.assign(a.size(), Vec3d::Zero());
    mSpeed = 0;
    double slack = 0;
    for (std::size_t v = 0; v < a.size(); ++v) {
      const Vec3d move = (b[v] - a[v]).cast<double>();
      slack = std::max(slack, move.norm());
      if (holds) continue;
      mVertexVelocity[v] = move * mSequence.fps;
      mSpeed = std::max(mSpeed, mVertexVelocity[v].norm());
    }
    TriangleMesh mesh;
    mesh.triangles = mSequence.triangles;
    mesh.vertices = a;
    mCurrent = MeshBoundary::fromMesh(std::move(mesh), name(), 1.0001 * slack + 1e-9);
  }
  mTime = t;
  mWeight = weight;
  mCurrent->moveVertices(verticesAt(k, weight));
  mStepReach = 0;
  if (!mPreviousVertices.empty()) {
    const auto& now = mCurrent->mesh().vertices;
    for (std::size_t v = 0; v < now.size(); ++v)
      mStepReach = std::max(mStepReach, double((now[v] - mPreviousVertices[v]).norm()));
  }
}

bool DeformingMeshBoundary::holdsIn(long k) const { return k < mSequence.firstFrame || k >= mSequence.lastFrame(); }

const std::vector<SurfacePoint>& DeformingMeshBoundary::contactPoints() const {
  if (mContactInterval != mInterval) {  // made when first asked in an interval: only rigid bodies ask
    TriangleMesh mesh;
    mesh.triangles = mSequence.triangles;
    mesh.vertices = mSequence.frame(mInterval);
    Vec3d lo = Vec3d::Constant(1e300), hi = -lo;
    for (const Eigen::Vector3f& x : mesh.vertices) lo = lo.cwiseMin(x.cast<double>()), hi = hi.cwiseMax(x.cast<double>());
    mContactPoints = sampleTrianglePoints(mesh, Real(contactPointGap((hi - lo).norm())));
    mContactInterval = mInterval;
  }
  return mContactPoints;
}

Boundary::Deformation DeformingMeshBoundary::deformation() const {
  Deformation d;
  d.interval = mInterval;
  d.weight = Real(mWeight);
  d.rate = holdsIn(mInterval) ? Real(0) : Real(mSequence.fps);
  return d;
}

void DeformingMeshBoundary::sampleDeformation(Real maxGap, std::vector<Vec3r>& start, std::vector<Vec3r>& end) const {
  TriangleMesh mesh;
  mesh.vertices = mSequence.frame(mInterval);
  mesh.triangles = mSequence.triangles;
  const std::vector<SurfacePoint> points = sampleTrianglePoints(mesh, maxGap);
  const auto& next = mSequence.frame(mInterval + 1);
  start.clear();
  end.clear();
  start.reserve(points.size());
  end.reserve(points.size());
  for (const SurfacePoint& p : points) {
    start.push_back(p.on(mesh.vertices).cast<Real>());
    end.push_back(p.on(next).cast<Real>());
  }
}

void DeformingMeshBoundary::sampleSurface(Real maxGap, std::vector<Vec3r>& samples) const {
  mCurrent->sampleSurface(maxGap, samples);
}

Vec3d DeformingMeshBoundary::velocityOfPoint(long triangle, const Vec3d& point) const {
  const auto& t = mSequence.triangles[std::size_t(triangle)];
  const auto& x = mCurrent->mesh().vertices;
  const std::array<double, 3> w = barycentric(point, x[t[0]].cast<double>(), x[t[1]].cast<double>(), x[t[2]].cast<double>());
  return w[0] * mVertexVelocity[t[0]] + w[1] * mVertexVelocity[t[1]] + w[2] * mVertexVelocity[t[2]];
}

Vec3r DeformingMeshBoundary::velocityAt(const Vec3r& x) const {
  if (mSpeed == 0) return Vec3r::Zero();
  Vec3r lo, hi;
  mCurrent->bounds(lo, hi);
  const double diagonal = double((hi - lo).norm());
  const Vec3d p = x.cast<double>();
  // The nearest surface point: a small search first (mirror planes and the guard's
  // exits lie on or just off the surface), growing until one is found.
  for (double reach = 1e-3 * std::max(diagonal, 1e-3);; reach *= 8) {
    Vec3d point;
    const long t = mCurrent->closestTriangle(p, reach, point);
    if (t >= 0) return velocityOfPoint(t, point).cast<Real>();
    if (reach > 2 * diagonal + double((x - lo).norm())) return Vec3r::Zero();
  }
}

void DeformingMeshBoundary::mirrorMaps(const Vec3r& x, Real range, std::uint32_t boundaryIndex,
                                       std::vector<MirrorMap>& maps) const {
  const std::size_t first = maps.size();
  mCurrent->mirrorMaps(x, range, boundaryIndex, maps);
  if (mSpeed == 0) return;
  for (std::size_t k = first; k < maps.size(); ++k) {
    const Vec3r wall = Real(0.5) * (x + maps[k].apply(x));  // on the mirror plane: the closest surface point
    maps[k].wallVelocity = velocityAt(wall);
  }
}

bool DeformingMeshBoundary::isInside(const Vec3r& x) const { return mCurrent->isInside(x); }

bool DeformingMeshBoundary::isInsideNear(const Vec3r& x, Real reach) const { return mCurrent->isInsideNear(x, reach); }

bool DeformingMeshBoundary::penetrated(const Vec3r& from, const Vec3r& to, Real clearance, Vec3r& exit,
                                       Vec3r& normal) const {
  // Relative motion: the start is carried with the surface point nearest it over the
  // step (its weights on the triangle now, applied to the vertices' moves), then the
  // move is tested on the surface now.
  Vec3r start = from;
  if (!mPreviousVertices.empty() && mStepReach > 0) {
    const double reach = double((to - from).norm()) + mStepReach + double(clearance);
    Vec3r lo, hi;
    mCurrent->bounds(lo, hi);
    bool near = true;
    for (int a = 0; a < 3; ++a)
      if (double(from[a]) < double(lo[a]) - reach || double(from[a]) > double(hi[a]) + reach) near = false;
    Vec3d point;
    const long t = near ? mCurrent->closestTriangle(from.cast<double>(), reach, point) : -1;
    if (t >= 0) {
      const auto& tri = mSequence.triangles[std::size_t(t)];
      const auto& now = mCurrent->mesh().vertices;
      const std::array<double, 3> w =
          barycentric(point, now[tri[0]].cast<double>(), now[tri[1]].cast<double>(), now[tri[2]].cast<double>());
      Vec3d move = Vec3d::Zero();
      for (int c = 0; c < 3; ++c) move += w[std::size_t(c)] * (now[tri[c]] - mPreviousVertices[tri[c]]).cast<double>();
      start = (from.cast<double>() + move).cast<Real>();
    }
  }
  return mCurrent->penetrated(start, to, clearance, exit, normal);
}

TriangleMesh DeformingMeshBoundary::surfaceMesh() const {
  TriangleMesh mesh = mCurrent->surfaceMesh();
  mesh.groups.assign(1, TriangleMesh::Group{name(), 0, mesh.triangles.size()});
  return mesh;
}

void DeformingMeshBoundary::bounds(Vec3r& lo, Vec3r& hi) const { mCurrent->bounds(lo, hi); }

} // namespace cascade
