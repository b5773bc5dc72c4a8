// `cascade surface OUT [--frames A-B] [surfacing options]` (docs/cli.md): defaults
// from OUT/scene.json's "surface" block, overridden by the options given.
#include "Commands.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/scene/SceneJson.h"
#include "surfacing/SurfaceStage.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <set>
#include <sstream>

namespace cascade::cli {

namespace {

struct SurfaceCommandOptions {
  std::string out;
  std::string frames;
  std::string method = "anisotropic";
  std::string filter = "mean-curvature";
  std::string meshFormat = "obj";
  SurfaceOptions surface;
  bool noVdb = false, noMesh = false, meshZUp = false, noVelocity = false;
};

template <class T>
void requireAtLeast(const char* option, T value, T minimum) {
  if (value < minimum) {
    std::ostringstream message;
    message << option << ": must be >= " << minimum << " (got " << value << ")";
    throw InputError(message.str());
  }
}

/// The defaults of OUT/scene.json's "surface" block, for every option not given
/// on the command line (`command`). No scene file (caches from another tool): none.
void applySceneDefaults(SurfaceCommandOptions& options, const CLI::App& command) {
  const OutputLayout layout(options.out);
  std::error_code error;
  if (!std::filesystem::is_regular_file(layout.scene(), error)) return;
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(readTextFile(layout.scene()));
  } catch (const nlohmann::json::exception& failure) {
    throw InputError(layout.scene().string() + ": not valid JSON (" + failure.what() + ")");
  }
  if (!document.is_object() || !document.contains("surface") || document["surface"].is_null()) return;
  const scene::SurfaceSettings settings = scene::parseSurfaceSettings(document["surface"], layout.scene().string());
  auto given = [&](const char* option) { return command.count(option) > 0; };
  if (!given("--method")) options.method = settings.method;
  if (!given("--mesh-format")) options.meshFormat = settings.meshFormat;
  if (!given("--no-vdb") && !given("--no-mesh")) {
    options.noVdb = settings.outputs == "mesh";
    options.noMesh = settings.outputs == "vdb";
  }
  if (!given("--no-velocity")) options.noVelocity = !settings.velocity;
  if (!given("--adaptivity")) options.surface.adaptivity = settings.adaptivity;
  if (!given("--mesh-z-up")) options.meshZUp = settings.meshUp == "z";
  if (!given("--foam-density")) options.surface.foamDensity = settings.foamDensity;
}

void runSurface(SurfaceCommandOptions& options) {
  SurfaceOptions& surface = options.surface;
  surface.method = parseSurfaceMethod(options.method);
  surface.filter = parseSurfaceFilter(options.filter);
  surface.meshFormat = parseMeshFormat(options.meshFormat);
  requireAtLeast("--voxel-size", surface.voxelSize, 0.0);
  requireAtLeast("--spacing", surface.particleSpacing, 0.0);
  requireAtLeast("--radius", surface.particleRadius, 0.0);
  requireAtLeast("--smoothing", surface.smoothingPasses, 0);
  requireAtLeast("--half-width", surface.halfWidth, 2);
  requireAtLeast("--remesh", surface.remeshEdgeLength, 0.0);
  if (surface.adaptivity < 0 || surface.adaptivity > 1) {
    std::ostringstream message;
    message << "--adaptivity: must be in [0, 1] (got " << surface.adaptivity << ")";
    throw InputError(message.str());
  }
  surface.writeVdb = !options.noVdb;
  surface.writeMesh = !options.noMesh;
  surface.meshYUp = !options.meshZUp;
  surface.velocity = !options.noVelocity;
  const FrameRange range = options.frames.empty() ? FrameRange{} : parseFrameRange(options.frames);
  const OutputLayout layout(options.out);
  if (!std::filesystem::is_directory(layout.root))
    throw InputError(layout.root.string() + ": no such output directory");

  const auto start = std::chrono::steady_clock::now();
  std::size_t done = 0, failed = 0, badInput = 0, total = 0;
  auto progress = [&](const SurfaceFrameReport& report) {
    ++done;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!report.error.empty()) {
      ++failed;
      if (report.badInput) ++badInput;
      std::cerr << report.error << '\n';
      return;
    }
    char line[256];
    if (report.skipped)
      std::snprintf(line, sizeof line, "surface: frame %s [%zu/%zu] skipped (outputs exist; --force redoes)",
                    OutputLayout::pad(report.frame).c_str(), done, total);
    else
      std::snprintf(line, sizeof line,
                    "surface: frame %s [%zu/%zu] %zu particles -> %zu triangles in %.2f s, ETA %.0f s",
                    OutputLayout::pad(report.frame).c_str(), done, total, report.particles, report.triangles,
                    report.timings.total(), total > done ? elapsed / double(done) * double(total - done) : 0.0);
    std::cerr << line << std::endl;
  };
  // Count the frames first for the progress lines (surfaceFrames decides the set).
  if (range.first && range.last) total = std::size_t(*range.last - *range.first + 1);
  else {
    std::set<int> frames;
    for (const char* extension : {"vdb", "ply"})
      for (int frame : listFrames(layout.particlesDir(), "particles", extension))
        if (range.contains(frame)) frames.insert(frame);
    total = frames.size();
  }
  surfaceFrames(layout, range, surface, progress);
  if (failed > 0) {
    std::ostringstream message;
    message << layout.root.string() << ": " << failed << " of " << total << " frames not surfaced";
    if (badInput == failed) throw InputError(message.str());
    throw std::runtime_error(message.str());
  }
}

} // namespace

void addSurfaceCommand(CLI::App& app) {
  auto options = std::make_shared<SurfaceCommandOptions>();
  SurfaceOptions& s = options->surface;
  CLI::App* command = app.add_subcommand(
      "surface", "Surface particle caches: OUT/particles -> OUT/surface/*.vdb level sets and OUT/mesh/*.obj|ply");
  command->add_option("OUT", options->out, "Output directory of a bake (reads OUT/particles)")->required();
  command->add_option("--frames", options->frames, "Frame range A-B (inclusive, 1-based); default all");
  command->add_option("--method", options->method,
                      "Level set: union (of spheres) | smooth (spheres, Zhu-Bridson 2005) | anisotropic (Yu-Turk 2013)")
      ->capture_default_str();
  command->add_option("--voxel-size", s.voxelSize, "Voxel edge, m (default: half the particle spacing)");
  command->add_option("--spacing", s.particleSpacing,
                      "Particle spacing, m (default: from the cache, else the median nearest-neighbour distance)");
  command->add_option("--radius", s.particleRadius, "Particle radius, m (default: the method's calibrated one)");
  command->add_option("--filter", options->filter, "Level-set filter: none | mean-curvature | gaussian | laplacian")
      ->capture_default_str();
  command->add_option("--smoothing", s.smoothingPasses, "Number of filter passes")->capture_default_str();
  command->add_option("--adaptivity", s.adaptivity,
                      "Mesh adaptivity in [0, 1]: merge flat cells within 0.45 voxel (0: uniform)")
      ->capture_default_str();
  command->add_option("--triangles", s.triangleBudget, "Triangle budget: decimate (CGAL) meshes above it (0: off)");
  command->add_option("--remesh", s.remeshEdgeLength, "Isotropic remeshing (CGAL) to this edge length, m (0: off)");
  command->add_option("--min-volume", s.minComponentVolume,
                      "Drop mesh pieces enclosing less than this, m^3 (default: 1/8 particle volume)");
  command->add_option("--half-width", s.halfWidth, "Narrow-band half width, voxels")->capture_default_str();
  command->add_flag("--density", s.writeDensity, "Also write a \"density\" fog grid (Blender renders fog)");
  command->add_flag("--foam-density", s.foamDensity,
                    "Also write a \"foam\" fog grid from OUT/whitewater (foam particles per spacing^3)");
  command->add_option("--mesh-format", options->meshFormat,
                      "Mesh file: obj (ASCII, no velocities) | ply (binary, with per-vertex velocities)")
      ->capture_default_str();
  command->add_flag("--no-vdb", options->noVdb, "Do not write OUT/surface/*.vdb (mesh only)");
  command->add_flag("--no-mesh,--no-obj", options->noMesh, "Do not write OUT/mesh/* (VDB only)");
  command->add_flag("--no-velocity", options->noVelocity,
                    "Do not write the \"v\" velocity grid and per-vertex mesh velocities");
  command->add_flag("--mesh-z-up,--obj-z-up", options->meshZUp,
                    "Write the mesh in the scene's z-up axes (default y-up: (x, y, z) -> (x, z, -y))");
  command->add_flag("--vdb-y-up", s.vdbYUp, "Give the VDB a y-up transform (for Houdini; default z-up)");
  command->add_flag("--vdb-blosc", s.vdbBlosc,
                    "Also Blosc-compress the VDB voxel values (a few % smaller, much slower to write)");
  command->add_flag("--force", s.force, "Redo frames whose outputs exist");
  command->callback([options, command] {
    applySceneDefaults(*options, *command);
    runSurface(*options);
  });
}

} // namespace cascade::cli
