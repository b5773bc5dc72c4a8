// Particle caches: OpenVDB point data grids (write/read) and PLY points (read/write).
#include "libsph/io/ParticleCache.h"

#include "libsph/Errors.h"
#include "libsph/Version.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/Ply.h"
#include "libsph/io/VdbFile.h"
#include "libsph/io/VdbPointAttributes.h"
#include "libsph/io/VdbWriter.h"

#include <openvdb/openvdb.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/points/PointDataGrid.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <numeric>
#include <sstream>

namespace cascade {

namespace fs = std::filesystem;

namespace {

constexpr const char* kGridName = "particles";
constexpr const char* kTimeKey = "cascade_time";
constexpr const char* kSpacingKey = "cascade_spacing";
constexpr const char* kVersionKey = "cascade_version";  // the writer (Version.h)

} // namespace

void writeParticleFrame(const fs::path& path, const ParticleFrame& frame, double voxelSize) {
  initializeOpenVdb();
  namespace points = openvdb::points;
  const std::size_t count = frame.size();
  std::vector<openvdb::Vec3R> positions(count);
  for (std::size_t i = 0; i < count; ++i)
    positions[i] = openvdb::Vec3R(frame.position[i].x(), frame.position[i].y(), frame.position[i].z());
  points::PointAttributeVector<openvdb::Vec3R> positionWrapper(positions);

  // About 8 particles per voxel keeps leaves dense and the P codec precise.
  if (voxelSize <= 0) {
    if (frame.spacing > 0) voxelSize = 2.0 * frame.spacing;
    else if (count > 0) voxelSize = points::computeVoxelSize(positionWrapper, 8);
    else voxelSize = 1.0;
  }
  const auto transform = openvdb::math::Transform::createLinearTransform(voxelSize);
  const auto indexGrid =
      openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(positionWrapper, *transform);
  // P: 16-bit fixed point within its voxel (precision voxelSize / 65536).
  auto grid = points::createPointDataGrid<points::FixedPointCodec<false>, points::PointDataGrid>(
      *indexGrid, positionWrapper, *transform);
  auto& tree = grid->tree();
  const auto& indexTree = indexGrid->tree();

  if (frame.velocity.size() == count) {
    std::vector<openvdb::Vec3f> velocity(count);
    for (std::size_t i = 0; i < count; ++i)
      velocity[i] = openvdb::Vec3f(float(frame.velocity[i].x()), float(frame.velocity[i].y()),
                                   float(frame.velocity[i].z()));
    // v: half floats (relative precision about 1e-3).
    points::appendAttribute<openvdb::Vec3f, points::TruncateCodec>(tree, "v");
    populatePointAttribute(tree, indexTree, "v", velocity);
  }
  if (frame.id.size() == count) {
    std::vector<int32_t> ids(frame.id.begin(), frame.id.end());
    points::appendAttribute<int32_t>(tree, "id");
    populatePointAttribute(tree, indexTree, "id", ids);
  }
  if (frame.density.size() == count) {
    std::vector<float> density(frame.density.begin(), frame.density.end());
    points::appendAttribute<float>(tree, "density");
    populatePointAttribute(tree, indexTree, "density", density);
  }
  if (frame.pressure.size() == count) {
    std::vector<float> pressure(frame.pressure.begin(), frame.pressure.end());
    points::appendAttribute<float>(tree, "pressure");
    populatePointAttribute(tree, indexTree, "pressure", pressure);
  }

  grid->setName(kGridName);
  grid->insertMeta(kTimeKey, openvdb::DoubleMetadata(frame.time));
  grid->insertMeta(kSpacingKey, openvdb::FloatMetadata(float(frame.spacing)));
  for (const auto& [key, value] : frame.metadata) grid->insertMeta(key, openvdb::StringMetadata(value));
  grid->insertMeta(kVersionKey, openvdb::StringMetadata(cascadeVersion()));

  writeFileAtomically(path, [&](const fs::path& temp) {
    writeVdbFile(temp, openvdb::GridCPtrVec{grid}, openvdb::io::COMPRESS_BLOSC | openvdb::io::COMPRESS_ACTIVE_MASK);
  });
}

namespace {

ParticleFrame readVdbFrame(const fs::path& path) {
  initializeOpenVdb();
  validateVdbFile(path);
  const VdbReadScope reading(path);
  namespace points = openvdb::points;
  openvdb::io::File file(path.string());
  file.open(false);  // no delayed loading: read everything now
  points::PointDataGrid::Ptr grid;
  for (auto name = file.beginName(); name != file.endName(); ++name) {
    auto base = file.readGrid(name.gridName());
    if (auto pointGrid = openvdb::gridPtrCast<points::PointDataGrid>(base)) {
      if (!grid || pointGrid->getName() == kGridName) grid = pointGrid;
    }
  }
  file.close();
  if (!grid) throw InputError(path.string() + ": no OpenVDB point data grid in the file");

  ParticleFrame frame;
  if (auto time = grid->getMetadata<openvdb::DoubleMetadata>(kTimeKey)) frame.time = time->value();
  if (auto spacing = grid->getMetadata<openvdb::FloatMetadata>(kSpacingKey)) frame.spacing = spacing->value();
  for (auto meta = grid->beginMeta(); meta != grid->endMeta(); ++meta)
    if (auto text = openvdb::DynamicPtrCast<openvdb::StringMetadata>(meta->second))
      frame.metadata[meta->first] = text->value();

  const auto& tree = grid->constTree();
  auto leaf = tree.cbeginLeaf();
  if (!leaf) return frame;
  const auto& descriptor = leaf->attributeSet().descriptor();
  auto has = [&](const char* name) { return descriptor.find(name) != points::AttributeSet::INVALID_POS; };
  if (!has("P")) throw InputError(path.string() + ": point grid has no P attribute");
  const bool hasVelocity = has("v"), hasId = has("id"), hasDensity = has("density"),
             hasPressure = has("pressure");
  const auto& transform = grid->transform();
  const std::size_t count = std::size_t(points::pointCount(tree));
  frame.position.reserve(count);
  if (hasVelocity) frame.velocity.reserve(count);
  if (hasId) frame.id.reserve(count);
  if (hasDensity) frame.density.reserve(count);
  if (hasPressure) frame.pressure.reserve(count);
  for (; leaf; ++leaf) {
    points::AttributeHandle<openvdb::Vec3f> positionHandle(leaf->constAttributeArray("P"));
    std::unique_ptr<points::AttributeHandle<openvdb::Vec3f>> velocityHandle;
    std::unique_ptr<points::AttributeHandle<int32_t>> idHandle;
    std::unique_ptr<points::AttributeHandle<float>> densityHandle, pressureHandle;
    if (hasVelocity) velocityHandle = std::make_unique<points::AttributeHandle<openvdb::Vec3f>>(leaf->constAttributeArray("v"));
    if (hasId) idHandle = std::make_unique<points::AttributeHandle<int32_t>>(leaf->constAttributeArray("id"));
    if (hasDensity) densityHandle = std::make_unique<points::AttributeHandle<float>>(leaf->constAttributeArray("density"));
    if (hasPressure) pressureHandle = std::make_unique<points::AttributeHandle<float>>(leaf->constAttributeArray("pressure"));
    for (auto index = leaf->beginIndexOn(); index; ++index) {
      const openvdb::Vec3d world =
          transform.indexToWorld(openvdb::Vec3d(positionHandle.get(*index)) + index.getCoord().asVec3d());
      frame.position.emplace_back(Real(world.x()), Real(world.y()), Real(world.z()));
      if (velocityHandle) {
        const openvdb::Vec3f v = velocityHandle->get(*index);
        frame.velocity.emplace_back(Real(v.x()), Real(v.y()), Real(v.z()));
      }
      if (idHandle) frame.id.push_back(static_cast<ParticleId>(idHandle->get(*index)));
      if (densityHandle) frame.density.push_back(Real(densityHandle->get(*index)));
      if (pressureHandle) frame.pressure.push_back(Real(pressureHandle->get(*index)));
    }
  }
  return frame;
}

// ---------------------------------------------------------------------------------- PLY

ParticleFrame readPlyFrame(const fs::path& path) {
  PlyReader reader(path);
  const std::string& where = reader.where();
  const auto& elements = reader.elements();
  const auto vertexIt = std::find_if(elements.begin(), elements.end(),
                                     [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertexIt == elements.end()) throw InputError(where + "no vertex element");
  const PlyElement& vertex = *vertexIt;
  int column[9];
  const char* names[9] = {"x", "y", "z", "vx", "vy", "vz", "id", "density", "pressure"};
  for (int k = 0; k < 9; ++k) column[k] = vertex.find(names[k]);
  if (column[0] < 0 || column[1] < 0 || column[2] < 0) throw InputError(where + "vertices lack x, y, z");
  for (const auto& property : vertex.properties)
    if (property.isList) throw InputError(where + "unsupported vertex property '" + property.name + "' (a list)");

  ParticleFrame frame;
  frame.position.reserve(vertex.count);
  const bool hasVelocity = column[3] >= 0 && column[4] >= 0 && column[5] >= 0;
  reader.read(std::size_t(vertexIt - elements.begin()), [&](const std::vector<double>& values, const auto&) {
    frame.position.emplace_back(Real(values[column[0]]), Real(values[column[1]]), Real(values[column[2]]));
    if (hasVelocity) frame.velocity.emplace_back(Real(values[column[3]]), Real(values[column[4]]), Real(values[column[5]]));
    if (column[6] >= 0) frame.id.push_back(ParticleId(values[column[6]]));
    if (column[7] >= 0) frame.density.push_back(Real(values[column[7]]));
    if (column[8] >= 0) frame.pressure.push_back(Real(values[column[8]]));
  });
  return frame;
}

} // namespace

void writeParticlePly(const fs::path& path, const ParticleFrame& frame) {
  const bool withVelocity = frame.velocity.size() == frame.size() && !frame.velocity.empty();
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment Cascade particles\ncomment " << writtenBy() << "\nelement vertex "
         << frame.size() << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (withVelocity) header << "property float vx\nproperty float vy\nproperty float vz\n";
  header << "end_header\n";
  std::string body = header.str();
  const std::size_t floatsPerVertex = withVelocity ? 6 : 3;
  std::vector<float> values;
  values.reserve(frame.size() * floatsPerVertex);
  for (std::size_t i = 0; i < frame.size(); ++i) {
    for (int k = 0; k < 3; ++k) values.push_back(float(frame.position[i][k]));
    if (withVelocity)
      for (int k = 0; k < 3; ++k) values.push_back(float(frame.velocity[i][k]));
  }
  body.append(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
  writeTextAtomically(path, body);
}

ParticleFrame readParticleFrame(const fs::path& path) {
  std::error_code error;
  if (!fs::is_regular_file(path, error)) throw InputError(path.string() + ": no such particle file");
  const std::string extension = path.extension().string();
  try {
    if (extension == ".ply") return readPlyFrame(path);
    if (extension == ".vdb") return readVdbFrame(path);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& failure) {
    throw InputError(path.string() + ": not a readable particle cache (" + failure.what() + ")");
  }
  throw InputError(path.string() + ": unknown particle file type (expected .vdb or .ply)");
}

std::uint64_t particleChecksum(const ParticleFrame& frame) {
  std::vector<std::size_t> order(frame.size());
  std::iota(order.begin(), order.end(), std::size_t(0));
  if (frame.id.size() == frame.size())
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return frame.id[a] < frame.id[b]; });
  std::uint64_t hash = 1469598103934665603ull;  // FNV-1a 64
  auto mix = [&hash](float value) {
    std::uint32_t bits;
    std::memcpy(&bits, &value, sizeof bits);
    for (int byte = 0; byte < 4; ++byte) {
      hash ^= (bits >> (8 * byte)) & 0xffu;
      hash *= 1099511628211ull;
    }
  };
  const bool withVelocity = frame.velocity.size() == frame.size();
  for (std::size_t i : order) {
    for (int k = 0; k < 3; ++k) mix(float(frame.position[i][k]));
    if (withVelocity)
      for (int k = 0; k < 3; ++k) mix(float(frame.velocity[i][k]));
  }
  return hash;
}

} // namespace cascade
