#include "distributed/SlabDecomposition.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace cascade::distributed {

int SlabDecomposition::ownerOf(Real coordinate) const {
  return int(std::upper_bound(cuts.begin(), cuts.end(), coordinate) - cuts.begin());
}

void SlabDecomposition::ranksWithin(Real coordinate, Real halo, int& first, int& last) const {
  // Slab r is [cut_{r-1}, cut_r): it comes within halo of c when cut_r > c - halo and cut_{r-1} <= c + halo.
  first = int(std::upper_bound(cuts.begin(), cuts.end(), coordinate - halo) - cuts.begin());
  last = int(std::upper_bound(cuts.begin(), cuts.end(), coordinate + halo) - cuts.begin());
}

std::vector<Real> balancedCuts(std::vector<Real> coordinates, int rankCount) {
  std::vector<Real> cuts;
  if (rankCount < 2) return cuts;
  std::sort(coordinates.begin(), coordinates.end());
  const std::size_t n = coordinates.size();
  for (int r = 1; r < rankCount; ++r) {
    const std::size_t k = n * std::size_t(r) / std::size_t(rankCount);
    if (n == 0) {
      cuts.push_back(Real(0));
    } else if (k == 0) {
      cuts.push_back(coordinates.front());
    } else if (k >= n) {
      cuts.push_back(std::nextafter(coordinates.back(), std::numeric_limits<Real>::infinity()));
    } else {
      const Real below = coordinates[k - 1], above = coordinates[k];
      cuts.push_back(below == above ? above : below + Real(0.5) * (above - below));
    }
  }
  return cuts;
}

std::size_t histogramBin(Real coordinate, Real lo, Real hi, std::size_t binCount) {
  if (!(hi > lo)) return 0;
  const double f = (double(coordinate) - double(lo)) / (double(hi) - double(lo)) * double(binCount);
  if (!(f > 0)) return 0;
  return std::min(binCount - 1, std::size_t(f));
}

std::vector<Real> balancedCutsFromHistogram(const std::vector<std::uint64_t>& bins, Real lo, Real hi,
                                            int rankCount) {
  std::vector<Real> cuts;
  const std::uint64_t total = std::accumulate(bins.begin(), bins.end(), std::uint64_t(0));
  const double width = (double(hi) - double(lo)) / double(std::max<std::size_t>(bins.size(), 1));
  std::uint64_t running = 0;
  std::size_t bin = 0;
  for (int r = 1; r < rankCount; ++r) {
    const std::uint64_t target = total * std::uint64_t(r) / std::uint64_t(rankCount);
    while (bin < bins.size() && running + bins[bin] <= target) running += bins[bin++];
    // Bins [0, bin) hold at most the target; the cut goes at the edge nearer to it.
    std::size_t edge = bin;
    if (bin < bins.size() && target - running > running + bins[bin] - target) edge = bin + 1;
    cuts.push_back(Real(double(lo) + width * double(edge)));
  }
  return cuts;
}

bool unbalanced(const std::vector<std::uint64_t>& counts, double tolerance) {
  if (counts.size() < 2) return false;
  const double total = double(std::accumulate(counts.begin(), counts.end(), std::uint64_t(0)));
  const double mean = total / double(counts.size());
  const auto [smallest, largest] = std::minmax_element(counts.begin(), counts.end());
  return total >= double(counts.size()) &&
         (double(*largest) > (1 + tolerance) * mean || double(*smallest) < (1 - tolerance) * mean);
}

int slabAxis(const Vec3r& lo, const Vec3r& hi, const Vec3r& gravity) {
  int down = 2;
  gravity.cwiseAbs().maxCoeff(&down);
  if (!(gravity.squaredNorm() > 0)) down = -1;
  int best = 0;
  Real extent = -1;
  for (int a = 0; a < 3; ++a) {
    if (a == down) continue;
    const Real e = hi[a] - lo[a];
    if (e > extent) extent = e, best = a;
  }
  return best;
}

} // namespace cascade::distributed
