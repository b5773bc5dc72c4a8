#include "surfacing/LevelSetFiltering.h"

#include "surfacing/detail/LeafNeighborhoods.h"
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

using LeafT = detail::FloatLeaf;
using detail::LeafNeighborhoods;
constexpr int D = detail::kLeafDim;
constexpr int P = detail::kPaddedDim;

inline float sq(float value) { return value * value; }

/// One step of mean curvature flow on the active voxels: phi += dt kappa |grad phi|,
/// dt = dx^2 / 3 (OpenVDB LevelSetFilter's step); kappa |grad phi| as OpenVDB's
/// CurvatureStencil::meanCurvatureNormGrad (index-space differences, so with
/// dt the update is alpha / (6 |grad phi|^2)).
void meanCurvatureStep(const LeafNeighborhoods& band, const std::vector<LeafT*>& leaves) {
  band.apply(leaves, [&](std::size_t i, const float (&f)[P][P][P], float* out) {
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
void renormalizeStep(const LeafNeighborhoods& band, const std::vector<LeafT*>& leaves, float background,
                     float voxelSize) {
  const float dt = 0.3f * voxelSize, inverseDx = 1.0f / voxelSize;
  band.apply(leaves, [&](std::size_t i, const float (&f)[P][P][P], float* out) {
    LeafT& leaf = *leaves[i];
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
    const LeafNeighborhoods band(grid.tree());
    std::vector<LeafT*> leaves;
    grid.tree().getNodes(leaves);
    profile.lap("filter: neighbourhoods");
    if (filter == SurfaceFilter::MeanCurvature && passes > 0) {
      for (int pass = 0; pass < passes; ++pass) {
        meanCurvatureStep(band, leaves);
        profile.lap("filter: mean curvature");
        renormalizeStep(band, leaves, background, voxelSize);
        profile.lap("filter: renormalize");
      }
    } else {
      renormalizeStep(band, leaves, background, voxelSize);
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
