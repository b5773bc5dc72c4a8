// `cascade bench surface`: ~0.9 M particles of a splash (a pool, a collapsing
// column with a crown sheet, 150 k airborne droplets; spacing 0.006 m) surfaced
// by each method, timed by stage, with what the "v" grid, binary PLY and adaptive
// meshing cost and give (file sizes, triangles, Hausdorff distance to the uniform
// mesh in voxels), and, in the same run, OpenVDB's vdb_tool (Debian
// libopenvdb-tools) on the same points for the ratio.
#include "BenchSplash.h"
#include "Benchmarks.h"

#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"
#include "surfacing/MeshChecks.h"
#include "surfacing/SurfaceStage.h"

#include <algorithm>

#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <sstream>
#include <sys/times.h>
#include <unistd.h>

namespace cascade::cli {

namespace {

namespace fs = std::filesystem;
constexpr double kVoxel = 0.003;

double milliseconds(double seconds) { return std::round(seconds * 1e4) / 10; }

/// One configuration of the bench: a method and the output choices.
struct Config {
  std::string name;  ///< for CASCADE_BENCH_SURFACE
  SurfaceMethod method = SurfaceMethod::AnisotropicKernels;
  MeshFormat format = MeshFormat::Obj;
  bool velocity = true;
  double adaptivity = 0;
};

} // namespace

BenchTable benchSurface() {
  BenchTable table("surface", {"method", "n_particles", "voxel_size", "mesh_format", "velocity", "adaptivity",
                               "rasterize_ms", "filter_ms", "mesh_ms", "cleanup_ms", "write_ms", "total_ms", "cpu_ms",
                               "triangles", "mesh_mb", "vdb_mb", "hausdorff_voxels", "vs_vdb_tool"});
  const Splash splash = splashParticles();
  const std::vector<Vec3r>& points = splash.points;
  const fs::path dir = fs::temp_directory_path() / ("cascade_bench_surface_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::cerr << "bench surface: " << points.size() << " particles, voxel " << kVoxel << " m, in " << dir << '\n';

  // The default (anisotropic, OBJ, "v", default adaptivity), then what each choice
  // costs: no "v", binary PLY, a uniform mesh (adaptivity 0, the reference of the
  // adaptive meshes' Hausdorff distances), and the other methods.
  double adaptivity = SurfaceOptions().adaptivity;
  // CASCADE_BENCH_SURFACE_ADAPTIVITY=A sets the adaptivity of the rows at the default.
  if (const char* value = std::getenv("CASCADE_BENCH_SURFACE_ADAPTIVITY")) adaptivity = std::atof(value);
  const std::vector<Config> configs = {
      {"anisotropic", SurfaceMethod::AnisotropicKernels, MeshFormat::Obj, true, adaptivity},
      {"no-v", SurfaceMethod::AnisotropicKernels, MeshFormat::Obj, false, adaptivity},
      {"ply", SurfaceMethod::AnisotropicKernels, MeshFormat::Ply, true, adaptivity},
      {"ply-no-v", SurfaceMethod::AnisotropicKernels, MeshFormat::Ply, false, adaptivity},
      {"uniform", SurfaceMethod::AnisotropicKernels, MeshFormat::Ply, true, 0},
      {"smooth", SurfaceMethod::SmoothSpheres, MeshFormat::Obj, true, adaptivity},
      {"union", SurfaceMethod::UnionOfSpheres, MeshFormat::Obj, true, adaptivity},
  };
  struct Row {
    Config config;
    SurfaceTimings timings;
    double cpu;  // process CPU seconds, all threads: load-independent
    std::size_t triangles;
    double meshMb, vdbMb, hausdorffVoxels;
  };
  std::vector<Row> rows;
  // CASCADE_BENCH_SURFACE=anisotropic,no-v,ply,ply-no-v,uniform,smooth,union,vdb_tool (default: all)
  // picks the rows, for profiling.
  const char* only = std::getenv("CASCADE_BENCH_SURFACE");
  const std::string selected =
      only ? "," + std::string(only) + "," : ",anisotropic,no-v,ply,ply-no-v,uniform,smooth,union,vdb_tool,";
  auto wanted = [&](const std::string& name) { return selected.find("," + name + ",") != std::string::npos; };
  {  // Warm-up (not timed): the first surfacing of a process pays for its page faults.
    SurfaceOptions options;
    options.voxelSize = kVoxel;
    surfaceParticles(points, splash.velocities, kSplashSpacing, options);
  }
  // The anisotropic meshes at the default adaptivity and the uniform one, for the
  // Hausdorff distances (filled in once both exist).
  TriangleMesh uniform, adaptive;
  std::vector<std::size_t> adaptiveRows;
  // CASCADE_BENCH_SURFACE_ROUNDS=N runs the rows N times, in turn, and keeps each row's
  // fastest run (this machine's speed drifts by 10-20 % within minutes).
  int rounds = 1;
  if (const char* value = std::getenv("CASCADE_BENCH_SURFACE_ROUNDS")) rounds = std::clamp(std::atoi(value), 1, 100);
  for (int round = 0; round < rounds; ++round)
  for (std::size_t c = 0, rowIndex = 0; c < configs.size(); ++c) {
    const Config& config = configs[c];
    if (!wanted(config.name)) continue;
    const std::size_t row = rowIndex++;
    SurfaceOptions options;
    options.method = config.method;
    options.voxelSize = kVoxel;
    options.velocity = config.velocity;
    options.adaptivity = config.adaptivity;
    const fs::path meshPath = dir / ("fluid." + meshFormatName(config.format));
    const std::clock_t cpuStart = std::clock();
    SurfaceResult result = surfaceParticles(points, splash.velocities, kSplashSpacing, options, dir / "surface.vdb", meshPath);
    const double cpu = double(std::clock() - cpuStart) / CLOCKS_PER_SEC;
    if (round > 0) {  // a later round: keep the faster
      if (result.timings.total() < rows[row].timings.total()) {
        rows[row].timings = result.timings;
        rows[row].cpu = cpu;
      }
      std::cerr << "bench surface: round " << round + 1 << " " << config.name << " " << milliseconds(result.timings.total())
                << " ms\n";
      fs::remove(meshPath);
      continue;
    }
    if (config.method == SurfaceMethod::AnisotropicKernels) {
      if (config.adaptivity == 0 && uniform.empty()) uniform = result.mesh;
      if (config.adaptivity > 0) {
        if (adaptive.empty()) adaptive = result.mesh;
        adaptiveRows.push_back(rows.size());
      }
    }
    rows.push_back({config, result.timings, cpu, result.mesh.triangles.size(), fs::file_size(meshPath) / 1e6,
                    fs::file_size(dir / "surface.vdb") / 1e6, -1.0});
    const std::string label = surfaceMethodName(config.method) + " " + meshFormatName(config.format) + (config.velocity ? " v" : " no-v") +
                              " adaptivity " + std::to_string(config.adaptivity).substr(0, 4);
    // CASCADE_BENCH_SURFACE_KEEP=DIR keeps the outputs (to compare versions).
    if (const char* keep = std::getenv("CASCADE_BENCH_SURFACE_KEEP")) {
      fs::create_directories(keep);
      std::string stem = label;
      std::replace(stem.begin(), stem.end(), ' ', '_');
      fs::copy_file(dir / "surface.vdb", fs::path(keep) / (stem + ".vdb"), fs::copy_options::overwrite_existing);
      fs::copy_file(meshPath, fs::path(keep) / (stem + meshPath.extension().string()),
                    fs::copy_options::overwrite_existing);
    }
    std::cerr << "bench surface: " << label << ": VDB " << rows.back().vdbMb << " MB (" << result.activeVoxels
              << " active voxels), mesh " << rows.back().meshMb << " MB, " << result.mesh.triangles.size()
              << " triangles\n";
    std::cerr << "bench surface: " << label << " " << milliseconds(result.timings.total())
              << " ms (VDB writer " << milliseconds(result.timings.vdbWrite) << " ms, overlapped); CPU ms by stage: "
              << milliseconds(result.timings.cpu.rasterize) << " " << milliseconds(result.timings.cpu.filter) << " "
              << milliseconds(result.timings.cpu.mesh) << " " << milliseconds(result.timings.cpu.cleanup) << " "
              << milliseconds(result.timings.cpu.write) << "\n";
    fs::remove(meshPath);
  }

  // vdb_tool on the same points, as a PLY file (its own reading and writing included).
  double vdbToolMs = -1, vdbToolCpuMs = -1;
  std::size_t vdbToolTriangles = 0;
  if (wanted("vdb_tool")) {
    ParticleFrame frame;
    frame.position = points;
    writeParticlePly(dir / "pts.ply", frame);
    std::ostringstream command;
    command << "vdb_tool -read " << (dir / "pts.ply").string() << " -points2ls voxel=" << kVoxel
            << " radius=2.0 width=3 -gauss iter=1 size=1 -ls2mesh adapt=0 -write " << (dir / "out.obj").string()
            << " > " << (dir / "vdb_tool.log").string() << " 2>&1";
    const auto start = std::chrono::steady_clock::now();
    struct tms before {}, after {};
    ::times(&before);
    const int status = std::system(command.str().c_str());
    ::times(&after);
    vdbToolCpuMs = 1000.0 * double((after.tms_cutime - before.tms_cutime) + (after.tms_cstime - before.tms_cstime)) /
                   double(::sysconf(_SC_CLK_TCK));
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (status == 0 && fs::exists(dir / "out.obj")) {
      vdbToolMs = milliseconds(seconds);
      vdbToolTriangles = readObj(dir / "out.obj").triangles.size();
    } else {
      std::cerr << "bench surface: vdb_tool failed or is missing (status " << status << ")\n";
    }
  }
  // Hausdorff distance of the adaptive anisotropic mesh from the uniform one (all such
  // rows make the same mesh; 0 without a search where merging did not pay).
  if (!uniform.empty() && !adaptive.empty()) {
    const bool same = adaptive.vertices == uniform.vertices && adaptive.triangles == uniform.triangles;
    const double voxels = same ? 0.0 : std::round(surfacing::hausdorffDistance(adaptive, uniform) / kVoxel * 1000) / 1000;
    for (std::size_t r : adaptiveRows) rows[r].hausdorffVoxels = voxels;
  }
  for (const Row& row : rows) {
    const double total = milliseconds(row.timings.total());
    table.addRow({surfaceMethodName(row.config.method), (long long)points.size(), kVoxel, meshFormatName(row.config.format),
                  (long long)row.config.velocity, row.config.adaptivity, milliseconds(row.timings.rasterize),
                  milliseconds(row.timings.filter), milliseconds(row.timings.mesh), milliseconds(row.timings.cleanup),
                  milliseconds(row.timings.write), total, milliseconds(row.cpu), (long long)row.triangles,
                  std::round(row.meshMb * 10) / 10, std::round(row.vdbMb * 10) / 10, row.hausdorffVoxels,
                  vdbToolMs > 0 ? std::round(vdbToolMs / total * 100) / 100 : 0.0});
  }
  if (wanted("vdb_tool"))
    table.addRow({std::string("vdb_tool"), (long long)points.size(), kVoxel, std::string("obj"), 0LL, 0.0, 0.0, 0.0,
                  0.0, 0.0, 0.0, vdbToolMs, std::round(vdbToolCpuMs), (long long)vdbToolTriangles, -1.0, -1.0, -1.0,
                  1.0});
  fs::remove_all(dir);
  return table;
}

} // namespace cascade::cli
