// `cascade bench surface`: ~0.9 M particles of a splash (a pool, a collapsing
// column with a crown sheet, 150 k airborne droplets; spacing 0.006 m) surfaced
// by each method, timed by stage, and, in the same run, OpenVDB's vdb_tool
// (Debian libopenvdb-tools) on the same points for the ratio (issue 5).
#include "Benchmarks.h"

#include "libsph/io/ParticleCache.h"
#include "libsph/io/TriangleMesh.h"
#include "surfacing/SurfaceStage.h"

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
constexpr double kSpacing = 0.006;
constexpr double kVoxel = 0.003;

/// The splash: deterministic, about 0.9 M particles.
std::vector<Vec3r> splashParticles() {
  std::vector<Vec3r> points;
  std::mt19937 random(20261121);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto jitter = [&] { return (unit(random) - 0.5) * 0.1 * kSpacing; };
  auto add = [&](double x, double y, double z) {
    points.emplace_back(Real(x + jitter()), Real(y + jitter()), Real(z + jitter()));
  };
  const double s = kSpacing;
  // Pool: 1.2 x 0.75 m, 15.4 cm deep, with a ring wave.
  const double poolX = 1.2, poolY = 0.75, poolDepth = 0.154;
  const Vec3d columnCenter(0.6, 0.375, 0);
  for (double x = 0.5 * s; x < poolX; x += s)
    for (double y = 0.5 * s; y < poolY; y += s) {
      const double r = std::hypot(x - columnCenter.x(), y - columnCenter.y());
      const double depth = poolDepth + 0.02 * std::exp(-std::pow((r - 0.3) / 0.06, 2));  // ring wave
      for (double z = 0.5 * s; z < depth; z += s) add(x, y, z);
    }
  // Collapsing column: a cylinder whose foot spreads out, on top of the pool.
  for (double z = poolDepth + 0.5 * s; z < poolDepth + 0.54; z += s) {
    const double radius = 0.09 + 0.12 * std::exp(-(z - poolDepth) / 0.05);
    for (double x = -radius; x <= radius; x += s)
      for (double y = -radius; y <= radius; y += s)
        if (x * x + y * y <= radius * radius) add(columnCenter.x() + x, columnCenter.y() + y, z);
  }
  // Crown: a thin sheet (one particle thick) rising from the ring wave.
  for (double z = poolDepth + 0.026; z < poolDepth + 0.156; z += s) {
    const double radius = 0.3 + 0.4 * (z - poolDepth - 0.026);
    const int n = int(2 * M_PI * radius / s);
    for (int i = 0; i < n; ++i) {
      const double a = 2 * M_PI * (i + 0.5 * (int(z / s) % 2)) / n;
      add(columnCenter.x() + radius * std::cos(a), columnCenter.y() + radius * std::sin(a), z);
    }
  }
  // 150 k airborne droplets around the column: single particles and small clusters.
  std::size_t droplets = 0;
  while (droplets < 150000) {
    const double a = 2 * M_PI * unit(random), r = 0.1 + 0.45 * unit(random);
    const double height = poolDepth + 0.036 + 0.45 * unit(random) * (1 - 0.6 * r);
    const double x = columnCenter.x() + r * std::cos(a), y = columnCenter.y() + r * std::sin(a);
    const int size = unit(random) < 0.7 ? 1 : 2 + int(6 * unit(random));
    for (int k = 0; k < size && droplets < 150000; ++k, ++droplets)
      add(x + (k % 2) * s, y + ((k / 2) % 2) * s, height + (k / 4) * s);
  }
  return points;
}

double milliseconds(double seconds) { return std::round(seconds * 1e4) / 10; }

} // namespace

BenchTable benchSurface() {
  BenchTable table("surface", {"method", "n_particles", "voxel_size", "rasterize_ms", "filter_ms", "mesh_ms",
                               "cleanup_ms", "write_ms", "total_ms", "cpu_ms", "triangles", "vs_vdb_tool"});
  const std::vector<Vec3r> points = splashParticles();
  const fs::path dir = fs::temp_directory_path() / ("cascade_bench_surface_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::cerr << "bench surface: " << points.size() << " particles, voxel " << kVoxel << " m, in " << dir << '\n';

  struct Row {
    std::string method;
    SurfaceTimings timings;
    double cpu;  // process CPU seconds, all threads: load-independent
    std::size_t triangles;
  };
  std::vector<Row> rows;
  // CASCADE_BENCH_SURFACE=anisotropic,smooth,union,vdb_tool (default: all) picks the rows, for profiling.
  const char* only = std::getenv("CASCADE_BENCH_SURFACE");
  const std::string selected = only ? "," + std::string(only) + "," : ",anisotropic,smooth,union,vdb_tool,";
  auto wanted = [&](const std::string& name) { return selected.find("," + name + ",") != std::string::npos; };
  for (SurfaceMethod method :
       {SurfaceMethod::AnisotropicKernels, SurfaceMethod::SmoothSpheres, SurfaceMethod::UnionOfSpheres}) {
    if (!wanted(surfaceMethodName(method))) continue;
    SurfaceOptions options;
    options.method = method;
    options.voxelSize = kVoxel;
    // CASCADE_BENCH_SURFACE_ADAPTIVITY=A overrides the volumeToMesh adaptivity (for comparisons).
    if (const char* adaptivity = std::getenv("CASCADE_BENCH_SURFACE_ADAPTIVITY")) options.adaptivity = std::atof(adaptivity);
    const std::clock_t cpuStart = std::clock();
    SurfaceResult result = surfaceParticles(points, kSpacing, options, dir / "surface.vdb", dir / "fluid.obj");
    const double cpu = double(std::clock() - cpuStart) / CLOCKS_PER_SEC;
    rows.push_back({surfaceMethodName(method), result.timings, cpu, result.mesh.triangles.size()});
    // CASCADE_BENCH_SURFACE_KEEP=DIR keeps the outputs as DIR/METHOD.vdb and .obj (to compare versions).
    if (const char* keep = std::getenv("CASCADE_BENCH_SURFACE_KEEP")) {
      fs::create_directories(keep);
      for (const char* name : {"surface.vdb", "fluid.obj"})
        fs::copy_file(dir / name, fs::path(keep) / (rows.back().method + fs::path(name).extension().string()),
                      fs::copy_options::overwrite_existing);
    }
    std::cerr << "bench surface: " << rows.back().method << " files: VDB " << fs::file_size(dir / "surface.vdb") / 1e6
              << " MB (" << result.activeVoxels << " active voxels), OBJ " << fs::file_size(dir / "fluid.obj") / 1e6
              << " MB\n";
    std::cerr << "bench surface: " << rows.back().method << " " << milliseconds(result.timings.total())
              << " ms (VDB writer " << milliseconds(result.timings.vdbWrite) << " ms, overlapped); CPU ms by stage: "
              << milliseconds(result.timings.cpu.rasterize) << " " << milliseconds(result.timings.cpu.filter) << " "
              << milliseconds(result.timings.cpu.mesh) << " " << milliseconds(result.timings.cpu.cleanup) << " "
              << milliseconds(result.timings.cpu.write) << "\n";
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
  for (const Row& row : rows) {
    const double total = milliseconds(row.timings.total());
    table.addRow({row.method, (long long)points.size(), kVoxel, milliseconds(row.timings.rasterize),
                  milliseconds(row.timings.filter), milliseconds(row.timings.mesh),
                  milliseconds(row.timings.cleanup), milliseconds(row.timings.write), total,
                  milliseconds(row.cpu), (long long)row.triangles, vdbToolMs > 0 ? std::round(vdbToolMs / total * 100) / 100 : 0.0});
  }
  if (wanted("vdb_tool"))
    table.addRow({std::string("vdb_tool"), (long long)points.size(), kVoxel, 0.0, 0.0, 0.0, 0.0, 0.0, vdbToolMs,
                  std::round(vdbToolCpuMs), (long long)vdbToolTriangles, 1.0});
  fs::remove_all(dir);
  return table;
}

} // namespace cascade::cli
