// `cascade bench render`: time per preview still at 1280x720 with 4x
// multisampling, for a 100 k and a 1 M triangle fluid mesh (a wavy
// latitude-longitude sphere) with an obstacle (a box tower) on a floor.
// Columns: triangles, width, height, samples, ms_per_frame; plus
// cpu_ms_per_frame (process CPU time per still, all threads: on a shared
// machine the wall time can exceed it by the time spent waiting for a core)
// and upload_ms/draw_ms are not separated: a still is mesh upload, five
// passes, read back (render/PreviewRenderer.h). PNG writing is not timed.
#include "Benchmarks.h"

#include "render/MeshPrimitives.h"
#include "render/PreviewRenderer.h"

#include <chrono>
#include <cmath>
#include <ctime>
#include <iostream>

namespace cascade::cli {

BenchTable benchRender() {
  using namespace cascade::render;
  BenchTable table("render", {"triangles", "width", "height", "samples", "ms_per_frame", "cpu_ms_per_frame"});
  const int width = 1280, height = 720, samples = 4, repeats = 3;
  PreviewRenderer renderer(width, height, samples);
  std::cerr << "bench render: " << renderer.glDescription() << ", " << renderer.effectiveSamples()
            << " samples per pixel\n";
  TriangleMesh solids = makeBox({-0.8f, -0.5f, -0.02f}, {0.8f, 0.5f, 0.0f}, "floor");
  appendMesh(solids, makeBox({0.32f, -0.1f, 0.0f}, {0.5f, 0.1f, 0.6f}, "tower"));
  for (const int target : {100000, 1000000}) {
    // 2 * segments * (rings - 1) triangles with segments = 2 rings.
    const int rings = int(std::lround(std::sqrt(target / 4.0))) + 1;
    const TriangleMesh fluid = makeLatLongSphere({-0.1f, 0.0f, 0.3f}, 0.28f, rings, 2 * rings, 0.12f);
    FrameScene scene;
    scene.fluid = &fluid;
    scene.solids = &solids;
    scene.camera.position = {0.9f, -1.6f, 0.9f};
    scene.camera.target = {0.0f, 0.0f, 0.25f};
    scene.camera.fovY = 40;
    renderer.render(scene);  // warm-up: shader variants, buffer sizes
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t cpuStart = std::clock();
    for (int i = 0; i < repeats; ++i) renderer.render(scene);
    const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    const double cpu = 1000.0 * double(std::clock() - cpuStart) / CLOCKS_PER_SEC;
    table.addRow({static_cast<long long>(fluid.triangles.size() + solids.triangles.size()),
                  static_cast<long long>(width), static_cast<long long>(height), static_cast<long long>(samples),
                  wall / repeats, cpu / repeats});
  }
  return table;
}

} // namespace cascade::cli
