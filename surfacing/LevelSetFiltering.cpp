#include "surfacing/LevelSetFiltering.h"

#include "surfacing/detail/Profile.h"

#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace cascade::surfacing {

namespace {

using LeafT = openvdb::FloatTree::LeafNodeType;
constexpr int D = LeafT::DIM;  // 8
constexpr int P = D + 2;       // padded by one voxel on each side
static_assert(D == 8, "leaf offsets below are (x << 6) | (y << 3) | z");

inline float sq(float value) { return value * value; }

/// The leaves of a tree with, for each, its 26 neighbours (or the tile value
/// that stands in for a missing one).
struct LeafNeighborhoods {
  std::vector<LeafT*> leaves;
  std::vector<std::array<const LeafT*, 27>> neighbor;  // index (dx+1)*9 + (dy+1)*3 + (dz+1)
  std::vector<std::array<float, 27>> tileValue;

  explicit LeafNeighborhoods(openvdb::FloatTree& tree) {
    tree.getNodes(leaves);
    neighbor.resize(leaves.size());
    tileValue.resize(leaves.size());
    const openvdb::FloatTree& constTree = tree;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 64), [&](const auto& range) {
      openvdb::tree::ValueAccessor<const openvdb::FloatTree> accessor(constTree);
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        const openvdb::Coord origin = leaves[i]->origin();
        for (int n = 0; n < 27; ++n) {
          const openvdb::Coord at = origin.offsetBy((n / 9 - 1) * D, (n / 3 % 3 - 1) * D, (n % 3 - 1) * D);
          const LeafT* leaf = n == 13 ? leaves[i] : accessor.probeConstLeaf(at);
          neighbor[i][n] = leaf;
          tileValue[i][n] = leaf ? 0.0f : accessor.getValue(at);
        }
      }
    });
  }

  /// Values of leaf i and one voxel layer of its neighbours: padded[x + 1][y + 1][z + 1].
  void gather(std::size_t i, float (&padded)[P][P][P]) const {
    for (int n = 0; n < 27; ++n) {
      const int ox = n / 9 - 1, oy = n / 3 % 3 - 1, oz = n % 3 - 1;
      // Source range inside the neighbour and destination start in the padded block, per axis.
      auto range = [](int o, int& from, int& to, int& destination) {
        if (o < 0) from = D - 1, to = D, destination = 0;
        else if (o == 0) from = 0, to = D, destination = 1;
        else from = 0, to = 1, destination = D + 1;
      };
      int x0, x1, dx, y0, y1, dy, z0, z1, dz;
      range(ox, x0, x1, dx);
      range(oy, y0, y1, dy);
      range(oz, z0, z1, dz);
      const LeafT* leaf = neighbor[i][n];
      if (leaf) {
        const float* v = leaf->buffer().data();
        for (int x = x0; x < x1; ++x)
          for (int y = y0; y < y1; ++y)
            for (int z = z0; z < z1; ++z) padded[dx + x - x0][dy + y - y0][dz + z - z0] = v[(x << 6) | (y << 3) | z];
      } else {
        const float value = tileValue[i][n];
        for (int x = x0; x < x1; ++x)
          for (int y = y0; y < y1; ++y)
            for (int z = z0; z < z1; ++z) padded[dx + x - x0][dy + y - y0][dz + z - z0] = value;
      }
    }
  }

  /// Runs step(i, padded, out) on every leaf, then copies the outputs into the leaves.
  template <class Step>
  void apply(const Step& step) {
    std::vector<float> out(leaves.size() * LeafT::SIZE);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 16), [&](const auto& range) {
      float padded[P][P][P];
      for (std::size_t i = range.begin(); i != range.end(); ++i) {
        gather(i, padded);
        step(i, padded, out.data() + i * LeafT::SIZE);
      }
    });
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, leaves.size(), 64), [&](const auto& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i)
        std::copy_n(out.data() + i * LeafT::SIZE, LeafT::SIZE, leaves[i]->buffer().data());
    });
  }
};

/// One step of mean curvature flow on the active voxels: phi += dt kappa |grad phi|,
/// dt = dx^2 / 3 (OpenVDB LevelSetFilter's step); kappa |grad phi| as OpenVDB's
/// CurvatureStencil::meanCurvatureNormGrad (index-space differences, so with
/// dt the update is alpha / (6 |grad phi|^2)).
void meanCurvatureStep(LeafNeighborhoods& band) {
  band.apply([&](std::size_t i, const float (&f)[P][P][P], float* out) {
    const LeafT& leaf = *band.leaves[i];
    for (int x = 1; x <= D; ++x)
      for (int y = 1; y <= D; ++y)
        for (int z = 1; z <= D; ++z) {
          const int offset = ((x - 1) << 6) | ((y - 1) << 3) | (z - 1);
          const float phi = f[x][y][z];
          out[offset] = phi;
          if (!leaf.valueMask().isOn(offset)) continue;
          const float Dx = 0.5f * (f[x + 1][y][z] - f[x - 1][y][z]);
          const float Dy = 0.5f * (f[x][y + 1][z] - f[x][y - 1][z]);
          const float Dz = 0.5f * (f[x][y][z + 1] - f[x][y][z - 1]);
          const float Dx2 = Dx * Dx, Dy2 = Dy * Dy, Dz2 = Dz * Dz, normGrad2 = Dx2 + Dy2 + Dz2;
          if (normGrad2 <= 1e-8f * 1e-8f) continue;  // OpenVDB: Tolerance<double>
          const float Dxx = f[x + 1][y][z] - 2 * phi + f[x - 1][y][z];
          const float Dyy = f[x][y + 1][z] - 2 * phi + f[x][y - 1][z];
          const float Dzz = f[x][y][z + 1] - 2 * phi + f[x][y][z - 1];
          const float Dxy = 0.25f * (f[x + 1][y + 1][z] - f[x - 1][y + 1][z] - f[x + 1][y - 1][z] + f[x - 1][y - 1][z]);
          const float Dxz = 0.25f * (f[x + 1][y][z + 1] - f[x - 1][y][z + 1] - f[x + 1][y][z - 1] + f[x - 1][y][z - 1]);
          const float Dyz = 0.25f * (f[x][y + 1][z + 1] - f[x][y - 1][z + 1] - f[x][y + 1][z - 1] + f[x][y - 1][z - 1]);
          const float alpha = Dx2 * (Dyy + Dzz) + Dy2 * (Dxx + Dzz) + Dz2 * (Dxx + Dyy) -
                              2 * (Dx * (Dy * Dxy + Dz * Dxz) + Dy * Dz * Dyz);
          out[offset] = phi + alpha / (6 * normGrad2);
        }
  });
}

/// One renormalisation step (Sussman, Smereka & Osher 1994) on the band dilated by
/// one voxel, then the band trimmed to |phi| < background: inactive voxels hold
/// +-background.
void renormalizeStep(LeafNeighborhoods& band, float background, float voxelSize) {
  const float dt = 0.3f * voxelSize, inverseDx = 1.0f / voxelSize;
  band.apply([&](std::size_t i, const float (&f)[P][P][P], float* out) {
    LeafT& leaf = *band.leaves[i];
    for (int x = 1; x <= D; ++x)
      for (int y = 1; y <= D; ++y)
        for (int z = 1; z <= D; ++z) {
          const int offset = ((x - 1) << 6) | ((y - 1) << 3) | (z - 1);
          const float phi = f[x][y][z];
          const float xm = f[x - 1][y][z], xp = f[x + 1][y][z], ym = f[x][y - 1][z], yp = f[x][y + 1][z],
                      zm = f[x][y][z - 1], zp = f[x][y][z + 1];
          const bool inBand =
              std::min({std::abs(phi), std::abs(xm), std::abs(xp), std::abs(ym), std::abs(yp), std::abs(zm),
                        std::abs(zp)}) < background;  // active, or a face neighbour of an active voxel
          float value = phi > 0 ? background : -background;
          if (inBand) {
            // Godunov's upwind |grad phi|^2, first-order one-sided differences (index space).
            const float dxm = phi - xm, dxp = xp - phi, dym = phi - ym, dyp = yp - phi, dzm = phi - zm,
                        dzp = zp - phi;
            float norm2;
            if (phi > 0)
              norm2 = std::max(sq(std::max(dxm, 0.0f)), sq(std::min(dxp, 0.0f))) +
                      std::max(sq(std::max(dym, 0.0f)), sq(std::min(dyp, 0.0f))) +
                      std::max(sq(std::max(dzm, 0.0f)), sq(std::min(dzp, 0.0f)));
            else
              norm2 = std::max(sq(std::min(dxm, 0.0f)), sq(std::max(dxp, 0.0f))) +
                      std::max(sq(std::min(dym, 0.0f)), sq(std::max(dyp, 0.0f))) +
                      std::max(sq(std::min(dzm, 0.0f)), sq(std::max(dzp, 0.0f)));
            const float sign = phi / (std::sqrt(phi * phi + norm2) + 1e-7f);
            value = phi - dt * sign * (std::sqrt(norm2) * inverseDx - 1.0f);
          }
          const bool on = std::abs(value) < background;
          out[offset] = on ? value : (value > 0 ? background : -background);
          leaf.setActiveState(openvdb::Index(offset), on);  // own mask only: neighbours read values
        }
  });
}

} // namespace

void filterLevelSet(openvdb::FloatGrid& grid, SurfaceFilter filter, int passes) {
  if (filter == SurfaceFilter::Gaussian || filter == SurfaceFilter::Laplacian) {
    filterLevelSetOpenVdb(grid, filter, passes);
    return;
  }
  detail::ProfileClock profile;
  const float background = grid.background();
  const float voxelSize = float(grid.voxelSize()[0]);
  {
    LeafNeighborhoods band(grid.tree());
    profile.lap("filter: neighbourhoods");
    if (filter == SurfaceFilter::MeanCurvature && passes > 0) {
      for (int pass = 0; pass < passes; ++pass) {
        meanCurvatureStep(band);
        profile.lap("filter: mean curvature");
        renormalizeStep(band, background, voxelSize);
        profile.lap("filter: renormalize");
      }
    } else {
      renormalizeStep(band, background, voxelSize);
      profile.lap("filter: renormalize");
    }
  }
  openvdb::tools::pruneLevelSet(grid.tree());
  profile.lap("filter: prune");
}

void filterLevelSetOpenVdb(openvdb::FloatGrid& grid, SurfaceFilter filter, int passes) {
  openvdb::tools::LevelSetFilter<openvdb::FloatGrid> levelSetFilter(grid);
  levelSetFilter.setSpatialScheme(openvdb::math::FIRST_BIAS);
  levelSetFilter.setTemporalScheme(openvdb::math::TVD_RK1);
  levelSetFilter.setNormCount(1);  // one Eikonal iteration after each pass
  levelSetFilter.setGrainSize(1);
  if (filter == SurfaceFilter::None || passes <= 0) {
    levelSetFilter.track();
    return;
  }
  for (int pass = 0; pass < passes; ++pass) {
    switch (filter) {
      case SurfaceFilter::MeanCurvature: levelSetFilter.meanCurvature(); break;
      case SurfaceFilter::Gaussian: levelSetFilter.gaussian(1); break;
      case SurfaceFilter::Laplacian: levelSetFilter.laplacian(); break;
      case SurfaceFilter::None: break;
    }
  }
}

} // namespace cascade::surfacing
