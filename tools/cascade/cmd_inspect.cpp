// `cascade inspect FILE` (docs/cli.md): what a particle cache, VDB level set
// or OBJ / PLY mesh holds; for a particle cache also a checksum over positions and
// velocities in id order (libsph/io/ParticleCache.h). `--against B`: two particle
// caches matched by id, or two meshes' Hausdorff distance.
#include "Commands.h"

#include "libsph/Errors.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/ParticleCompare.h"
#include "libsph/io/Ply.h"
#include "libsph/io/TriangleMesh.h"
#include "libsph/io/VdbFile.h"
#include "surfacing/MeshChecks.h"

#include "whitewater/WhitewaterFile.h"

#include <openvdb/openvdb.h>
#include <openvdb/points/PointDataGrid.h>

#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

namespace cascade::cli {

namespace fs = std::filesystem;

namespace {

void printBounds(const char* label, const Vec3d& lo, const Vec3d& hi) {
  std::printf("%s[%.6g, %.6g, %.6g] - [%.6g, %.6g, %.6g]\n", label, lo.x(), lo.y(), lo.z(), hi.x(), hi.y(),
              hi.z());
}

void inspectParticles(const fs::path& path) {
  const ParticleFrame frame = readParticleFrame(path);
  std::printf("file: %s\nkind: particle cache\n", path.string().c_str());
  std::printf("count: %zu\n", frame.size());
  std::string attributes = "P";
  if (!frame.velocity.empty()) attributes += ", v";
  if (!frame.id.empty()) attributes += ", id";
  if (!frame.density.empty()) attributes += ", density";
  if (!frame.pressure.empty()) attributes += ", pressure";
  std::printf("attributes: %s\n", attributes.c_str());
  if (!frame.position.empty()) {
    Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
    for (const Vec3r& p : frame.position) {
      lo = lo.cwiseMin(p.cast<double>());
      hi = hi.cwiseMax(p.cast<double>());
    }
    printBounds("bounds: ", lo, hi);
  }
  std::printf("time: %.9g s\n", frame.time);
  if (frame.spacing > 0) std::printf("spacing: %.6g m\n", double(frame.spacing));
  if (!frame.density.empty()) {
    double sum = 0, low = 1e300, high = -1e300;
    for (Real d : frame.density) sum += d, low = std::min(low, double(d)), high = std::max(high, double(d));
    std::printf("density: min %.6g, mean %.6g, max %.6g kg/m^3\n", low, sum / double(frame.density.size()), high);
  }
  if (!frame.velocity.empty()) {
    double top = 0;
    for (const Vec3r& v : frame.velocity) top = std::max(top, double(v.norm()));
    std::printf("max speed: %.6g m/s\n", top);
  }
  for (const auto& [key, value] : frame.metadata) std::printf("meta %s: %s\n", key.c_str(), value.c_str());
  std::printf("checksum: %016" PRIx64 "\n", particleChecksum(frame));
}

void inspectVolume(const fs::path& path, openvdb::GridPtrVecPtr grids) {
  std::printf("file: %s\nkind: OpenVDB volume\ngrids: %zu\n", path.string().c_str(), grids->size());
  for (const openvdb::GridBase::Ptr& grid : *grids) {
    std::string gridClass = openvdb::GridBase::gridClassToString(grid->getGridClass());
    std::printf("grid \"%s\": type %s, class %s\n", grid->getName().c_str(), grid->valueType().c_str(),
                gridClass.c_str());
    const openvdb::Vec3d voxel = grid->voxelSize();
    std::printf("  voxel size: %.6g", voxel.x());
    if (voxel.y() != voxel.x() || voxel.z() != voxel.x()) std::printf(" %.6g %.6g", voxel.y(), voxel.z());
    std::printf(" m\n  active voxels: %" PRIu64 "\n", static_cast<std::uint64_t>(grid->activeVoxelCount()));
    const openvdb::CoordBBox box = grid->evalActiveVoxelBoundingBox();
    if (!box.empty()) {
      const openvdb::Vec3d lo = grid->indexToWorld(box.min().asVec3d() - openvdb::Vec3d(0.5));
      const openvdb::Vec3d hi = grid->indexToWorld(box.max().asVec3d() + openvdb::Vec3d(0.5));
      printBounds("  bounds: ", Vec3d(lo.x(), lo.y(), lo.z()), Vec3d(hi.x(), hi.y(), hi.z()));
    }
    if (grid->getGridClass() == openvdb::GRID_LEVEL_SET) {
      if (auto floatGrid = openvdb::GridBase::grid<openvdb::FloatGrid>(grid))
        std::printf("  background (half band width): %.6g m\n", double(floatGrid->background()));
    }
  }
}

void inspectWhitewater(const fs::path& path) {
  const whitewater::WhitewaterFrame frame = whitewater::readWhitewaterVdb(path);
  const auto counts = frame.counts();
  std::printf("file: %s\nkind: whitewater\n", path.string().c_str());
  std::printf("count: %zu\n", frame.particles.size());
  for (int type = 0; type < whitewater::kDiffuseTypeCount; ++type)
    std::printf("%s: %zu\n", whitewater::diffuseTypeName(whitewater::DiffuseType(type)), counts[std::size_t(type)]);
  std::printf("attributes: P, v, id, type, age\n");
  if (frame.particles.size() > 0) {
    Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
    double oldest = 0;
    for (std::size_t i = 0; i < frame.particles.size(); ++i) {
      lo = lo.cwiseMin(frame.particles.position[i].cast<double>());
      hi = hi.cwiseMax(frame.particles.position[i].cast<double>());
      oldest = std::max(oldest, double(frame.particles.age[i]));
    }
    printBounds("bounds: ", lo, hi);
    std::printf("oldest: %.6g s\n", oldest);
  }
  std::printf("time: %.9g s\nnext id: %u\n", frame.time, frame.nextId);
  std::printf("checksum: %016" PRIx64 "\n", whitewater::whitewaterChecksum(frame));
}

void inspectVdb(const fs::path& path) {
  openvdb::initialize();
  validateVdbFile(path);  // truncated or foreign files: InputError before OpenVDB reads them
  const VdbReadScope reading(path);
  openvdb::GridPtrVecPtr grids;
  try {
    openvdb::io::File file(path.string());
    file.open(false);
    // Grid descriptors only: point grids are read by readParticleFrame.
    for (openvdb::io::File::NameIterator name = file.beginName(); name != file.endName(); ++name) {
      const openvdb::GridBase::Ptr meta = file.readGridMetadata(name.gridName());
      if (meta->type() == openvdb::points::PointDataGrid::gridType()) {
        const bool whitewater = meta->getName() == "whitewater";
        file.close();
        return whitewater ? inspectWhitewater(path) : inspectParticles(path);
      }
    }
    grids = file.getGrids();
    file.close();
  } catch (const std::exception& error) {
    throw InputError(path.string() + ": not a readable VDB file (" + error.what() + ")");
  }
  for (const openvdb::GridBase::Ptr& grid : *grids)
    if (grid->isType<openvdb::points::PointDataGrid>()) return inspectParticles(path);
  inspectVolume(path, grids);
}

/// A PLY with faces is a mesh; one with vertices only, a particle file.
bool plyHasFaces(const fs::path& path) {
  const PlyReader reader(path, true);  // the header only: the file is read again as what it is
  for (const PlyElement& element : reader.elements())
    if (element.name == "face" && element.count > 0) return true;
  return false;
}

void inspectMesh(const fs::path& path) {
  const bool ply = path.extension() == ".ply";
  std::vector<std::string> comments;
  const TriangleMesh mesh = ply ? readPly(path, &comments) : readObj(path);
  std::printf("file: %s\nkind: %s mesh\n", path.string().c_str(), ply ? "PLY" : "OBJ");
  std::printf("vertices: %zu\ntriangles: %zu\n", mesh.vertices.size(), mesh.triangles.size());
  if (!mesh.vertices.empty()) {
    Vec3d lo = Vec3d::Constant(1e300), hi = Vec3d::Constant(-1e300);
    for (const auto& v : mesh.vertices) {
      lo = lo.cwiseMin(v.cast<double>());
      hi = hi.cwiseMax(v.cast<double>());
    }
    printBounds("bounds: ", lo, hi);
  }
  std::printf("normals: %s\n", mesh.normals.empty() ? "no" : "yes");
  if (mesh.velocities.empty()) {
    std::printf("velocities: no\n");
  } else {
    double top = 0;
    for (const auto& v : mesh.velocities) top = std::max(top, double(v.norm()));
    std::printf("velocities: yes (max speed %.6g m/s)\n", top);
  }
  for (const std::string& comment : comments) std::printf("comment: %s\n", comment.c_str());
  std::printf("groups: %zu\n", mesh.groups.size());
  for (const TriangleMesh::Group& group : mesh.groups)
    std::printf("  group \"%s\": %zu triangles\n", group.name.c_str(), group.end - group.begin);
}

} // namespace

/// `--against B`: the two particle caches matched by id (ParticleCompare.h).
void compareParticles(const fs::path& a, const fs::path& b) {
  const ParticleFrame frameA = readParticleFrame(a), frameB = readParticleFrame(b);
  ParticleDifference d;
  try {
    d = compareParticleFrames(frameA, frameB);
  } catch (const InputError& error) {
    throw InputError(a.string() + " against " + b.string() + ": " + error.what());
  }
  std::printf("file: %s\nagainst: %s\n", a.string().c_str(), b.string().c_str());
  std::printf("count: %zu %zu\n", frameA.size(), frameB.size());
  std::printf("matched: %zu (by %s)\n", d.matched, d.byId ? "id" : "file order");
  std::printf("only_in_a: %zu\nonly_in_b: %zu\n", d.onlyInA, d.onlyInB);
  std::printf("max_position_difference_m: %.9g (%s %u)\n", d.maxPosition, d.byId ? "id" : "index",
              unsigned(d.maxPositionId));
  std::printf("rms_position_difference_m: %.9g\n", d.rmsPosition);
  if (!frameA.velocity.empty() && !frameB.velocity.empty())
    std::printf("max_velocity_difference_m_s: %.9g\nrms_velocity_difference_m_s: %.9g\n", d.maxVelocity,
                d.rmsVelocity);
  std::printf("time: %.9g %.9g s\n", frameA.time, frameB.time);
}

/// `--against B` for two meshes: their symmetric Hausdorff distance (MeshChecks.h).
void compareMeshes(const fs::path& a, const fs::path& b) {
  const TriangleMesh meshA = readMesh(a), meshB = readMesh(b);
  if (meshA.triangles.empty() || meshB.triangles.empty())
    throw InputError((meshA.triangles.empty() ? a : b).string() + ": a mesh with no triangles has no distance to another");
  std::printf("file: %s\nagainst: %s\n", a.string().c_str(), b.string().c_str());
  std::printf("triangles: %zu %zu\n", meshA.triangles.size(), meshB.triangles.size());
  std::printf("vertices: %zu %zu\n", meshA.vertices.size(), meshB.vertices.size());
  std::printf("hausdorff_distance_m: %.9g\n", surfacing::hausdorffDistance(meshA, meshB));
}

bool isMesh(const fs::path& path) {
  return path.extension() == ".obj" || (path.extension() == ".ply" && plyHasFaces(path));
}

void addInspectCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("inspect", "Show what a particle cache, VDB, OBJ or PLY file holds");
  auto file = std::make_shared<std::string>();
  auto against = std::make_shared<std::string>();
  command->add_option("file", *file, "A file: particles.NNNN.vdb | .ply | surface.NNNN.vdb | fluid.NNNN.obj | .ply | whitewater.NNNN.vdb")->required();
  command->add_option("--against", *against,
                      "Another particle cache (match the particles by id, print the position differences) or "
                      "mesh (print the Hausdorff distance)");
  command->callback([file, against] {
    const fs::path path(*file);
    std::error_code error;
    if (!fs::is_regular_file(path, error)) throw InputError(path.string() + ": file not found");
    if (!against->empty()) {
      if (!fs::is_regular_file(*against, error)) throw InputError(*against + ": file not found");
      const bool meshA = isMesh(path), meshB = isMesh(*against);
      if (meshA != meshB)
        throw InputError(path.string() + " against " + *against + ": " + (meshA ? "a mesh" : "a particle cache") +
                         " and " + (meshB ? "a mesh" : "a particle cache") + " do not compare");
      return meshA ? compareMeshes(path, *against) : compareParticles(path, *against);
    }
    const std::string extension = path.extension().string();
    if (extension == ".vdb") inspectVdb(path);
    else if (extension == ".ply") plyHasFaces(path) ? inspectMesh(path) : inspectParticles(path);
    else if (extension == ".obj") inspectMesh(path);
    else throw InputError(path.string() + ": unknown file type (expected .vdb, .ply or .obj)");
  });
}

} // namespace cascade::cli
