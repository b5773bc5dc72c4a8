#include "libsph/NeighborSearch.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>


namespace cascade {

void BruteForceSearch::build(const Vec3r* points, std::size_t count, Real maxSupportRadius) {
  mPoints = points;
  mCount = count;
  mRadius = maxSupportRadius;
}

void BruteForceSearch::query(const Vec3r* queries, std::size_t count, const Real* supportRadii,
                             bool excludeSelf, NeighborLists& out) const {
  std::vector<std::vector<std::uint32_t>> perQuery(count);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count), [&](const auto& range) {
    for (std::size_t q = range.begin(); q != range.end(); ++q) {
      const Real radius = supportRadii ? supportRadii[q] : mRadius;
      const Real radius2 = radius * radius;
      for (std::size_t p = 0; p < mCount; ++p) {
        if (excludeSelf && p == q) continue;
        if (squaredDistance(queries[q], mPoints[p]) <= radius2)
          perQuery[q].push_back(static_cast<std::uint32_t>(p));
      }
    }
  });
  assembleNeighborLists(perQuery, out);
}

void assembleNeighborLists(const std::vector<std::vector<std::uint32_t>>& perQuery,
                           NeighborLists& out) {
  out.offsets.resize(perQuery.size() + 1);
  out.offsets[0] = 0;
  out.ends.clear();
  out.order.clear();
  for (std::size_t q = 0; q < perQuery.size(); ++q)
    out.offsets[q + 1] = out.offsets[q] + static_cast<std::uint32_t>(perQuery[q].size());
  out.indices.resize(out.offsets.back());
  tbb::parallel_for(std::size_t(0), perQuery.size(), [&](std::size_t q) {
    std::copy(perQuery[q].begin(), perQuery[q].end(), out.indices.begin() + out.offsets[q]);
  });
}

} // namespace cascade
