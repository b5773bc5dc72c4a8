#include "libsph/boundary/BoundarySampling.h"

#include "libsph/NeighborSearch.h"

#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace cascade {

void removeDuplicateSamples(std::vector<Vec3r>& samples, Real tolerance, std::vector<std::size_t>* kept) {
  if (kept) {
    kept->resize(samples.size());
    for (std::size_t k = 0; k < samples.size(); ++k) (*kept)[k] = k;
  }
  if (samples.empty() || tolerance <= 0) return;
  if (kept) kept->clear();
  // Hash cells of edge `tolerance`; a duplicate lies in one of the 27 cells around.
  const double inv = 1.0 / double(tolerance);
  auto key = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return (std::uint64_t(x) * 73856093ULL) ^ (std::uint64_t(y) * 19349663ULL) ^
           (std::uint64_t(z) * 83492791ULL);
  };
  std::unordered_multimap<std::uint64_t, std::size_t> cells;
  cells.reserve(samples.size() * 2);
  std::vector<Vec3r> unique;
  unique.reserve(samples.size());
  const Real tolerance2 = tolerance * tolerance;
  for (std::size_t k = 0; k < samples.size(); ++k) {
    const Vec3r& p = samples[k];
    const std::int64_t cx = std::int64_t(std::floor(p.x() * inv));
    const std::int64_t cy = std::int64_t(std::floor(p.y() * inv));
    const std::int64_t cz = std::int64_t(std::floor(p.z() * inv));
    bool duplicate = false;
    for (int dz = -1; dz <= 1 && !duplicate; ++dz)
      for (int dy = -1; dy <= 1 && !duplicate; ++dy)
        for (int dx = -1; dx <= 1 && !duplicate; ++dx) {
          auto range = cells.equal_range(key(cx + dx, cy + dy, cz + dz));
          for (auto it = range.first; it != range.second; ++it)
            if (squaredDistance(unique[it->second], p) < tolerance2) { duplicate = true; break; }
        }
    if (duplicate) continue;
    cells.emplace(key(cx, cy, cz), unique.size());
    unique.push_back(p);
    if (kept) kept->push_back(k);
  }
  samples.swap(unique);
}

} // namespace cascade
