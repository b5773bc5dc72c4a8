#include "surfacing/SurfaceStage.h"

#include "libsph/Errors.h"
#include "libsph/Version.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/ParticleCache.h"
#include "libsph/io/VdbFile.h"
#include "libsph/io/VdbWriter.h"
#include "libsph/scene/SceneSetup.h"
#include "surfacing/LevelSetFiltering.h"
#include "surfacing/LevelSetMesher.h"
#include "surfacing/LevelSetMethods.h"
#include "surfacing/MeshCleanup.h"
#include "surfacing/ParticleGrid.h"
#include "surfacing/FoamDensity.h"
#include "surfacing/detail/Profile.h"
#include "whitewater/WhitewaterFile.h"

#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetUtil.h>
#include <openvdb/tools/ValueTransformer.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <exception>
#include <iomanip>
#include <cmath>
#include <mutex>
#include <optional>
#include <set>
#include <sstream>
#include <thread>
#include <time.h>

namespace cascade {

namespace fs = std::filesystem;

SurfaceMethod parseSurfaceMethod(const std::string& name) {
  if (name == "union") return SurfaceMethod::UnionOfSpheres;
  if (name == "smooth") return SurfaceMethod::SmoothSpheres;
  if (name == "anisotropic") return SurfaceMethod::AnisotropicKernels;
  throw InputError("--method: unknown surfacing method '" + name + "' (union, smooth, anisotropic)");
}

std::string surfaceMethodName(SurfaceMethod method) {
  switch (method) {
    case SurfaceMethod::UnionOfSpheres: return "union";
    case SurfaceMethod::SmoothSpheres: return "smooth";
    case SurfaceMethod::AnisotropicKernels: return "anisotropic";
  }
  return "?";
}

MeshFormat parseMeshFormat(const std::string& name) {
  if (name == "obj") return MeshFormat::Obj;
  if (name == "ply") return MeshFormat::Ply;
  throw InputError("--mesh-format: unknown mesh format '" + name + "' (obj, ply)");
}

std::string meshFormatName(MeshFormat format) { return format == MeshFormat::Ply ? "ply" : "obj"; }

SurfaceFilter parseSurfaceFilter(const std::string& name) {
  if (name == "none") return SurfaceFilter::None;
  if (name == "mean-curvature") return SurfaceFilter::MeanCurvature;
  if (name == "gaussian") return SurfaceFilter::Gaussian;
  if (name == "laplacian") return SurfaceFilter::Laplacian;
  throw InputError("--filter: unknown level-set filter '" + name + "' (none, mean-curvature, gaussian, laplacian)");
}

std::string surfaceFilterName(SurfaceFilter filter) {
  switch (filter) {
    case SurfaceFilter::None: return "none";
    case SurfaceFilter::MeanCurvature: return "mean-curvature";
    case SurfaceFilter::Gaussian: return "gaussian";
    case SurfaceFilter::Laplacian: return "laplacian";
  }
  return "?";
}

namespace {

using Clock = std::chrono::steady_clock;
double secondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// CPU seconds of the whole process (all threads) so far.
double processCpuSeconds() {
  timespec now{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &now);
  return double(now.tv_sec) + 1e-9 * double(now.tv_nsec);
}

void writeSurfaceVdb(const fs::path& path, openvdb::FloatGrid& levelSet, openvdb::Vec3SGrid* velocity,
                     bool withDensity, openvdb::FloatGrid* foam, const SurfaceOptions& options, double spacing,
                     bool yUp) {
  openvdb::GridPtrVec grids;
  openvdb::FloatGrid::Ptr surface = levelSet.copy();  // shares the tree; own metadata and transform
  surface->setName("surface");
  surface->setGridClass(openvdb::GRID_LEVEL_SET);
  openvdb::math::Mat4d rotation = openvdb::math::Mat4d::identity();
  if (yUp) {  // rotate the lattice: world (x, y, z) -> (x, z, -y)
    rotation.setToRotation(openvdb::math::X_AXIS, -M_PI / 2);
    surface->transform().postMult(rotation);
  }
  surface->insertMeta("cascade_method", openvdb::StringMetadata(surfaceMethodName(options.method)));
  surface->insertMeta("cascade_spacing", openvdb::FloatMetadata(float(spacing)));
  surface->insertMeta("cascade_up_axis", openvdb::StringMetadata(yUp ? "y" : "z"));
  surface->insertMeta("cascade_version", openvdb::StringMetadata(cascadeVersion()));
  grids.push_back(surface);
  if (velocity) {
    openvdb::Vec3SGrid::Ptr v;
    if (yUp) {  // world-space vectors turn with the lattice
      v = velocity->deepCopy();
      v->transform().postMult(rotation);
      openvdb::tools::foreach(v->beginValueOn(), [](const openvdb::Vec3SGrid::ValueOnIter& value) {
        const openvdb::Vec3s w = *value;
        value.setValue(openvdb::Vec3s(w.x(), w.z(), -w.y()));
      });
    } else {
      v = velocity->copy();  // shares the tree
    }
    v->setName("v");
    // Half floats on disk (3 significant digits: ample for motion blur), as
    // Houdini writes velocity fields by default; readers get floats back.
    v->setSaveFloatAsHalf(true);
    grids.push_back(v);
  }
  if (withDensity) {
    auto density = surface->deepCopy();
    openvdb::tools::sdfToFogVolume(*density);
    density->setName("density");
    density->setGridClass(openvdb::GRID_FOG_VOLUME);
    grids.push_back(density);
  }
  if (foam) {
    foam->transform().postMult(rotation);
    grids.push_back(foam->copy());
  }
  writeFileAtomically(path, [&](const fs::path& temp) {
    // Active-mask compression (inactive values are +-background); Blosc only on request.
    writeVdbFile(temp, openvdb::GridCPtrVec(grids.begin(), grids.end()),
                 options.vdbBlosc ? openvdb::io::COMPRESS_ACTIVE_MASK | openvdb::io::COMPRESS_BLOSC
                                  : openvdb::io::COMPRESS_ACTIVE_MASK);
  });
}

} // namespace

double leastSurfaceBytes(std::size_t particles, double spacing, double voxelSize, bool velocity) {
  if (!(spacing > 0) || !(voxelSize > 0)) return 0;
  const double volume = double(particles) * spacing * spacing * spacing;
  const double area = std::cbrt(36 * M_PI) * std::pow(volume, 2.0 / 3.0);  // a sphere's: the least
  const double bandVoxels = area * 2 / (voxelSize * voxelSize);
  return bandVoxels * (velocity ? 16.0 : 4.0);
}

SurfaceResult surfaceParticles(const std::vector<Vec3r>& positions, double spacing, const SurfaceOptions& options,
                               const fs::path& vdbPath, const fs::path& meshPath) {
  return surfaceParticles(positions, {}, spacing, options, vdbPath, meshPath);
}

SurfaceResult surfaceParticles(const std::vector<Vec3r>& positions, const std::vector<Vec3r>& velocities,
                               double spacing, const SurfaceOptions& options, const fs::path& vdbPath,
                               const fs::path& meshPath, const std::vector<Vec3r>* foam) {
  initializeOpenVdb();
  SurfaceResult result;
  if (options.particleSpacing > 0) spacing = options.particleSpacing;
  if (!(spacing > 0)) spacing = surfacing::estimateParticleSpacing(positions);
  if (!(spacing > 0)) spacing = options.voxelSize > 0 ? 2 * options.voxelSize : 0;
  const double voxelSize = options.voxelSize > 0 ? options.voxelSize : 0.5 * spacing;
  result.voxelSize = voxelSize;
  result.particleSpacing = spacing;

  // Refuse, before allocating, a frame whose level set cannot fit even at its least.
  const double least =
      leastSurfaceBytes(positions.size(), spacing, voxelSize, options.velocity && !velocities.empty());
  const double available = scene::availableMemory();
  if (available > 0 && least > available) {
    std::ostringstream message;
    message << std::setprecision(3) << "surface: needs at least " << least / double(1 << 30) << " GiB ("
            << positions.size() << " particles at voxel size " << voxelSize << " m, spacing " << spacing
            << " m), this machine has " << available / double(1 << 30) << " GiB available (a larger --voxel-size)";
    throw InputError(message.str());
  }

  surfacing::LevelSetSettings settings;
  settings.voxelSize = voxelSize;
  settings.spacing = spacing;
  settings.radius = options.particleRadius;
  settings.halfWidth = std::max(2, options.halfWidth);
  if (options.velocity && !velocities.empty()) {
    if (velocities.size() != positions.size())
      throw InputError("surface: " + std::to_string(velocities.size()) + " velocities for " +
                       std::to_string(positions.size()) + " particles");
    settings.velocities = &velocities;
  }

  auto start = Clock::now();
  double cpuStart = processCpuSeconds();
  auto stageDone = [&](double& seconds, double& cpuSeconds) {
    seconds = secondsSince(start);
    const double cpuNow = processCpuSeconds();
    cpuSeconds = cpuNow - cpuStart;
    start = Clock::now();
    cpuStart = cpuNow;
  };
  openvdb::FloatGrid::Ptr levelSet;
  openvdb::Vec3STree::Ptr kernelVelocity;
  if (positions.empty() || !(voxelSize > 0)) {
    levelSet = openvdb::createLevelSet<openvdb::FloatGrid>(voxelSize > 0 ? voxelSize : 1.0, settings.halfWidth);
  } else {
    surfacing::ParticleLevelSet made = surfacing::particlesToLevelSet(options.method, positions, settings);
    levelSet = made.surface;
    kernelVelocity = made.velocity;
  }
  levelSet->setName("surface");
  stageDone(result.timings.rasterize, result.timings.cpu.rasterize);

  if (!positions.empty()) surfacing::filterLevelSet(*levelSet, options.filter, options.smoothingPasses);
  result.activeVoxels = levelSet->activeVoxelCount();
  openvdb::Vec3SGrid::Ptr velocity;  // over the final band
  if (kernelVelocity) velocity = surfacing::velocityOverBand(*levelSet, std::move(kernelVelocity), settings.halfWidth);
  result.hasVelocity = velocity != nullptr;
  stageDone(result.timings.filter, result.timings.cpu.filter);

  // The level set is final: write the VDB on a thread of its own (file I/O and
  // compression are serial in OpenVDB) while the mesh is made, cleaned and written.
  std::exception_ptr vdbFailure;
  std::thread vdbWriter;
  if (!vdbPath.empty()) {
    vdbWriter = std::thread([&] {
      const auto writeStart = Clock::now();
      try {
        openvdb::FloatGrid::Ptr foamGrid;
        if (foam) foamGrid = surfacing::foamDensityGrid(*foam, spacing, voxelSize);
        writeSurfaceVdb(vdbPath, *levelSet, velocity.get(), options.writeDensity, foamGrid.get(), options, spacing,
                        options.vdbYUp);
      } catch (...) {
        vdbFailure = std::current_exception();
      }
      result.timings.vdbWrite = secondsSince(writeStart);
    });
  }
  struct JoinOnExit {  // an exception below still waits for the writer
    std::thread& thread;
    ~JoinOnExit() {
      if (thread.joinable()) thread.join();
    }
  } joinOnExit{vdbWriter};

  result.mesh = surfacing::levelSetToMesh(*levelSet, std::clamp(options.adaptivity, 0.0, 1.0));
  stageDone(result.timings.mesh, result.timings.cpu.mesh);

  surfacing::MeshCleanupSettings cleanup;
  cleanup.minComponentVolume =
      options.minComponentVolume >= 0 ? options.minComponentVolume : spacing * spacing * spacing / 8;
  cleanup.triangleBudget = options.triangleBudget;
  cleanup.remeshEdgeLength = options.remeshEdgeLength;
  surfacing::cleanupMesh(result.mesh, cleanup);
  // Vertex velocities where they go somewhere: a PLY file, or the caller's mesh.
  surfacing::detail::ProfileClock cleanupProfile;
  if (velocity && (meshPath.empty() || meshPath.extension() == ".ply"))
    result.mesh.velocities = surfacing::sampleVelocity(*velocity, result.mesh.vertices);
  cleanupProfile.lap("cleanup: vertex velocities");
  stageDone(result.timings.cleanup, result.timings.cpu.cleanup);

  surfacing::detail::ProfileClock profile;
  if (!meshPath.empty()) writeSurfaceMesh(meshPath, result.mesh, options.meshYUp);
  profile.lap("write: mesh");
  if (vdbWriter.joinable()) vdbWriter.join();
  profile.lap("write: wait for vdb");
  stageDone(result.timings.write, result.timings.cpu.write);
  if (vdbFailure) std::rethrow_exception(vdbFailure);
  return result;
}

void writeSurfaceMesh(const fs::path& path, const TriangleMesh& mesh, bool yUp) {
  // "up: y|z" tells Cascade's render, the Blender script (and people) the file's axes.
  const std::string comment = yUp ? "up: y (a scene point x, y, z is stored as x, z, -y)" : "up: z (scene coordinates)";
  const MeshAxes axes = yUp ? MeshAxes::ZUpToYUp : MeshAxes::AsIs;
  if (path.extension() == ".ply") writePly(path, mesh, comment, axes);
  else writeObj(path, mesh, comment, axes);
}

std::vector<SurfaceFrameReport> surfaceFrames(const OutputLayout& layout, const FrameRange& range,
                                              const SurfaceOptions& options,
                                              const std::function<void(const SurfaceFrameReport&)>& progress) {
  initializeOpenVdb();
  // Frames to do: every number in A-B when both are given, else those on disk within the range.
  std::set<int> onDisk;
  for (const char* extension : {"vdb", "ply"})
    for (int frame : listFrames(layout.particlesDir(), "particles", extension)) onDisk.insert(frame);
  std::vector<int> frames;
  if (range.first && range.last) {
    for (int frame = *range.first; frame <= *range.last; ++frame) frames.push_back(frame);
  } else {
    for (int frame : onDisk)
      if (range.contains(frame)) frames.push_back(frame);
    if (frames.empty())
      throw InputError(layout.particlesDir().string() +
                       ": no particle caches (particles.NNNN.vdb or .ply) in the frame range");
  }
  if (!options.writeVdb && !options.writeMesh)
    throw InputError("surface: nothing to write (both the VDB and the mesh output are off)");
  const std::string meshExtension = meshFormatName(options.meshFormat);

  std::vector<SurfaceFrameReport> reports(frames.size());
  std::mutex progressMutex;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, frames.size(), 1), [&](const auto& indices) {
    for (std::size_t index = indices.begin(); index != indices.end(); ++index) {
      SurfaceFrameReport& report = reports[index];
      const int frame = report.frame = frames[index];
      const fs::path vdbOut = layout.surface(frame), meshOut = layout.mesh(frame, meshExtension);
      const bool done = (!options.writeVdb || fs::exists(vdbOut)) && (!options.writeMesh || fs::exists(meshOut));
      try {
        if (done && !options.force) {
          report.skipped = true;
        } else {
          fs::path input = layout.particles(frame);
          if (!fs::exists(input) && fs::exists(layout.particlesPly(frame))) input = layout.particlesPly(frame);
          const ParticleFrame particles = readParticleFrame(input);  // InputError names the file
          report.particles = particles.size();
          std::optional<std::vector<Vec3r>> foam;
          if (options.foamDensity && options.writeVdb) {
            const fs::path whitewaterFile = layout.whitewater(frame);
            if (!fs::is_regular_file(whitewaterFile))
              throw InputError(whitewaterFile.string() + ": no such file (the foam grid needs `cascade whitewater` first)");
            const whitewater::WhitewaterFrame diffuse = whitewater::readWhitewaterVdb(whitewaterFile);
            foam.emplace();
            for (std::size_t i = 0; i < diffuse.particles.size(); ++i)
              if (diffuse.type[i] == whitewater::DiffuseType::Foam) foam->push_back(diffuse.particles.position[i]);
          }
          SurfaceResult result = surfaceParticles(particles.position, particles.velocity, particles.spacing, options,
                                                  options.writeVdb ? vdbOut : fs::path(),
                                                  options.writeMesh ? meshOut : fs::path(), foam ? &*foam : nullptr);
          report.timings = result.timings;
          report.triangles = result.mesh.triangles.size();
        }
      } catch (const InputError& error) {
        report.error = error.what();
        report.badInput = true;
      } catch (const std::exception& error) {
        report.error = "frame " + std::to_string(frame) + ": " + error.what();
      }
      if (progress) {
        std::lock_guard<std::mutex> lock(progressMutex);
        progress(report);
      }
    }
  });
  return reports;
}

} // namespace cascade
