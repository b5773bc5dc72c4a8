#include "surfacing/DualContourMesher.h"

#include "surfacing/detail/Profile.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#if defined(__SSE2__)
#include <emmintrin.h>
#include <xmmintrin.h>
#endif
#include <cassert>
#include <memory>
#include <type_traits>
#include <vector>

namespace cascade::surfacing {

namespace {

constexpr int kOtherAxes[3][2] = {{1, 2}, {0, 2}, {0, 1}};

int cornerIndex(const int (&c)[3]) { return c[0] | c[1] << 1 | c[2] << 2; }

/// Corners of edge e (see CellEdgeGroups): c0 has coordinate 0 along the edge's axis.
void edgeCorners(int e, int& c0, int& c1) {
  const int axis = e >> 2;
  int c[3];
  c[axis] = 0;
  c[kOtherAxes[axis][0]] = e & 1;
  c[kOtherAxes[axis][1]] = e >> 1 & 1;
  c0 = cornerIndex(c);
  c[axis] = 1;
  c1 = cornerIndex(c);
}

/// Coordinate along `axis` of edge e, which must not run along `axis`.
int edgeCoordinate(int e, int axis) {
  const int along = e >> 2;
  return kOtherAxes[along][0] == axis ? (e & 1) : (e >> 1 & 1);
}

/// Groups of `config` from its face segments; the face `flippedFace` (or none if
/// -1) cuts off its inside corners instead of its outside ones.
CellEdgeGroups deriveGroups(int config, int flippedFace) {
  auto inside = [config](int corner) { return (config >> corner & 1) != 0; };
  CellEdgeGroups groups;
  for (int e = 0; e < 12; ++e) {
    int c0, c1;
    edgeCorners(e, c0, c1);
    if (inside(c0) != inside(c1)) groups.edges |= std::uint16_t(1u << e);
  }
  int parent[12];
  for (int e = 0; e < 12; ++e) parent[e] = e;
  auto find = [&parent](int e) {
    while (parent[e] != e) e = parent[e] = parent[parent[e]];
    return e;
  };
  auto join = [&](int a, int b) { parent[find(a)] = find(b); };
  for (int face = 0; face < 6; ++face) {
    const int axis = face >> 1, side = face & 1;
    int faceEdges[4], changing[4], nFace = 0, nChanging = 0;
    for (int e = 0; e < 12; ++e)
      if (e >> 2 != axis && edgeCoordinate(e, axis) == side) {
        faceEdges[nFace++] = e;
        if (groups.edges >> e & 1) changing[nChanging++] = e;
      }
    if (nChanging == 2) {
      join(changing[0], changing[1]);
    } else if (nChanging == 4) {  // ambiguous face: cut off the corners of one kind
      const bool cutInside = face == flippedFace;
      for (int corner = 0; corner < 8; ++corner) {
        if ((corner >> axis & 1) != side || inside(corner) != cutInside) continue;
        int incident[2], n = 0;
        for (int e : faceEdges) {
          int c0, c1;
          edgeCorners(e, c0, c1);
          if (c0 == corner || c1 == corner) incident[n++] = e;
        }
        join(incident[0], incident[1]);
      }
    }
  }
  int label[12];
  std::fill(std::begin(label), std::end(label), -1);
  for (int e = 0; e < 12; ++e) {
    if (!(groups.edges >> e & 1)) continue;
    int& root = label[find(e)];
    if (root < 0) root = groups.groupCount++;
    groups.group[std::size_t(e)] = std::uint8_t(root);
  }
  // A face whose segments lie in one polygon (all four edges in one group).
  for (int face = 0; face < 6 && flippedFace < 0; ++face) {
    const int axis = face >> 1, side = face & 1;
    int n = 0, firstGroup = -1;
    bool oneGroup = true;
    for (int e = 0; e < 12; ++e)
      if (e >> 2 != axis && edgeCoordinate(e, axis) == side && (groups.edges >> e & 1)) {
        if (firstGroup < 0) firstGroup = groups.group[std::size_t(e)];
        oneGroup = oneGroup && groups.group[std::size_t(e)] == firstGroup;
        ++n;
      }
    if (n == 4 && oneGroup && groups.flipFace < 0) groups.flipFace = std::int8_t(face);
  }
  return groups;
}

std::array<CellEdgeGroups, 512> buildTable() {
  std::array<CellEdgeGroups, 512> table;
  for (int config = 0; config < 256; ++config) {
    table[std::size_t(config)] = deriveGroups(config, -1);
    const int face = table[std::size_t(config)].flipFace;
    table[std::size_t(config) + 256] = face < 0 ? table[std::size_t(config)] : deriveGroups(config, face);
    table[std::size_t(config) + 256].flipFace = std::int8_t(face);
  }
  return table;
}

using FloatTree = openvdb::FloatTree;
using FloatLeaf = FloatTree::LeafNodeType;
using Accessor = openvdb::tree::ValueAccessor<const FloatTree>;
using openvdb::Coord;
static_assert(FloatLeaf::DIM == 8, "blocks are 8^3 cells, offsets (x << 6) | (y << 3) | z");

/// The voxels a block's cells read: the block's own leaf (or tile) and the
/// leaves (or tiles) on its +x/+y/+z sides, neighbour o at offset
/// 8 (o & 1, o >> 1 & 1, o >> 2 & 1).
struct BlockVoxels {
  const float* data[8];
  float tile[8];

  BlockVoxels(const Accessor& accessor, const Coord& origin) {
    for (int o = 0; o < 8; ++o) {
      const Coord at = origin.offsetBy(8 * (o & 1), 8 * (o >> 1 & 1), 8 * (o >> 2 & 1));
      const FloatLeaf* leaf = accessor.probeConstLeaf(at);
      data[o] = leaf ? leaf->buffer().data() : nullptr;
      tile[o] = leaf ? 0.0f : accessor.getValue(at);
    }
  }
  /// Value at block-local (x, y, z), each in 0..8.
  float value(int x, int y, int z) const {
    const int o = (x >> 3) | (y >> 3) << 1 | (z >> 3) << 2;
    return data[o] ? data[o][((x & 7) << 6) | ((y & 7) << 3) | (z & 7)] : tile[o];
  }
  /// Inside bits (phi < 0) of the 8 voxels z = 0..7 at (x & 7, y & 7) of neighbour o.
  unsigned insideRow(int o, int x, int y) const {
    if (!data[o]) return tile[o] < 0.0f ? 0xFFu : 0u;
    const float* v = data[o] + ((x & 7) << 6 | (y & 7) << 3);
#if defined(__SSE2__)
    const __m128 zero = _mm_setzero_ps();
    return unsigned(_mm_movemask_ps(_mm_cmplt_ps(_mm_loadu_ps(v), zero)) |
                    _mm_movemask_ps(_mm_cmplt_ps(_mm_loadu_ps(v + 4), zero)) << 4);
#else
    unsigned bits = 0;
    for (int z = 0; z < 8; ++z) bits |= unsigned(v[z] < 0.0f) << z;
    return bits;
#endif
  }
  /// All corner values of the block's cells: corners[x][y][z], each 0..8.
  void gather(float (&corners)[9][9][9]) const {
    auto line = [](const float* from, float tile, float* to, int n) {  // n values, or the tile
      if (from) std::copy(from, from + n, to);
      else std::fill(to, to + n, tile);
    };
    auto at = [this](int o, int offset) { return data[o] ? data[o] + offset : nullptr; };
    for (int x = 0; x < 8; ++x) {
      for (int y = 0; y < 8; ++y) {
        line(at(0, x << 6 | y << 3), tile[0], corners[x][y], 8);
        corners[x][y][8] = data[4] ? data[4][x << 6 | y << 3] : tile[4];
      }
      line(at(2, x << 6), tile[2], corners[x][8], 8);
      corners[x][8][8] = data[6] ? data[6][x << 6] : tile[6];
    }
    for (int y = 0; y < 8; ++y) {
      line(at(1, y << 3), tile[1], corners[8][y], 8);
      corners[8][y][8] = data[5] ? data[5][y << 3] : tile[5];
    }
    line(at(3, 0), tile[3], corners[8][8], 8);
    corners[8][8][8] = data[7] ? data[7][0] : tile[7];
  }
  /// Inside bits of the corner row (x, y), x and y in 0..8: bit z for z = 0..8.
  unsigned cornerRow(int x, int y) const {
    const int o = (x >> 3) | (y >> 3) << 1;
    return insideRow(o, x, y) | unsigned(value(x, y, 8) < 0.0f) << 8;
  }
};

/// Marching-cubes case of the cell at ijk read through the accessor (cells across a block's side).
unsigned configAt(const Accessor& accessor, const Coord& ijk) {
  unsigned config = 0;
  for (int n = 0; n < 8; ++n)
    if (accessor.getValue(ijk.offsetBy(n & 1, n >> 1 & 1, n >> 2 & 1)) < 0.0f) config |= 1u << n;
  return config;
}

/// Case of cell (x, y, z) from the inside bits of the corner rows (bit z of rows[x][y]).
inline unsigned configFromRows(const std::uint16_t (&rows)[9][9], int x, int y, int z) {
  const unsigned r00 = rows[x][y] >> z & 3u, r10 = rows[x + 1][y] >> z & 3u;
  const unsigned r01 = rows[x][y + 1] >> z & 3u, r11 = rows[x + 1][y + 1] >> z & 3u;
  // corner n = cx | cy << 1 | cz << 2; bit 0 of a row pair is cz = 0, bit 1 is cz = 1
  return (r00 & 1u) | (r10 & 1u) << 1 | (r01 & 1u) << 2 | (r11 & 1u) << 3 | (r00 >> 1) << 4 | (r10 >> 1) << 5 |
         (r01 >> 1) << 6 | (r11 >> 1) << 7;
}

/// Bits set in a word (portable; the build does not assume a popcnt instruction).
inline std::size_t popcount(std::uint64_t word) {
  word -= (word >> 1) & 0x5555555555555555ull;
  word = (word & 0x3333333333333333ull) + ((word >> 2) & 0x3333333333333333ull);
  word = (word + (word >> 4)) & 0x0F0F0F0F0F0F0F0Full;
  return std::size_t((word * 0x0101010101010101ull) >> 56);
}

/// Offset of corner n of a cell in a [9][9][9] array of corner values.
constexpr int kCornerOffset[8] = {0, 81, 9, 90, 1, 82, 10, 91};

/// Per table entry and group: the sum of the group's edges' start corners (x, y, z, 0) and 1 / edge count.
struct GroupGeometry {
  float baseSum[4][4] = {};
  float inverseCount[4] = {};
};

#if defined(__SSE2__)
/// Lane i all ones when bit i is set.
const __m128 kLaneMask[16] = {
#define CASCADE_LANES(m) \
  _mm_castsi128_ps(_mm_setr_epi32(-((m) & 1), -((m) >> 1 & 1), -((m) >> 2 & 1), -((m) >> 3 & 1)))
    CASCADE_LANES(0),  CASCADE_LANES(1),  CASCADE_LANES(2),  CASCADE_LANES(3),  CASCADE_LANES(4),  CASCADE_LANES(5),
    CASCADE_LANES(6),  CASCADE_LANES(7),  CASCADE_LANES(8),  CASCADE_LANES(9),  CASCADE_LANES(10), CASCADE_LANES(11),
    CASCADE_LANES(12), CASCADE_LANES(13), CASCADE_LANES(14), CASCADE_LANES(15),
#undef CASCADE_LANES
};
#endif

struct CellEntry {
  std::uint32_t firstVertex;  ///< in the mesh
  std::uint32_t groups;       ///< group of edge e in bits 2e, 2e + 1
};

/// One 8^3 block of cells (a leaf, or a missing leaf on a leaf's -x/-y/-z side).
struct Block {
  Coord origin;
  std::array<std::int32_t, 8> neighbor{};  ///< block at origin - 8 (b & 1, b >> 1 & 1, b >> 2 & 1), -1 if none
  bool allNeighbors = false;
  std::uint16_t rows[9][9];                ///< inside bits of the corners: bit z of rows[x][y], 0..8 each
  std::array<std::uint64_t, 8> mixed{};    ///< cells with a sign change, word x, bit (y << 3) | z
  std::array<std::uint16_t, 8> rank{};     ///< mixed cells in the words before
  std::uint32_t cellCount = 0, vertexCount = 0, quadCount = 0;
};

/// Cells around an edge along each axis, as offsets subtracted from the edge's start,
/// counter-clockwise seen from the +axis side.
constexpr int kQuadCells[3][4][3] = {
    {{0, 1, 1}, {0, 0, 1}, {0, 0, 0}, {0, 1, 0}},
    {{1, 0, 1}, {1, 0, 0}, {0, 0, 0}, {0, 0, 1}},
    {{1, 1, 0}, {0, 1, 0}, {0, 0, 0}, {1, 0, 0}},
};

/// Visits the edges starting in a block (start local 0..7) with a sign change:
/// visit(std::integral_constant<int, axis>, start cell index, inside at the start).
template <class Visit>
void forEachSignChange(const std::uint16_t (&rows)[9][9], const Visit& visit) {
  auto along = [&visit](auto axis, unsigned bits, int start, unsigned row) {
    for (; bits; bits &= bits - 1) {
      const int z = __builtin_ctz(bits);
      visit(axis, start | z, (row >> z & 1u) != 0);
    }
  };
  for (int x = 0; x < 8; ++x)
    for (int y = 0; y < 8; ++y) {
      const unsigned row = rows[x][y];
      const int start = x << 6 | y << 3;
      along(std::integral_constant<int, 0>(), (row ^ rows[x + 1][y]) & 0xFFu, start, row);
      along(std::integral_constant<int, 1>(), (row ^ rows[x][y + 1]) & 0xFFu, start, row);
      along(std::integral_constant<int, 2>(), (row ^ row >> 1) & 0xFFu, start, row);
    }
}

class Mesher {
public:
  explicit Mesher(const openvdb::FloatGrid& grid)
      : mTree(grid.tree()), mTransform(grid.transform()), mTable(cellEdgeGroupTable()) {
    if (mTransform.isLinear()) mAffine = mTransform.baseMap()->getAffineMap();
    for (int e = 0; e < 12; ++e) edgeCorners(e, mEdgeCorner0[e], mEdgeCorner1[e]);
    for (std::size_t config = 0; config < 512; ++config) {
      const CellEdgeGroups& groups = mTable[config];
      GroupGeometry& geometry = mGroupGeometry[config];
      int samples[4] = {};
      for (int e = 0; e < 12; ++e) {
        if (!(groups.edges >> e & 1)) continue;
        const int g = groups.group[std::size_t(e)];
        for (int a = 0; a < 3; ++a) geometry.baseSum[g][a] += float(mEdgeCorner0[e] >> a & 1);
        ++samples[g];
      }
      for (int g = 0; g < groups.groupCount; ++g) geometry.inverseCount[g] = 1.0f / float(samples[g]);
      mPackedGroups[config] = 0;
      for (int e = 0; e < 12; ++e) mPackedGroups[config] |= std::uint32_t(groups.group[std::size_t(e)]) << (2 * e);
    }
  }

  TriangleMesh run() {
    detail::ProfileClock profile;
    collectBlocks();
    profile.lap("mesh: blocks");
    auto forBlocks = [this](std::size_t grain, const auto& body) {
      tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mBlocks.size(), grain), [&](const auto& range) {
        Accessor accessor(mTree);
        for (std::size_t b = range.begin(); b != range.end(); ++b) body(accessor, b);
      });
    };
    forBlocks(16, [this](const Accessor& accessor, std::size_t b) { countBlock(accessor, mBlocks[b]); });
    profile.lap("mesh: count");
    mCellBase.assign(mBlocks.size() + 1, 0);
    mVertexBase.assign(mBlocks.size() + 1, 0);
    mQuadBase.assign(mBlocks.size() + 1, 0);
    for (std::size_t b = 0; b < mBlocks.size(); ++b) {
      mCellBase[b + 1] = mCellBase[b] + mBlocks[b].cellCount;
      mVertexBase[b + 1] = mVertexBase[b] + mBlocks[b].vertexCount;
      mQuadBase[b + 1] = mQuadBase[b] + mBlocks[b].quadCount;
    }
    TriangleMesh mesh;
    mesh.vertices.resize(mVertexBase.back());
    mesh.triangles.resize(2 * mQuadBase.back());
    mCells.reset(new CellEntry[mCellBase.back()]);  // every entry written in pass 2 (no zero fill)
    profile.lap("mesh: allocate");
    forBlocks(16, [&](const Accessor& accessor, std::size_t b) { placeVertices(accessor, b, mesh.vertices); });
    profile.lap("mesh: vertices");
    forBlocks(16, [&](const Accessor&, std::size_t b) { writeTriangles(b, mesh); });
    profile.lap("mesh: triangles");
    return mesh;
  }

private:
  /// Every leaf and every missing leaf at -8 (0/1, 0/1, 0/1) from one, sorted by origin
  /// (x major), with their -x/-y/-z neighbours' indices.
  void collectBlocks() {
    std::vector<const FloatLeaf*> leaves;
    mTree.getNodes(leaves);
    if (leaves.empty()) return;
    Coord low = leaves[0]->origin(), high = low;
    for (const FloatLeaf* leaf : leaves) {
      low.minComponent(leaf->origin());
      high.maxComponent(leaf->origin());
    }
    low.offset(-16);  // blocks reach 8 below the leaves, their neighbours' keys 16
    constexpr int kBits = 21;  // per axis, in leaf units: origins as one sortable integer
    const Coord span = high - low;
    if (std::max({span.x(), span.y(), span.z()}) / 8 < (1 << kBits)) {
      // Grouped by 16^3 leaves (the tree's lower internal nodes), then x major:
      // neighbouring blocks lie close in memory. Any block at -8 (0/1, 0/1, 0/1) sorts before.
      constexpr int kNode = kBits - 4;
      auto key = [low](const Coord& c) {
        const std::uint64_t x = std::uint64_t((c.x() - low.x()) / 8), y = std::uint64_t((c.y() - low.y()) / 8),
                            z = std::uint64_t((c.z() - low.z()) / 8);
        return (x >> 4) << (12 + 2 * kNode) | (y >> 4) << (12 + kNode) | (z >> 4) << 12 | (x & 15) << 8 |
               (y & 15) << 4 | (z & 15);
      };
      auto origin = [low](std::uint64_t k) {
        constexpr std::uint64_t mask = (std::uint64_t(1) << kNode) - 1;
        const int x = int((k >> (12 + 2 * kNode)) << 4 | (k >> 8 & 15)), y = int((k >> (12 + kNode) & mask) << 4 | (k >> 4 & 15)),
                  z = int((k >> 12 & mask) << 4 | (k & 15));
        return low.offsetBy(8 * x, 8 * y, 8 * z);
      };
      collectBlocksBy(leaves, key, origin, [key, origin](std::uint64_t k, int o) {
        return key(origin(k).offsetBy(-8 * (o & 1), -8 * (o >> 1 & 1), -8 * (o >> 2 & 1)));
      });
    } else {  // a grid over 16 M voxels wide: sort the coordinates themselves
      collectBlocksBy(leaves, [](const Coord& c) { return c; }, [](const Coord& c) { return c; },
                      [](const Coord& c, int o) { return c.offsetBy(-8 * (o & 1), -8 * (o >> 1 & 1), -8 * (o >> 2 & 1)); });
    }
  }

  /// collectBlocks with origins as sortable keys (key(origin), origin(key), the key
  /// of the block at -8 (o & 1, o >> 1 & 1, o >> 2 & 1), which sorts before).
  template <class ToKey, class ToOrigin, class NeighborKey>
  void collectBlocksBy(const std::vector<const FloatLeaf*>& leaves, const ToKey& key, const ToOrigin& origin,
                       const NeighborKey& neighborKey) {
    using Key = std::decay_t<decltype(key(Coord()))>;
    std::vector<Key> keys(8 * leaves.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 256), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const Key k = key(leaves[i]->origin());
        for (int o = 0; o < 8; ++o) keys[8 * i + std::size_t(o)] = neighborKey(k, o);
      }
    });
    tbb::parallel_sort(keys.begin(), keys.end());
    keys.erase(std::unique(keys.begin(), keys.end()), keys.end());
    mBlocks.resize(keys.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keys.size(), 512), [&](const auto& range) {
      for (std::size_t b = range.begin(); b != range.end(); ++b) {
        Block& block = mBlocks[b];
        block.origin = origin(keys[b]);
        block.neighbor[0] = std::int32_t(b);
        block.allNeighbors = true;
        for (int o = 1; o < 8; ++o) {
          const Key target = neighborKey(keys[b], o);
          const auto end = keys.begin() + std::ptrdiff_t(b);  // neighbours sort before
          const auto it = std::lower_bound(keys.begin(), end, target);
          block.neighbor[std::size_t(o)] = it != end && *it == target ? std::int32_t(it - keys.begin()) : -1;
          block.allNeighbors = block.allNeighbors && block.neighbor[std::size_t(o)] >= 0;
        }
      }
    });
  }

  /// Whether the cells around an edge (start cell index, axis) all lie in existing blocks.
  static bool quadComplete(const Block& block, int start, int axis) {
    const int p[3] = {start >> 6, start >> 3 & 7, start & 7};
    if (block.allNeighbors || (p[kOtherAxes[axis][0]] > 0 && p[kOtherAxes[axis][1]] > 0)) return true;
    for (const auto& offset : kQuadCells[axis]) {
      const int b = int(p[0] < offset[0]) | int(p[1] < offset[1]) << 1 | int(p[2] < offset[2]) << 2;
      if (block.neighbor[std::size_t(b)] < 0) return false;
    }
    return true;
  }

  /// Table index of mixed cell (x, y, z): its case, + 256 when it and the cell across
  /// its flip face are both flip cases on that face (correctCellSigns, see header).
  unsigned cellConfig(const Accessor& accessor, const Block& block, int x, int y, int z) const {
    const unsigned config = configFromRows(block.rows, x, y, z);
    const int face = mTable[config].flipFace;
    if (face < 0) return config;
    const int axis = face >> 1;
    int cell[3] = {x, y, z};
    cell[axis] += (face & 1) ? 1 : -1;
    const unsigned neighbor = cell[axis] >= 0 && cell[axis] < 8
                                  ? configFromRows(block.rows, cell[0], cell[1], cell[2])
                                  : configAt(accessor, block.origin.offsetBy(cell[0], cell[1], cell[2]));
    return mTable[neighbor].flipFace == (face ^ 1) ? config + 256 : config;
  }

  /// Pass 1: inside bits, mixed cells, and the block's counts of cells, vertices and quads.
  void countBlock(const Accessor& accessor, Block& block) const {
    const BlockVoxels voxels(accessor, block.origin);
    bool uniform = true;  // all tiles of one sign: nothing to do (most missing blocks)
    for (int o = 0; o < 8; ++o) uniform = uniform && !voxels.data[o] && (voxels.tile[o] < 0.0f) == (voxels.tile[0] < 0.0f);
    if (uniform) return;
    for (int x = 0; x < 9; ++x)
      for (int y = 0; y < 9; ++y) block.rows[x][y] = std::uint16_t(voxels.cornerRow(x, y));
    const auto& rows = block.rows;
    std::uint32_t cells = 0;
    for (int x = 0; x < 8; ++x) {
      std::uint64_t word = 0;
      for (int y = 0; y < 8; ++y) {
        const unsigned all = rows[x][y] & rows[x + 1][y] & rows[x][y + 1] & rows[x + 1][y + 1];
        const unsigned any = rows[x][y] | rows[x + 1][y] | rows[x][y + 1] | rows[x + 1][y + 1];
        word |= std::uint64_t(((any | any >> 1) & ~(all & all >> 1)) & 0xFFu) << (8 * y);
      }
      block.mixed[std::size_t(x)] = word;
      block.rank[std::size_t(x)] = std::uint16_t(cells);
      cells += std::uint32_t(popcount(word));
    }
    block.cellCount = cells;
    if (cells == 0) return;  // an edge with a sign change starting here would make its cell mixed
    for (int x = 0; x < 8; ++x)
      for (std::uint64_t word = block.mixed[std::size_t(x)]; word; word &= word - 1) {
        const int bit = __builtin_ctzll(word);
        block.vertexCount += mTable[cellConfig(accessor, block, x, bit >> 3, bit & 7)].groupCount;
      }
    forEachSignChange(rows, [&](auto axis, int start, bool) { block.quadCount += quadComplete(block, start, axis); });
  }

  openvdb::Vec3s toWorld(const openvdb::Vec3d& index) const {
    return openvdb::Vec3s(mAffine ? mAffine->applyMap(index) : mTransform.indexToWorld(index));
  }

  /// Pass 2: the block's cell entries and its vertices, one per edge group at the
  /// average of the group's zero crossings.
  void placeVertices(const Accessor& accessor, std::size_t b, std::vector<Eigen::Vector3f>& vertices) {
    const Block& block = mBlocks[b];
    if (block.cellCount == 0) return;
    float corners[9][9][9];
    BlockVoxels(accessor, block.origin).gather(corners);
    CellEntry* entry = &mCells[mCellBase[b]];
    std::uint32_t vertex = std::uint32_t(mVertexBase[b]);
    const openvdb::Vec3d origin(block.origin.asVec3d());
    for (int x = 0; x < 8; ++x)
      for (std::uint64_t word = block.mixed[std::size_t(x)]; word; word &= word - 1) {
        const int bit = __builtin_ctzll(word), y = bit >> 3, z = bit & 7;
        const unsigned config = cellConfig(accessor, block, x, y, z);
        const CellEdgeGroups& groups = mTable[config];
        *entry++ = {vertex, mPackedGroups[config]};
        const float* v = &corners[x][y][z];
        const GroupGeometry& geometry = mGroupGeometry[config];
        float t[12];  // zero crossing along each edge, from its corner with coordinate 0 (linear interpolation)
#if defined(__SSE2__)
        // Four edges per axis in one register (edges are numbered axis-major; see kCornerOffset).
        const __m128 low = _mm_setr_ps(v[0], v[81], v[9], v[90]);   // corners 0..3 (z = 0)
        const __m128 high = _mm_setr_ps(v[1], v[82], v[10], v[91]); // corners 4..7 (z = 1)
        const __m128 start[3] = {_mm_shuffle_ps(low, high, _MM_SHUFFLE(2, 0, 2, 0)), _mm_movelh_ps(low, high), low};
        const __m128 end[3] = {_mm_shuffle_ps(low, high, _MM_SHUFFLE(3, 1, 3, 1)), _mm_movehl_ps(high, low), high};
        __m128 along[3];
        for (int a = 0; a < 3; ++a)  // edges without a sign change masked to 0 (their 0/0 never used)
          along[a] = _mm_and_ps(kLaneMask[groups.edges >> (4 * a) & 0xFu],
                                _mm_div_ps(start[a], _mm_sub_ps(start[a], end[a])));
        if (groups.groupCount == 1) {  // the common case: sums per axis by a transpose
          __m128 w = _mm_setzero_ps();
          _MM_TRANSPOSE4_PS(along[0], along[1], along[2], w);
          const __m128 sum = _mm_add_ps(_mm_add_ps(along[0], along[1]), _mm_add_ps(along[2], w));
          const __m128 local = _mm_mul_ps(_mm_add_ps(_mm_loadu_ps(geometry.baseSum[0]), sum), _mm_set1_ps(geometry.inverseCount[0]));
          float p[4];
          _mm_storeu_ps(p, local);
          const openvdb::Vec3s world = toWorld(origin + openvdb::Vec3d(x + p[0], y + p[1], z + p[2]));
          vertices[vertex++] = Eigen::Vector3f(world.x(), world.y(), world.z());
          continue;
        }
        for (int a = 0; a < 3; ++a) _mm_storeu_ps(t + 4 * a, along[a]);
#else
        for (int e = 0; e < 12; ++e) {
          const float v0 = v[kCornerOffset[mEdgeCorner0[e]]], v1 = v[kCornerOffset[mEdgeCorner1[e]]];
          t[e] = (groups.edges >> e & 1) ? v0 / (v0 - v1) : 0.0f;
        }
#endif
        float sum[4][4];
        std::copy(&geometry.baseSum[0][0], &geometry.baseSum[0][0] + 16, &sum[0][0]);
        for (unsigned edges = groups.edges; edges; edges &= edges - 1) {
          const int e = __builtin_ctz(edges);
          sum[groups.group[std::size_t(e)]][e >> 2] += t[e];
        }
        for (int g = 0; g < groups.groupCount; ++g) {
          const float inverse = geometry.inverseCount[g];
          const openvdb::Vec3s p =
              toWorld(origin + openvdb::Vec3d(x + sum[g][0] * inverse, y + sum[g][1] * inverse, z + sum[g][2] * inverse));
          vertices[vertex++] = Eigen::Vector3f(p.x(), p.y(), p.z());
        }
      }
  }

  /// Entry of cell n of block b (which must be mixed).
  const CellEntry& cellEntry(std::size_t b, int n) const {
    const Block& block = mBlocks[b];
    const std::size_t word = std::size_t(n >> 6);
    assert(block.mixed[word] >> (n & 63) & 1);
    return mCells[mCellBase[b] + block.rank[word] + popcount(block.mixed[word] & ((std::uint64_t(1) << (n & 63)) - 1))];
  }

  /// Pass 3: a quad per edge with a sign change, as two triangles split along its
  /// shorter diagonal.
  void writeTriangles(std::size_t b, TriangleMesh& mesh) const {
    const Block& block = mBlocks[b];
    if (block.quadCount == 0) return;
    // The block's own cells by cell index (most quads' cells are in the block).
    std::uint16_t local[512];
    for (int x = 0, k = 0; x < 8; ++x)
      for (std::uint64_t word = block.mixed[std::size_t(x)]; word; word &= word - 1)
        local[x << 6 | __builtin_ctzll(word)] = std::uint16_t(k++);
    const CellEntry* cells = &mCells[mCellBase[b]];
    std::array<std::uint32_t, 3>* triangle = &mesh.triangles[2 * mQuadBase[b]];
    const Eigen::Vector3f* vertices = mesh.vertices.data();
    forEachSignChange(block.rows, [&](auto axisConstant, int start, bool inside) {
      constexpr int axis = decltype(axisConstant)::value;
      if (!quadComplete(block, start, axis)) return;
      const int p[3] = {start >> 6, start >> 3 & 7, start & 7};
      std::uint32_t index[4];
      for (int i = 0; i < 4; ++i) {
        const int* offset = kQuadCells[axis][inside ? i : 3 - i];
        const int c[3] = {p[0] - offset[0], p[1] - offset[1], p[2] - offset[2]};
        const int which = int(c[0] < 0) | int(c[1] < 0) << 1 | int(c[2] < 0) << 2;
        const int n = (c[0] & 7) << 6 | (c[1] & 7) << 3 | (c[2] & 7);
        const CellEntry& entry =
            which == 0 ? cells[local[n]] : cellEntry(std::size_t(block.neighbor[std::size_t(which)]), n);
        const int edge = 4 * axis + offset[kOtherAxes[axis][0]] + 2 * offset[kOtherAxes[axis][1]];
        index[i] = entry.firstVertex + (entry.groups >> (2 * edge) & 3u);
      }
      const Eigen::Vector3f &a = vertices[index[0]], &b = vertices[index[1]], &c = vertices[index[2]], &d = vertices[index[3]];
      if ((a - c).squaredNorm() <= (b - d).squaredNorm()) {  // shorter diagonal
        *triangle++ = {index[0], index[1], index[2]};
        *triangle++ = {index[0], index[2], index[3]};
      } else {
        *triangle++ = {index[0], index[1], index[3]};
        *triangle++ = {index[1], index[2], index[3]};
      }
    });
  }

  const FloatTree& mTree;
  const openvdb::math::Transform& mTransform;
  openvdb::math::AffineMap::Ptr mAffine;
  const std::array<CellEdgeGroups, 512>& mTable;
  int mEdgeCorner0[12], mEdgeCorner1[12];
  std::array<GroupGeometry, 512> mGroupGeometry;
  std::array<std::uint32_t, 512> mPackedGroups;
  std::vector<Block> mBlocks;
  std::vector<std::size_t> mCellBase, mVertexBase, mQuadBase;
  std::unique_ptr<CellEntry[]> mCells;
};

} // namespace

const std::array<CellEdgeGroups, 512>& cellEdgeGroupTable() {
  static const std::array<CellEdgeGroups, 512> table = buildTable();
  return table;
}

TriangleMesh dualContourMesh(const openvdb::FloatGrid& grid) { return Mesher(grid).run(); }

} // namespace cascade::surfacing
