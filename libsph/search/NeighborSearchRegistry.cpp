// makeNeighborSearch(), neighborSearchMethods() and zOrderPermutation() of
// libsph/NeighborSearch.h: the one place that knows every search method by name.
#include "libsph/NeighborSearch.h"
#include "libsph/search/OctreeSearch.h"
#include "libsph/search/UniformGridSearch.h"

#include <stdexcept>

namespace cascade {

std::vector<std::string> neighborSearchMethods() { return {"brute", "grid", "octree"}; }

std::unique_ptr<NeighborSearch> makeNeighborSearch(const std::string& method) {
  if (method == "brute") return std::make_unique<BruteForceSearch>();
  if (method == "grid") return std::make_unique<search::UniformGridSearch>();
  if (method == "octree") return std::make_unique<search::OctreeSearch>();
  throw std::invalid_argument("unknown neighbour search method '" + method + "'");
}

std::vector<std::size_t> zOrderPermutation(const Vec3r* points, std::size_t count, Real cellSize) {
  search::UniformGridSearch grid;
  grid.setIncrementalBuild(false);
  grid.build(points, count, cellSize);
  return grid.zOrder();
}

} // namespace cascade
