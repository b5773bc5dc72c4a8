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

using openvdb::Index;

/// One leaf of meanCurvatureStep, from its padded values `f` into `out`. Compiled
/// for AVX2 and for the baseline (the same IEEE operations, so the same bits).
__attribute__((target_clones("avx2", "default")))
void meanCurvatureLeaf(const float (&f)[P][P][P], float* out, const LeafT::NodeMaskType& mask) {
  for (int x = 1; x <= D; ++x)
    for (int y = 1; y <= D; ++y) {
      const float *c = &f[x][y][1], *xm = &f[x - 1][y][1], *xp = &f[x + 1][y][1], *ym = &f[x][y - 1][1],
                  *yp = &f[x][y + 1][1];
      const float *xmym = &f[x - 1][y - 1][1], *xmyp = &f[x - 1][y + 1][1], *xpym = &f[x + 1][y - 1][1],
                  *xpyp = &f[x + 1][y + 1][1];
      float updated[D];
      for (int z = 0; z < D; ++z) {
        const float Dx = 0.5f * (xp[z] - xm[z]), Dy = 0.5f * (yp[z] - ym[z]), Dz = 0.5f * (c[z + 1] - c[z - 1]);
        const float Dx2 = Dx * Dx, Dy2 = Dy * Dy, Dz2 = Dz * Dz, normGrad2 = Dx2 + Dy2 + Dz2;
        const float Dxx = xp[z] - 2 * c[z] + xm[z], Dyy = yp[z] - 2 * c[z] + ym[z], Dzz = c[z + 1] - 2 * c[z] + c[z - 1];
        const float Dxy = 0.25f * (xpyp[z] - xmyp[z] - xpym[z] + xmym[z]);
        const float Dxz = 0.25f * (xp[z + 1] - xm[z + 1] - xp[z - 1] + xm[z - 1]);
        const float Dyz = 0.25f * (yp[z + 1] - ym[z + 1] - yp[z - 1] + ym[z - 1]);
        const float alpha = Dx2 * (Dyy + Dzz) + Dy2 * (Dxx + Dzz) + Dz2 * (Dxx + Dyy) -
                            2 * (Dx * (Dy * Dxy + Dz * Dxz) + Dy * Dz * Dyz);
        const bool flat = normGrad2 <= 1e-16f;  // OpenVDB: no update below Tolerance<double>
        updated[z] = flat ? c[z] : c[z] + alpha / (6 * (flat ? 1.0f : normGrad2));
      }
      // Inactive voxels keep their value.
      const unsigned rowBits = unsigned(mask.getWord<std::uint64_t>(Index(x - 1)) >> ((y - 1) << 3)) & 0xffu;
      float* o = out + (((x - 1) << 6) | ((y - 1) << 3));
      for (int z = 0; z < D; ++z) o[z] = (rowBits >> z) & 1u ? updated[z] : c[z];
    }
}

/// One step of mean curvature flow on the active voxels: phi += dt kappa |grad phi|,
/// dt = dx^2 / 3 (OpenVDB LevelSetFilter's step); kappa |grad phi| as OpenVDB's
/// CurvatureStencil::meanCurvatureNormGrad (index-space differences, so with
/// dt the update is alpha / (6 |grad phi|^2)).
void meanCurvatureStep(const LeafNeighborhoods& band, const std::vector<LeafT*>& leaves,
                       std::vector<LeafT::Buffer>& scratch) {
  band.apply(leaves, scratch, [&](std::size_t i, const float (&f)[P][P][P], float* out) {
    meanCurvatureLeaf(f, out, band.leaves[i]->valueMask());
  });
}

/// One renormalisation step (Sussman, Smereka & Osher 1994) of one leaf, from its
/// padded values `f` into `out`; sets the bits of the new active voxels
/// (|phi| < background) in `mask`.
/// Compiled for AVX2 and for the baseline; both give the same bits (no FMA
/// contraction: -ffp-contract=off, and the same IEEE operations).
__attribute__((target_clones("avx2", "default")))
void renormalizeLeaf(const float (&f)[P][P][P], float* out, LeafT::NodeMaskType& mask, float background,
                     float dt, float inverseDx) {
  for (int x = 1; x <= D; ++x)
    for (int y = 1; y <= D; ++y) {
      const float* c = &f[x][y][1];
      const float *xm = &f[x - 1][y][1], *xp = &f[x + 1][y][1], *ym = &f[x][y - 1][1], *yp = &f[x][y + 1][1];
      float* o = out + (((x - 1) << 6) | ((y - 1) << 3));
      // Active (|phi| < background), or a face neighbour of an active voxel.
      float nearest[D];
      for (int z = 0; z < D; ++z)
        nearest[z] = std::min(std::min(std::min(std::abs(c[z]), std::abs(xm[z])), std::min(std::abs(xp[z]), std::abs(ym[z]))),
                              std::min(std::abs(yp[z]), std::min(std::abs(c[z - 1]), std::abs(c[z + 1]))));
      float rowNearest = background;
      for (int z = 0; z < D; ++z) rowNearest = std::min(rowNearest, nearest[z]);
      if (rowNearest >= background) {  // the row is outside the band: +-background, inactive
        for (int z = 0; z < D; ++z) o[z] = c[z] > 0 ? background : -background;
        continue;
      }
      // Every voxel computed, then selected: no branch in the loop, so it vectorises.
      for (int z = 0; z < D; ++z) {
        const float phi = c[z];
        // Godunov's upwind |grad phi|^2, first-order one-sided differences (index space):
        // outside max(D-, 0)^2 vs min(D+, 0)^2, inside the other way round.
        const float s = phi > 0 ? 1.0f : -1.0f;
        const float ax = std::max(s * (phi - xm[z]), 0.0f), bx = std::min(s * (xp[z] - phi), 0.0f);
        const float ay = std::max(s * (phi - ym[z]), 0.0f), by = std::min(s * (yp[z] - phi), 0.0f);
        const float az = std::max(s * (phi - c[z - 1]), 0.0f), bz = std::min(s * (c[z + 1] - phi), 0.0f);
        const float norm2 = std::max(ax * ax, bx * bx) + std::max(ay * ay, by * by) + std::max(az * az, bz * bz);
        const float sign = phi / (std::sqrt(phi * phi + norm2) + 1e-7f);
        const float step = phi - dt * sign * (std::sqrt(norm2) * inverseDx - 1.0f);
        const float value = nearest[z] < background ? step : s * background;
        o[z] = std::min(std::max(value, -background), background);  // the band's limits
      }
      std::uint64_t rowBits = 0;
      for (int z = 0; z < D; ++z) rowBits |= std::uint64_t(std::abs(o[z]) < background) << z;
      mask.getWord<std::uint64_t>(Index(x - 1)) |= rowBits << ((y - 1) << 3);
    }
}

/// One renormalisation step on the band dilated by one voxel, then the band
/// trimmed to |phi| < background: inactive voxels hold +-background.
void renormalizeStep(const LeafNeighborhoods& band, const std::vector<LeafT*>& leaves,
                     std::vector<LeafT::Buffer>& scratch, float background, float voxelSize) {
  const float dt = 0.3f * voxelSize, inverseDx = 1.0f / voxelSize;
  band.apply(leaves, scratch, [&](std::size_t i, const float (&f)[P][P][P], float* out) {
    LeafT::NodeMaskType mask;
    renormalizeLeaf(f, out, mask, background, dt, inverseDx);
    leaves[i]->setValueMask(mask);  // own mask only: neighbours read values
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
    std::vector<LeafT::Buffer> scratch;
    profile.lap("filter: neighbourhoods");
    if (filter == SurfaceFilter::MeanCurvature && passes > 0) {
      for (int pass = 0; pass < passes; ++pass) {
        meanCurvatureStep(band, leaves, scratch);
        profile.lap("filter: mean curvature");
        renormalizeStep(band, leaves, scratch, background, voxelSize);
        profile.lap("filter: renormalize");
      }
    } else {
      renormalizeStep(band, leaves, scratch, background, voxelSize);
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
