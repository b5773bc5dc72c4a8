// Whitewater frames as OpenVDB point data grids and PLY points.
#include "whitewater/WhitewaterFile.h"

#include "libsph/Errors.h"
#include "libsph/Version.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/VdbFile.h"
#include "libsph/io/VdbPointAttributes.h"
#include "libsph/io/VdbWriter.h"

#include <openvdb/openvdb.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointDataGrid.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <atomic>
#include <cstring>
#include <numeric>
#include <sstream>

namespace cascade::whitewater {

namespace fs = std::filesystem;

namespace {

constexpr const char* kGridName = "whitewater";
constexpr const char* kTimeKey = "cascade_time";
constexpr const char* kNextIdKey = "cascade_next_id";
constexpr const char* kSpacingKey = "cascade_spacing";
constexpr const char* kHashKey = "cascade_input_hash";

openvdb::points::PointDataGrid::Ptr readGrid(const fs::path& path, bool withData) {
  initializeOpenVdb();
  validateVdbFile(path);
  const VdbReadScope reading(path);
  openvdb::io::File file(path.string());
  file.open(!withData);
  openvdb::points::PointDataGrid::Ptr grid;
  for (auto name = file.beginName(); name != file.endName(); ++name) {
    if (name.gridName() != kGridName) continue;
    grid = openvdb::gridPtrCast<openvdb::points::PointDataGrid>(file.readGrid(name.gridName()));
  }
  file.close();
  if (!grid) throw InputError(path.string() + ": no \"whitewater\" point grid in the file (not a whitewater frame)");
  return grid;
}

void readMetadata(const openvdb::GridBase& grid, WhitewaterFrame& frame) {
  if (auto time = grid.getMetadata<openvdb::DoubleMetadata>(kTimeKey)) frame.time = time->value();
  if (auto next = grid.getMetadata<openvdb::Int64Metadata>(kNextIdKey)) frame.nextId = std::uint32_t(next->value());
  if (auto spacing = grid.getMetadata<openvdb::DoubleMetadata>(kSpacingKey)) frame.spacing = spacing->value();
  if (auto hash = grid.getMetadata<openvdb::StringMetadata>(kHashKey)) frame.inputHash = hash->value();
}

} // namespace

std::array<std::size_t, kDiffuseTypeCount> WhitewaterFrame::counts() const {
  std::array<std::size_t, kDiffuseTypeCount> result{};
  for (DiffuseType t : type) ++result[std::size_t(t)];
  return result;
}

namespace {
/// The voxel size of a frame's points: two fluid spacings (P's precision is 2 spacings / 65535).
double voxelSizeOf(const WhitewaterFrame& frame) { return frame.spacing > 0 ? 2.0 * frame.spacing : 0.01; }

/// One coordinate through OpenVDB 10's point conversion and back: the voxel is
/// Coord::round of the index position (world times the inverse voxel size, in
/// double); the offset from the voxel centre is cast to float and stored by
/// FixedPointCodec<false> (PositionRange: (offset + 0.5) x 65535, truncated,
/// clamped to [0, 65535]); reading decodes it and maps the index position back.
float storedCoordinate(float world, double voxelSize, double inverseVoxelSize) {
  const double index = double(world) * inverseVoxelSize;
  const double voxel = std::floor(index + 0.5);
  const float offset = float(index - voxel);
  const float shifted = offset + 0.5f;
  const std::uint16_t code = 0.0f > shifted ? std::uint16_t(0)
                             : 1.0f <= shifted ? std::uint16_t(65535)
                                               : std::uint16_t(shifted * 65535.0f);
  const float decoded = float(code) / 65535.0f - 0.5f;
  return float((double(decoded) + voxel) * voxelSize);
}
} // namespace

void roundPositionsAsStored(WhitewaterFrame& frame) {
  const double voxelSize = voxelSizeOf(frame);
  const double inverse = 1.0 / voxelSize;
  std::vector<Vec3r>& positions = frame.particles.position;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, positions.size(), 16384), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i)
      for (int a = 0; a < 3; ++a) positions[i][a] = storedCoordinate(positions[i][a], voxelSize, inverse);
  });
}

void writeWhitewaterVdb(const fs::path& path, const WhitewaterFrame& frame) {
  initializeOpenVdb();
  namespace points = openvdb::points;
  const DiffuseParticles& p = frame.particles;
  const std::size_t count = p.size();
  if (frame.type.size() != count) throw std::logic_error("writeWhitewaterVdb: one type per particle");
  if (count > 0 && *std::max_element(p.id.begin(), p.id.end()) > std::uint32_t(INT32_MAX))
    throw std::runtime_error("whitewater: more than 2^31 particles born in one run (lower rate_scale)");
  std::vector<openvdb::Vec3R> positions(count);
  std::vector<openvdb::Vec3f> velocity(count);
  std::vector<int32_t> ids(count), types(count);
  std::vector<float> age(p.age.begin(), p.age.end());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 16384), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) {
      positions[i] = openvdb::Vec3R(p.position[i].x(), p.position[i].y(), p.position[i].z());
      velocity[i] = openvdb::Vec3f(p.velocity[i].x(), p.velocity[i].y(), p.velocity[i].z());
      ids[i] = int32_t(p.id[i]);
      types[i] = int32_t(frame.type[i]);
    }
  });
  points::PointAttributeVector<openvdb::Vec3R> positionWrapper(positions);
  // Voxels of two fluid spacings, as the particle caches.
  const double voxelSize = voxelSizeOf(frame);
  const auto transform = openvdb::math::Transform::createLinearTransform(voxelSize);
  const auto indexGrid = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(positionWrapper, *transform);
  auto grid = points::createPointDataGrid<points::FixedPointCodec<false>, points::PointDataGrid>(*indexGrid, positionWrapper,
                                                                                               *transform);
  auto& tree = grid->tree();
  const auto& indexTree = indexGrid->tree();
  points::appendAttribute<openvdb::Vec3f>(tree, "v");
  populatePointAttribute(tree, indexTree, "v", velocity);
  points::appendAttribute<int32_t>(tree, "id");
  populatePointAttribute(tree, indexTree, "id", ids);
  points::appendAttribute<int32_t>(tree, "type");
  populatePointAttribute(tree, indexTree, "type", types);
  points::appendAttribute<float>(tree, "age");
  populatePointAttribute(tree, indexTree, "age", age);

  grid->setName(kGridName);
  grid->insertMeta(kTimeKey, openvdb::DoubleMetadata(frame.time));
  grid->insertMeta(kNextIdKey, openvdb::Int64Metadata(frame.nextId));
  grid->insertMeta(kSpacingKey, openvdb::DoubleMetadata(frame.spacing));
  grid->insertMeta(kHashKey, openvdb::StringMetadata(frame.inputHash));
  grid->insertMeta("cascade_version", openvdb::StringMetadata(cascadeVersion()));
  writeFileAtomically(path, [&](const fs::path& temp) {
    writeVdbFile(temp, openvdb::GridCPtrVec{grid}, openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
  });
}

WhitewaterFrame readWhitewaterVdb(const fs::path& path) {
  namespace points = openvdb::points;
  try {
    const auto grid = readGrid(path, true);
    WhitewaterFrame frame;
    readMetadata(*grid, frame);
    auto leaf = grid->constTree().cbeginLeaf();
    if (!leaf) return frame;
    const auto& descriptor = leaf->attributeSet().descriptor();
    for (const char* name : {"P", "v", "id", "type", "age"})
      if (descriptor.find(name) == points::AttributeSet::INVALID_POS)
        throw InputError(path.string() + ": whitewater points lack the \"" + std::string(name) + "\" attribute");
    const auto& transform = grid->transform();
    // Leaf by leaf in parallel, each into its own slice (the leaves' order).
    std::vector<const points::PointDataTree::LeafNodeType*> leaves;
    std::vector<std::size_t> first{0};
    for (; leaf; ++leaf) {
      leaves.push_back(&*leaf);
      first.push_back(first.back() + std::size_t(leaf->onPointCount()));
    }
    const std::size_t count = first.back();
    DiffuseParticles& p = frame.particles;
    p.position.resize(count);
    p.velocity.resize(count);
    p.id.resize(count);
    p.age.resize(count);
    frame.type.resize(count);
    std::atomic<int> badType{-1};
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size()), [&](const auto& range) {
      for (std::size_t l = range.begin(); l != range.end(); ++l) {
        const auto& node = *leaves[l];
        points::AttributeHandle<openvdb::Vec3f> position(node.constAttributeArray("P"));
        points::AttributeHandle<openvdb::Vec3f> velocity(node.constAttributeArray("v"));
        points::AttributeHandle<int32_t> id(node.constAttributeArray("id"));
        points::AttributeHandle<int32_t> type(node.constAttributeArray("type"));
        points::AttributeHandle<float> age(node.constAttributeArray("age"));
        std::size_t out = first[l];
        for (auto index = node.beginIndexOn(); index; ++index, ++out) {
          const openvdb::Vec3d world =
              transform.indexToWorld(openvdb::Vec3d(position.get(*index)) + index.getCoord().asVec3d());
          const openvdb::Vec3f v = velocity.get(*index);
          const int32_t t = type.get(*index);
          if (t < 0 || t >= kDiffuseTypeCount) badType = t;
          p.position[out] = Vec3r(float(world.x()), float(world.y()), float(world.z()));
          p.velocity[out] = Vec3r(v.x(), v.y(), v.z());
          p.id[out] = std::uint32_t(id.get(*index));
          p.age[out] = age.get(*index);
          frame.type[out] = DiffuseType(t < 0 || t >= kDiffuseTypeCount ? 0 : t);
        }
      }
    });
    if (badType != -1)
      throw InputError(path.string() + ": whitewater type " + std::to_string(badType.load()) + " is not 0, 1 or 2");
    return frame;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& failure) {
    throw InputError(path.string() + ": not a readable whitewater frame (" + failure.what() + ")");
  }
}

WhitewaterFrame readWhitewaterHeader(const fs::path& path) {
  try {
    const auto grid = readGrid(path, false);
    WhitewaterFrame frame;
    readMetadata(*grid, frame);
    return frame;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& failure) {
    throw InputError(path.string() + ": not a readable whitewater frame (" + failure.what() + ")");
  }
}

void writeWhitewaterPly(const fs::path& path, const WhitewaterFrame& frame) {
  const DiffuseParticles& p = frame.particles;
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment Cascade whitewater (type: 0 spray, 1 foam, 2 bubble)\ncomment "
         << writtenBy() << "\n"
         << "comment up: z\nelement vertex " << p.size()
         << "\nproperty float x\nproperty float y\nproperty float z\nproperty float vx\nproperty float vy\n"
            "property float vz\nproperty int id\nproperty uchar type\nproperty float age\nend_header\n";
  std::string body = header.str();
  constexpr std::size_t kRecord = 6 * sizeof(float) + sizeof(int32_t) + 1 + sizeof(float);
  const std::size_t start = body.size();
  body.resize(start + p.size() * kRecord);
  char* out = body.data() + start;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector3f x = p.position[i].cast<float>(), v = p.velocity[i].cast<float>();
    std::memcpy(out, x.data(), 12);
    std::memcpy(out + 12, v.data(), 12);
    const int32_t id = int32_t(p.id[i]);
    std::memcpy(out + 24, &id, 4);
    out[28] = char(frame.type[i]);
    std::memcpy(out + 29, &p.age[i], 4);
    out += kRecord;
  }
  writeTextAtomically(path, body);
}

std::uint64_t whitewaterChecksum(const WhitewaterFrame& frame) {
  const DiffuseParticles& p = frame.particles;
  std::vector<std::size_t> order(p.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return p.id[a] < p.id[b]; });
  std::uint64_t hash = 1469598103934665603ull;  // FNV-1a 64
  auto mix = [&hash](const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < size; ++k) {
      hash ^= bytes[k];
      hash *= 1099511628211ull;
    }
  };
  for (std::size_t i : order) {
    const Eigen::Vector3f x = p.position[i].cast<float>(), v = p.velocity[i].cast<float>();
    mix(x.data(), 12);
    mix(v.data(), 12);
    mix(&p.id[i], 4);
    mix(&frame.type[i], 1);
    mix(&p.age[i], 4);
  }
  return hash;
}

} // namespace cascade::whitewater
