#include "surfacing/LevelSetMesher.h"

#include "surfacing/DualContourMesher.h"
#include "surfacing/MeshChecks.h"
#include "surfacing/MeshCleanup.h"
#include "surfacing/detail/Profile.h"

#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>
#include <tbb/parallel_reduce.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <unordered_map>
#include <utility>
#include <vector>

namespace cascade::surfacing {

namespace {

/// How far (cells) the triangles that a repair changes reach from the repaired
/// cell: its leaf's blocks re-merge (up to 8 cells) and their triangles join the
/// next leaves' vertices (8 more), with a leaf's margin.
constexpr int kChangeReach = 24;

/// OpenVDB's adaptive mesh of `grid`, its quads split along the shorter diagonal;
/// voxels of `mask` (may be null) are not merged.
TriangleMesh volumeToTriangles(const openvdb::FloatGrid& grid, double adaptivity,
                               const openvdb::BoolTree::Ptr& mask) {
  openvdb::tools::VolumeToMesh mesher(0.0, adaptivity, true);
  if (mask) mesher.setAdaptivityMask(mask);
  mesher(grid);
  TriangleMesh mesh;
  mesh.vertices.resize(mesher.pointListSize());
  const openvdb::Vec3s* points = mesher.pointList().get();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.vertices.size(), 8192), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      mesh.vertices[i] = Eigen::Vector3f(points[i].x(), points[i].y(), points[i].z());
  });
  for (std::size_t n = 0; n < mesher.polygonPoolListSize(); ++n) {
    const openvdb::tools::PolygonPool& pool = mesher.polygonPoolList()[n];
    for (std::size_t i = 0; i < pool.numTriangles(); ++i) {
      const openvdb::Vec3I& t = pool.triangle(i);
      mesh.triangles.push_back({t[0], t[1], t[2]});
    }
    for (std::size_t i = 0; i < pool.numQuads(); ++i) {
      const openvdb::Vec4I& q = pool.quad(i);
      const Eigen::Vector3f& a = mesh.vertices[q[0]];
      const Eigen::Vector3f& b = mesh.vertices[q[1]];
      const Eigen::Vector3f& c = mesh.vertices[q[2]];
      const Eigen::Vector3f& d = mesh.vertices[q[3]];
      if ((a - c).squaredNorm() <= (b - d).squaredNorm()) {  // shorter diagonal
        mesh.triangles.push_back({q[0], q[1], q[2]});
        mesh.triangles.push_back({q[0], q[2], q[3]});
      } else {
        mesh.triangles.push_back({q[0], q[1], q[3]});
        mesh.triangles.push_back({q[1], q[2], q[3]});
      }
    }
  }
  return mesh;
}

/// Triangles of `mesh` whose centroid or a corner lies further than `tolerance`
/// (m) from the zero crossing of the level set (|phi| there, trilinear).
std::vector<std::size_t> trianglesOffTheSurface(const TriangleMesh& mesh, const openvdb::FloatGrid& grid,
                                                float tolerance) {
  tbb::enumerable_thread_specific<std::vector<std::size_t>> found;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh.triangles.size(), 4096), [&](const auto& range) {
    // The sampler keeps a reference to the accessor: it must outlive the sampler.
    const openvdb::FloatGrid::ConstAccessor access = grid.getConstAccessor();
    openvdb::tools::GridSampler<openvdb::FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> phi(access,
                                                                                                 grid.transform());
    auto off = [&](const Eigen::Vector3f& p) {
      return std::abs(phi.wsSample(openvdb::Vec3d(p.x(), p.y(), p.z()))) > tolerance;
    };
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const auto& c = mesh.triangles[t];
      const Eigen::Vector3f& a = mesh.vertices[c[0]];
      const Eigen::Vector3f& b = mesh.vertices[c[1]];
      const Eigen::Vector3f& d = mesh.vertices[c[2]];
      if (off((a + b + d) / 3.0f) || off(a) || off(b) || off(d)) found.local().push_back(t);
    }
  });
  std::vector<std::size_t> result;
  for (const auto& local : found) result.insert(result.end(), local.begin(), local.end());
  return result;
}

/// The cell (index space, floored) of a vertex: a dual contouring vertex lies in the
/// cell of the edge crossings it was made from.
openvdb::Coord vertexCell(const Eigen::Vector3f& p, const openvdb::math::Transform& transform) {
  return openvdb::Coord::floor(transform.worldToIndex(openvdb::Vec3d(p.x(), p.y(), p.z())));
}

/// vertexCell of every vertex.
std::vector<openvdb::Coord> vertexCells(const TriangleMesh& mesh, const openvdb::math::Transform& transform) {
  std::vector<openvdb::Coord> cell(mesh.vertices.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cell.size(), 8192), [&](const auto& range) {
    for (std::size_t v = range.begin(); v != range.end(); ++v) cell[v] = vertexCell(mesh.vertices[v], transform);
  });
  return cell;
}

openvdb::CoordBBox cellBox(const std::array<std::uint32_t, 3>& t, const std::vector<openvdb::Coord>& cell) {
  openvdb::CoordBBox box(cell[t[0]], cell[t[0]]);
  box.expand(cell[t[1]]);
  box.expand(cell[t[2]]);
  return box;
}

/// The triangles t of `mesh` with keep[t], as a mesh of their own: vertices
/// renumbered (shared ones stay shared); `original` gets each triangle's index,
/// `sourceVertex` (if given) each vertex's.
TriangleMesh subMesh(const TriangleMesh& mesh, const std::vector<char>& keep, std::vector<std::size_t>& original,
                     std::vector<std::uint32_t>* sourceVertex = nullptr) {
  TriangleMesh part;
  original.clear();
  if (sourceVertex) sourceVertex->clear();
  std::vector<std::uint32_t> index(mesh.vertices.size(), std::uint32_t(-1));
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (!keep[t]) continue;
    std::array<std::uint32_t, 3> corners{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& i = index[mesh.triangles[t][k]];
      if (i == std::uint32_t(-1)) {
        i = std::uint32_t(part.vertices.size());
        part.vertices.push_back(mesh.vertices[mesh.triangles[t][k]]);
        if (sourceVertex) sourceVertex->push_back(mesh.triangles[t][k]);
      }
      corners[k] = i;
    }
    part.triangles.push_back(corners);
    original.push_back(t);
  }
  return part;
}

/// Boxes (index space) of the mesh's components no more than `extent` cells across
/// along every axis: droplets and spray, which merging would reshape (and which the
/// clean-up's volume threshold would then treat unlike the uniform mesh's).
std::vector<openvdb::CoordBBox> smallComponents(const TriangleMesh& mesh, const std::vector<openvdb::Coord>& cell,
                                                int extent) {
  const std::vector<std::uint32_t> root = componentRoots(mesh);
  std::vector<openvdb::CoordBBox> box(mesh.vertices.size());  // empty boxes, but at roots
  for (std::size_t v = 0; v < root.size(); ++v) box[root[v]].expand(cell[v]);
  std::vector<openvdb::CoordBBox> small;
  for (std::size_t v = 0; v < root.size(); ++v) {
    if (root[v] != v || box[v].empty()) continue;
    const openvdb::Coord cells = box[v].dim();
    if (cells.x() <= extent && cells.y() <= extent && cells.z() <= extent) small.push_back(box[v]);
  }
  return small;
}

/// The part of an adaptive mesh that merged cells made, and what lies around it: the
/// triangles that span more than two cells along an axis (a uniform mesh's triangle
/// joins the cells around one edge: at most two along each axis), and every triangle
/// whose cell box touches one of theirs. Its vertices are renumbered (shared ones stay
/// shared); `original` gets each triangle's index in `mesh`.
TriangleMesh mergedPart(const TriangleMesh& mesh, const std::vector<openvdb::Coord>& cell,
                        std::vector<std::size_t>& original) {
  const std::size_t n = mesh.triangles.size();
  std::vector<char> merged(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 8192), [&](const auto& range) {
    for (std::size_t t = range.begin(); t != range.end(); ++t) {
      const openvdb::Coord cells = cellBox(mesh.triangles[t], cell).dim();  // cells spanned, per axis
      merged[t] = cells.x() > 2 || cells.y() > 2 || cells.z() > 2;
    }
  });
  // Merged triangles by bucket of 8^3 cells (a leaf), then every triangle against them.
  const auto bucketOf = [](const openvdb::Coord& c) { return openvdb::Coord(c.x() >> 3, c.y() >> 3, c.z() >> 3); };
  std::unordered_map<openvdb::Coord, std::vector<openvdb::CoordBBox>> buckets;  // merged triangles' cell boxes
  for (std::size_t t = 0; t < n; ++t) {
    if (!merged[t]) continue;
    const openvdb::CoordBBox box = cellBox(mesh.triangles[t], cell);
    const openvdb::CoordBBox range(bucketOf(box.min()), bucketOf(box.max()));
    for (auto b = range.beginXYZ(); b; ++b) buckets[*b].push_back(box);
  }
  std::vector<char> near = merged;
  if (!buckets.empty())
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const auto& range) {
      for (std::size_t t = range.begin(); t != range.end(); ++t) {
        if (near[t]) continue;
        const openvdb::CoordBBox box = cellBox(mesh.triangles[t], cell);
        const openvdb::CoordBBox around(bucketOf(box.min()), bucketOf(box.max()));
        for (auto b = around.beginXYZ(); b && !near[t]; ++b) {
          const auto found = buckets.find(*b);
          if (found == buckets.end()) continue;
          for (const openvdb::CoordBBox& mergedBox : found->second)
            if (box.hasOverlap(mergedBox)) {
              near[t] = 1;
              break;
            }
        }
      }
    });
  return subMesh(mesh, near, original);
}

/// The triangles of `mesh` with a corner in a cell on in `region`, as a mesh of
/// their own (shared vertices stay shared); `original` gets each one's index in
/// `mesh`, `partCell` each vertex's cell (from `cell`).
TriangleMesh trianglesNear(const TriangleMesh& mesh, const std::vector<openvdb::Coord>& cell,
                           const openvdb::BoolTree& region, std::vector<std::size_t>& original,
                           std::vector<openvdb::Coord>& partCell) {
  const std::size_t n = mesh.triangles.size();
  std::vector<char> near(n, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 8192), [&](const auto& range) {
    openvdb::tree::ValueAccessor<const openvdb::BoolTree> inside(region);
    for (std::size_t t = range.begin(); t != range.end(); ++t)
      for (std::uint32_t corner : mesh.triangles[t])
        if (inside.isValueOn(cell[corner])) {
          near[t] = 1;
          break;
        }
  });
  std::vector<std::uint32_t> sourceVertex;
  TriangleMesh part = subMesh(mesh, near, original, &sourceVertex);
  partCell.resize(sourceVertex.size());
  for (std::size_t v = 0; v < sourceVertex.size(); ++v) partCell[v] = cell[sourceVertex[v]];
  return part;
}

/// The cells of the uniform mesh's vertices that the adaptive mesh misses: a vertex
/// with no adaptive vertex in its cell within `tolerance` (its cell was merged) that
/// lies further than `tolerance` from the merged part. Merging around a thin spike or sheet can span it
/// with a tent of triangles that stays on the surface at its corners and centroids
/// but leaves the spike out.
std::vector<openvdb::Coord> uncoveredCells(const TriangleMesh& uniform, const std::vector<openvdb::Coord>& uniformCell,
                                           const std::vector<std::size_t>* uniformVertices,
                                           const TriangleMesh& adaptive, const std::vector<openvdb::Coord>& adaptiveCell,
                                           const TriangleMesh& merged, double tolerance) {
  std::unordered_map<openvdb::Coord, std::uint32_t> vertexOfCell;  // an unmerged cell's one vertex
  vertexOfCell.reserve(adaptive.vertices.size());
  for (std::size_t v = 0; v < adaptive.vertices.size(); ++v) vertexOfCell.emplace(adaptiveCell[v], std::uint32_t(v));
  std::vector<Eigen::Vector3f> missing;
  std::vector<openvdb::Coord> missingCell;
  const std::size_t count = uniformVertices ? uniformVertices->size() : uniform.vertices.size();
  for (std::size_t i = 0; i < count; ++i) {
    const std::size_t v = uniformVertices ? (*uniformVertices)[i] : i;
    const auto found = vertexOfCell.find(uniformCell[v]);
    if (found != vertexOfCell.end() &&
        (adaptive.vertices[found->second] - uniform.vertices[v]).squaredNorm() <= float(tolerance * tolerance))
      continue;  // a vertex of the adaptive mesh is that close
    missing.push_back(uniform.vertices[v]);
    missingCell.push_back(uniformCell[v]);
  }
  std::vector<openvdb::Coord> cells;
  for (std::size_t i : pointsFartherThan(missing, merged, tolerance)) cells.push_back(missingCell[i]);
  return cells;
}

/// Whether every two of the unit vectors `n[0..count)` satisfy 1 - n_i . n_j <= limit
/// (VolumeToMesh's isMergeable), without the pairwise scan where a cone decides: all
/// within an angle theta of their mean keeps every pair within 2 theta; the vector
/// furthest from the mean is the likeliest to fail against another.
bool withinLimit(const openvdb::Vec3s* n, std::size_t count, float limit) {
  openvdb::Vec3s mean(0.0f);
  for (std::size_t i = 0; i < count; ++i) mean += n[i];
  mean.normalize();
  float nearest = 1;  // cos theta of the furthest
  std::size_t furthest = 0;
  for (std::size_t i = 0; i < count; ++i)
    if (const float c = n[i].dot(mean); c < nearest) nearest = c, furthest = i;
  if (nearest > 0 && 2 * (1 - nearest * nearest) <= limit) return true;  // 1 - cos 2 theta
  for (std::size_t j = 0; j < count; ++j)
    if (1.0f - n[furthest].dot(n[j]) > limit) return false;
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t j = i + 1; j < count; ++j)
      if (1.0f - n[i].dot(n[j]) > limit) return false;
  return true;
}

/// Morton order of a leaf's 8^3 cells by VDB offset (x << 6) | (y << 3) | z: the cells
/// of each sub-block of 2, 4 (and 8) cells are then contiguous, a cell's sub-block at
/// level k (2^k cells across) being its code >> 3k.
const std::array<std::uint16_t, 512>& mortonCodes() {
  static const std::array<std::uint16_t, 512> table = [] {
    std::array<std::uint16_t, 512> code{};
    for (int offset = 0; offset < 512; ++offset)
      for (int b = 0; b < 3; ++b)
        code[std::size_t(offset)] |= std::uint16_t(((offset >> (6 + b) & 1) << (3 * b + 2)) |
                                                   ((offset >> (3 + b) & 1) << (3 * b + 1)) | ((offset >> b & 1) << (3 * b)));
    return code;
  }();
  return table;
}

/// The vertices OpenVDB's VolumeToMesh would make at an adaptivity, for one block of
/// 8^3 cells (aligned with the leaves) of a uniform mesh: its merging test
/// (MergeVoxelRegions) replayed on the cells holding the uniform mesh's vertices. Blocks
/// of 2, then 4, then 8 cells merge into one vertex when every sub-block merged and the
/// level set's normals at their cells (central differences at the cells' lower corners,
/// as VolumeToMesh takes them) are all within 1 - n_i . n_j <= adaptivity of each
/// other; a cell with two or more vertices (an ambiguous case) never merges.
class BlockMergeEstimate {
public:
  using FloatLeaf = openvdb::FloatTree::LeafNodeType;
  static constexpr int D = FloatLeaf::DIM;
  static_assert(D == 8, "blocks of 8^3 cells, offsets (x << 6) | (y << 3) | z");

  explicit BlockMergeEstimate(float adaptivity) : mLimit(adaptivity) {}

  static openvdb::Coord blockOf(const openvdb::Coord& c) {
    return openvdb::Coord(c.x() & ~(D - 1), c.y() & ~(D - 1), c.z() & ~(D - 1));
  }

  /// Vertices of the block at `origin` once merged, from the cells of its `count`
  /// uniform vertices.
  std::size_t vertices(const openvdb::Coord& origin, const openvdb::Coord* cell, std::size_t count,
                       openvdb::FloatGrid::ConstAccessor& phi) {
    const std::array<std::uint16_t, 512>& morton = mortonCodes();
    for (std::size_t v = 0; v < count; ++v) {
      const int offset = ((cell[v].x() - origin.x()) << 6) | ((cell[v].y() - origin.y()) << 3) | (cell[v].z() - origin.z());
      const std::uint16_t code = morton[std::size_t(offset)];
      if (mCount[code]++ == 0) {
        mOffset[code] = std::uint16_t(offset);
        mPresent[code >> 6] |= std::uint64_t(1) << (code & 63);
      }
    }
    mCode.clear();
    for (std::size_t word = 0; word < mPresent.size(); ++word) {
      for (std::uint64_t bits = mPresent[word]; bits; bits &= bits - 1)
        mCode.push_back(std::uint16_t(word * 64 + std::size_t(__builtin_ctzll(bits))));
      mPresent[word] = 0;
    }
    placeNormals(origin, phi);
    const std::size_t result = merge(0, mCode.size(), 3).second;
    for (std::uint16_t code : mCode) mCount[code] = 0;
    return result;
  }

private:
  /// Normals at the cells in use, read from the block's leaf and its six face
  /// neighbours (the accessor where one is missing).
  void placeNormals(const openvdb::Coord& origin, openvdb::FloatGrid::ConstAccessor& phi) {
    std::array<const FloatLeaf*, 7> leaf{};  // this one, then -x, +x, -y, +y, -z, +z
    leaf[0] = phi.probeConstLeaf(origin);
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side) {
        openvdb::Coord next = origin;
        next[axis] += side ? D : -D;
        leaf[std::size_t(1 + 2 * axis + side)] = phi.probeConstLeaf(next);
      }
    mNormal.resize(mCode.size());
    for (std::size_t i = 0; i < mCode.size(); ++i) {
      const int offset = mOffset[mCode[i]];
      const int local[3] = {offset >> 6, offset >> 3 & 7, offset & 7};
      openvdb::Vec3s n;
      for (int axis = 0; axis < 3; ++axis) {
        const int stride = 1 << (3 * (2 - axis));
        float ends[2];
        for (int side = 0; side < 2; ++side) {
          const FloatLeaf* owner = leaf[0];
          int at = offset + (side ? stride : -stride);
          if (const int next = local[axis] + (side ? 1 : -1); next < 0 || next >= D) {  // the next leaf's far layer
            owner = leaf[std::size_t(1 + 2 * axis + side)];
            at = side ? offset - (D - 1) * stride : offset + (D - 1) * stride;
          }
          if (owner) {
            ends[side] = owner->getValue(openvdb::Index(at));
          } else {
            openvdb::Coord ijk = origin.offsetBy(local[0], local[1], local[2]);
            ijk[axis] += side ? 1 : -1;
            ends[side] = phi.getValue(ijk);
          }
        }
        n[axis] = ends[1] - ends[0];
      }
      n.normalize();
      mNormal[i] = n;
    }
  }

  /// The sub-block of `level` (2^level cells across) over codes [begin, end):
  /// {merged, vertices}, from its eight parts' results.
  std::pair<bool, std::size_t> merge(std::size_t begin, std::size_t end, int level) const {
    if (level == 0) {
      const std::uint8_t n = mCount[mCode[begin]];
      return {n <= 1, n};
    }
    bool merged = true;
    std::size_t vertices = 0;
    for (std::size_t part = begin; part < end;) {
      const int key = mCode[part] >> (3 * (level - 1));
      std::size_t next = part + 1;
      while (next < end && mCode[next] >> (3 * (level - 1)) == key) ++next;
      const auto [partMerged, partVertices] = merge(part, next, level - 1);
      merged = merged && partMerged;
      vertices += partVertices;
      part = next;
    }
    if (!merged || vertices <= 1) return {merged, vertices};
    if (withinLimit(mNormal.data() + begin, end - begin, mLimit)) return {true, 1};
    return {false, vertices};
  }

  float mLimit;
  std::array<std::uint8_t, 512> mCount{};    // vertices per cell, by Morton code
  std::array<std::uint16_t, 512> mOffset{};  // VDB offset, by Morton code
  std::array<std::uint64_t, 8> mPresent{};   // Morton codes in use
  std::vector<std::uint16_t> mCode;          // in use, ascending
  std::vector<openvdb::Vec3s> mNormal;       // of each code in use
};

} // namespace

double estimatedAdaptiveCut(const TriangleMesh& uniform, const openvdb::FloatGrid& grid, double adaptivity) {
  constexpr std::size_t kChunk = 1024, kExact = std::size_t(1) << 18;
  const std::size_t n = uniform.vertices.size();
  if (n == 0) return 1;
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  const std::size_t stride = std::max<std::size_t>(1, n / kExact);
  const openvdb::math::Transform& transform = grid.transform();
  const auto cellOf = [&](std::size_t v) { return vertexCell(uniform.vertices[v], transform); };
  using Counts = std::pair<std::size_t, std::size_t>;  // uniform vertices, estimated vertices
  const Counts counts = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, (chunks + stride - 1) / stride, 1), Counts(0, 0),
      [&](const auto& range, Counts sum) {
        openvdb::FloatGrid::ConstAccessor phi = grid.getConstAccessor();
        BlockMergeEstimate estimate{float(adaptivity)};
        std::vector<openvdb::Coord> cell;
        for (std::size_t c = range.begin(); c != range.end(); ++c) {
          // The blocks that start in this chunk, whole.
          std::size_t begin = c * stride * kChunk;
          const std::size_t chunkEnd = std::min(n, begin + kChunk);
          cell.clear();
          if (begin > 0) {
            openvdb::Coord before = BlockMergeEstimate::blockOf(cellOf(begin - 1));
            while (begin < chunkEnd && BlockMergeEstimate::blockOf(cellOf(begin)) == before) ++begin;
          }
          for (std::size_t v = begin; v < n; ++v) {
            const openvdb::Coord ijk = cellOf(v);
            if (v >= chunkEnd && BlockMergeEstimate::blockOf(ijk) != BlockMergeEstimate::blockOf(cell.back())) break;
            cell.push_back(ijk);
          }
          for (std::size_t run = 0; run < cell.size();) {
            const openvdb::Coord origin = BlockMergeEstimate::blockOf(cell[run]);
            std::size_t next = run + 1;
            while (next < cell.size() && BlockMergeEstimate::blockOf(cell[next]) == origin) ++next;
            sum.first += next - run;
            sum.second += estimate.vertices(origin, cell.data() + run, next - run, phi);
            run = next;
          }
        }
        return sum;
      },
      [](Counts a, Counts b) { return Counts(a.first + b.first, a.second + b.second); });
  return counts.second > 0 ? double(counts.first) / double(counts.second) : 1.0;
}

TriangleMesh levelSetToMesh(const openvdb::FloatGrid& grid, double adaptivity) {
  if (adaptivity <= 0) return dualContourMesh(grid);
  // Components of the uniform mesh small enough to be droplets or spray are kept
  // unmerged (OpenVDB's adaptivity mask) from the start: merging would reshape them,
  // or make one vanish, and the clean-up's volume threshold would then keep a
  // different set of specks than the uniform mesh's. Merged cells that stray from the
  // surface or make the mesh cross itself are meshed again with the voxels around them
  // kept unmerged too, until none is left; after kMaxRepairs rounds, the uniform mesh.
  constexpr int kMaxRepairs = 4;
  const double dx = grid.voxelSize()[0];
  const int reach = openvdb::FloatTree::LeafNodeType::DIM / 2;  // a merged cell's reach: half a leaf
  auto mask = std::make_shared<openvdb::BoolTree>(false);
  detail::ProfileClock profile;
  TriangleMesh uniform = dualContourMesh(grid);
  profile.lap("adaptive: uniform mesh");
  // Merging bounded by the normals alone would not cut this mesh enough: the uniform
  // mesh, before any adaptive meshing is paid for (a splash of droplets and sheets).
  const double cut = estimatedAdaptiveCut(uniform, grid, adaptivity);
  profile.lap("adaptive: estimate");
  if (std::getenv("CASCADE_SURFACE_PROFILE"))
    std::fprintf(stderr, "  profile adaptive estimate: at most %.2fx fewer vertices than %zu uniform\n", cut,
                 uniform.vertices.size());
  if (cut < kMinimumAdaptiveCut) return uniform;
  const std::vector<openvdb::Coord> uniformCell = vertexCells(uniform, grid.transform());
  std::size_t droplets = 0;
  for (openvdb::CoordBBox box : smallComponents(uniform, uniformCell, 2 * reach)) {
    box.expand(1);  // the voxels at the corners of its cells, and one more
    mask->sparseFill(box, true, true);
    ++droplets;
  }
  profile.lap("adaptive: droplets");
  // After a repair, the cells whose triangles can differ from the last round's
  // (within kChangeReach cells of a repaired cell), and those of the triangles the
  // changed ones can cross or cover (twice as far).
  openvdb::BoolTree::Ptr changed, context;
  for (int round = 0; round <= kMaxRepairs; ++round) {
    TriangleMesh mesh = volumeToTriangles(grid, adaptivity, droplets > 0 || round > 0 ? mask : nullptr);
    profile.lap("adaptive: mesh");
    // Repairs only add triangles: a mesh that merging does not cut enough is not worth
    // its checks (a splash of droplets and thin sheets); the uniform mesh then.
    if (double(mesh.triangles.size()) * kMinimumAdaptiveCut > double(uniform.triangles.size())) {
      if (std::getenv("CASCADE_SURFACE_PROFILE"))
        std::fprintf(stderr, "  profile adaptive round %d: %zu triangles against %zu uniform: the uniform mesh\n", round,
                     mesh.triangles.size(), uniform.triangles.size());
      return uniform;
    }
    const std::vector<openvdb::Coord> cell = vertexCells(mesh, grid.transform());
    // After a repair only the mesh near the repaired cells differs from the last
    // round's, whose other triangles passed: the checks look there alone.
    std::vector<std::size_t> inPart;  // the checked triangles' indices in `mesh`
    std::vector<openvdb::Coord> partCell;
    const TriangleMesh part = round == 0 ? TriangleMesh() : trianglesNear(mesh, cell, *context, inPart, partCell);
    const TriangleMesh& checked = round == 0 ? mesh : part;
    const std::vector<openvdb::Coord>& checkedCell = round == 0 ? cell : partCell;
    std::vector<std::size_t> bad = trianglesOffTheSurface(checked, grid, float(kAdaptiveTolerance * dx));
    const std::size_t off = bad.size();
    std::vector<std::size_t> original;
    const TriangleMesh merged = mergedPart(checked, checkedCell, original);
    // Uniform vertices to cover: all of them, or those in the changed region.
    std::vector<std::size_t> uniformVertices;
    if (round > 0)
      for (std::size_t v = 0; v < uniform.vertices.size(); ++v)
        if (changed->isValueOn(uniformCell[v])) uniformVertices.push_back(v);
    // CGAL's self-intersection search runs on one thread: the coverage search (on all
    // of them) beside it.
    std::vector<std::size_t> crossing;
    std::vector<openvdb::Coord> uncovered;
    tbb::parallel_invoke([&] { crossing = selfIntersectingTriangles(merged); },
                         [&] {
                           uncovered = uncoveredCells(uniform, uniformCell, round == 0 ? nullptr : &uniformVertices,
                                                      mesh, cell, merged, kAdaptiveTolerance * dx);
                         });
    for (std::size_t& t : crossing) t = original[t];
    bad.insert(bad.end(), crossing.begin(), crossing.end());
    if (round > 0)
      for (std::size_t& t : bad) t = inPart[t];
    profile.lap("adaptive: off the surface, crossing, uncovered");
    // Unmerge the regions that made a bad triangle: the cells of its corners (a merged
    // region's vertex lies in its block; a masked voxel keeps its block of 2 and the
    // blocks of 4 and 8 around it unmerged), one voxel around them. A triangle whose
    // corners are all masked is the uniform mesh's own: it stays.
    std::vector<openvdb::Coord> repair;
    for (std::size_t t : bad)
      for (std::uint32_t corner : mesh.triangles[t])
        if (!mask->isValueOn(cell[corner])) repair.push_back(cell[corner]);
    for (const openvdb::Coord& c : uncovered)
      if (!mask->isValueOn(c)) repair.push_back(c);
    if (std::getenv("CASCADE_SURFACE_PROFILE"))
      std::fprintf(stderr,
                   "  profile adaptive round %d: %zu triangles (%zu merged or near), %zu off, %zu crossing, %zu uncovered, "
                   "%zu droplets, %zu cells to repair\n",
                   round, mesh.triangles.size(), merged.triangles.size(), off, crossing.size(), uncovered.size(),
                   droplets, repair.size());
    if (repair.empty()) return mesh;
    if (round == kMaxRepairs) break;
    changed = std::make_shared<openvdb::BoolTree>(false);
    context = std::make_shared<openvdb::BoolTree>(false);
    for (const openvdb::Coord& c : repair) {
      mask->sparseFill(openvdb::CoordBBox(c.offsetBy(-1), c.offsetBy(1)), true, true);
      changed->sparseFill(openvdb::CoordBBox(c.offsetBy(-kChangeReach), c.offsetBy(kChangeReach)), true, true);
      context->sparseFill(openvdb::CoordBBox(c.offsetBy(-2 * kChangeReach), c.offsetBy(2 * kChangeReach)), true, true);
    }
  }
  return uniform;
}

} // namespace cascade::surfacing
