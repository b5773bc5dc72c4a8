// `cascade bench neighbors`: build and query times of every neighbour search
// method on a dam-break block (a jittered lattice column, height = 2 x width as
// in Martin & Moyce's n^2 = 2), support radius 2.1 spacings (about 30-40
// neighbours per particle), 10k, 100k and 1M particles.
//
// The particles are first put in Z-order (Particles::permute(zOrder()), as the
// solver does every few steps); each time is the best of several repetitions
// (the machine is shared; stderr also shows the CPU time of all threads, which
// the other jobs on the machine do not stretch). Rows:
//   <method>              full build() from scratch + self query() with lists;
//   grid-incremental      build() after every particle moved by up to 0.05
//                         spacing (a time step), reusing the previous order;
//   octree-bucket8        the octree with leaves of up to 8 particles (the
//                         faithful "octree" splits to one particle per leaf);
//   *-variable-h          every particle with its own support radius, drawn in
//                         [0.5, 1] x the radius (gather form; the grid's cells
//                         stay sized for the largest).
// Brute force runs up to 100k only, and is skipped (a row says so) when its
// time estimated from 10k passes a minute.
//
// Memory traffic: `bytes_per_particle` is what a build and self query must move at
// least, each once: the positions read (12 bytes), the grid's sorted copy written
// (positions and index, 16), the lists written (4 per neighbour and 4 for the
// offset; the other methods' rows count the same, as the least any search moves).
// `gb_per_s` is that over the build and query time, and `stream_share` its
// share of the machine's measured memory rate (a triad a = b + s c over 3 x 64 MB on
// every thread, best of 5, printed first): how near the search is to being memory bound.
#include "Benchmarks.h"

#include "libsph/NeighborSearch.h"
#include "libsph/search/OctreeSearch.h"
#include "libsph/search/UniformGridSearch.h"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>
#include <random>

namespace cascade::cli {

namespace {

/// CPU time of the whole process (all threads), ms: shows the work done when
/// the shared machine's other jobs stretch the wall-clock times.
double processCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

/// A dam-break column of about `target` particles: width m, depth m, height 2m.
std::vector<Vec3r> damBreakBlock(std::size_t target, Real spacing, unsigned seed) {
  int m = 1;
  while (2.0 * double(m + 1) * (m + 1) * (m + 1) <= double(target)) ++m;
  if (std::abs(2.0 * (m + 1) * (m + 1) * (m + 1) - double(target)) <
      std::abs(2.0 * m * m * m - double(target)))
    ++m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<Real> jitter(-Real(0.1) * spacing, Real(0.1) * spacing);
  std::vector<Vec3r> points;
  points.reserve(std::size_t(2) * m * m * m);
  for (int k = 0; k < 2 * m; ++k)
    for (int j = 0; j < m; ++j)
      for (int i = 0; i < m; ++i)
        points.emplace_back(i * spacing + jitter(rng), j * spacing + jitter(rng),
                            k * spacing + jitter(rng));
  return points;
}

void zOrderPoints(std::vector<Vec3r>& points, Real radius) {
  search::UniformGridSearch grid;
  grid.build(points.data(), points.size(), radius);
  const auto order = grid.zOrder();
  std::vector<Vec3r> sorted(points.size());
  for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = points[order[k]];
  points.swap(sorted);
}

/// The machine's memory rate, GB/s: a[i] = b[i] + s c[i] over three 64 MB arrays on every
/// thread, 24 bytes per element (the writes' line fills not counted), best of 5.
double streamTriadRate() {
  const std::size_t n = std::size_t(8) << 20;
  std::vector<double> a(n, 0.0), b(n, 1.0), c(n, 2.0);
  double best = 1e300;
  for (int r = 0; r < 5; ++r) {
    const auto start = std::chrono::steady_clock::now();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1 << 16), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i) a[i] = b[i] + 3.0 * c[i];
    });
    best = std::min(best, millisecondsSince(start));
  }
  if (a[n / 2] != 7.0) return 0.0;  // (uses the result)
  return 24.0 * double(n) / (best * 1e-3) / 1e9;
}

struct Timing {
  double buildMs = 1e300, queryMs = 1e300;
  double buildCpuMs = 1e300, queryCpuMs = 1e300;
  std::size_t pairs = 0;
};

} // namespace

BenchTable benchNeighbors() {
  BenchTable table("neighbors", {"method", "n", "build_ms", "query_ms", "ns_per_particle",
                                 "neighbors_per_particle", "bytes_per_particle", "gb_per_s", "stream_share"});
  const double stream = streamTriadRate();
  std::fprintf(stderr, "  memory rate (triad, all threads): %.1f GB/s\n", stream);
  const Real spacing = Real(0.01);
  const Real radius = Real(2.1) * spacing;
  const std::size_t sizes[] = {10000, 100000, 1000000};
  double bruteMs = 0;
  std::size_t bruteN = 0;

  auto addRow = [&](const std::string& method, std::size_t n, const Timing& t) {
    const double neighbors = double(t.pairs) / double(n);
    const double bytes = 12.0 + 16.0 + 4.0 * neighbors + 4.0;  // positions in, sorted copy, lists out
    const double rate = bytes * double(n) / ((t.buildMs + t.queryMs) * 1e-3) / 1e9;
    table.addRow({method, static_cast<long long>(n), t.buildMs, t.queryMs,
                  (t.buildMs + t.queryMs) * 1e6 / double(n), neighbors, bytes, rate,
                  stream > 0 ? rate / stream : 0.0});
    std::fprintf(stderr, "  %-18s n=%-8zu build %.2f ms (cpu %.2f), query %.2f ms (cpu %.2f)\n",
                 method.c_str(), n, t.buildMs, t.buildCpuMs, t.queryMs, t.queryCpuMs);
  };

  for (const std::size_t target : sizes) {
    std::vector<Vec3r> points = damBreakBlock(target, spacing, 1);
    zOrderPoints(points, radius);
    const std::size_t n = points.size();
    const int repetitions = n <= 100000 ? 7 : 5;

    // Variable smoothing length (SEED 2.1): each particle's support radius
    // drawn in [0.5, 1] x radius; the grid is built with the largest.
    std::vector<Real> radii(n);
    {
      std::mt19937 rng(3);
      std::uniform_real_distribution<Real> factor(Real(0.5), Real(1));
      for (auto& r : radii) r = factor(rng) * radius;
    }

    // Full build + query, best of `repetitions`.
    auto measure = [&](NeighborSearch& search, int reps, const Real* queryRadii = nullptr) {
      Timing t;
      NeighborLists lists;
      for (int r = 0; r < reps; ++r) {
        double cpu = processCpuMs();
        auto start = std::chrono::steady_clock::now();
        search.build(points.data(), n, radius);
        t.buildMs = std::min(t.buildMs, millisecondsSince(start));
        t.buildCpuMs = std::min(t.buildCpuMs, processCpuMs() - cpu);
        cpu = processCpuMs();
        start = std::chrono::steady_clock::now();
        search.query(points.data(), n, queryRadii, true, lists);
        t.queryMs = std::min(t.queryMs, millisecondsSince(start));
        t.queryCpuMs = std::min(t.queryCpuMs, processCpuMs() - cpu);
      }
      t.pairs = lists.totalCount();
      return t;
    };

    if (target <= 100000) {
      // All pairs: capped when the estimate from the last size passes a minute.
      const double estimateMs =
          bruteN ? bruteMs * double(n) * double(n) / (double(bruteN) * double(bruteN)) : 0.0;
      if (estimateMs > 60000.0) {
        const double nan = std::numeric_limits<double>::quiet_NaN();
        table.addRow({"brute (skipped: estimated " + std::to_string(int(estimateMs / 1000)) + " s > 60 s)",
                      static_cast<long long>(n), nan, nan, nan, nan, nan, nan, nan});
      } else {
        BruteForceSearch brute;
        const Timing t = measure(brute, n <= 10000 ? 3 : 1);
        bruteMs = t.buildMs + t.queryMs;
        bruteN = n;
        addRow("brute", n, t);
      }
    }
    {
      search::UniformGridSearch grid;
      grid.setIncrementalBuild(false);
      addRow("grid", n, measure(grid, repetitions));
    }
    {
      // One time step: every particle moves by up to 0.05 spacing per axis.
      search::UniformGridSearch grid;
      std::vector<Vec3r> moved = points;
      std::mt19937 rng(2);
      std::uniform_real_distribution<Real> step(-Real(0.05) * spacing, Real(0.05) * spacing);
      for (auto& p : moved) p += Vec3r(step(rng), step(rng), step(rng));
      Timing t;
      NeighborLists lists;
      for (int r = 0; r < repetitions; ++r) {
        grid.build(points.data(), n, radius);
        double cpu = processCpuMs();
        auto start = std::chrono::steady_clock::now();
        grid.build(moved.data(), n, radius);
        t.buildMs = std::min(t.buildMs, millisecondsSince(start));
        t.buildCpuMs = std::min(t.buildCpuMs, processCpuMs() - cpu);
        cpu = processCpuMs();
        start = std::chrono::steady_clock::now();
        grid.query(moved.data(), n, nullptr, true, lists);
        t.queryMs = std::min(t.queryMs, millisecondsSince(start));
        t.queryCpuMs = std::min(t.queryCpuMs, processCpuMs() - cpu);
      }
      t.pairs = lists.totalCount();
      addRow(grid.lastBuildWasIncremental() ? "grid-incremental" : "grid-incremental(fell back)", n, t);
    }
    {
      search::OctreeSearch octree;
      addRow("octree", n, measure(octree, repetitions));
    }
    {
      search::OctreeSearch octree(8);
      addRow("octree-bucket8", n, measure(octree, repetitions));
    }
    {
      search::UniformGridSearch grid;
      grid.setIncrementalBuild(false);
      addRow("grid-variable-h", n, measure(grid, repetitions, radii.data()));
      search::OctreeSearch octree;
      addRow("octree-variable-h", n, measure(octree, repetitions, radii.data()));
      search::OctreeSearch bucket(8);
      addRow("octree-bucket8-variable-h", n, measure(bucket, repetitions, radii.data()));
    }
  }
  return table;
}

} // namespace cascade::cli
