#include "surfacing/LevelSetFiltering.h"

#include <openvdb/tools/LevelSetFilter.h>

namespace cascade::surfacing {

void filterLevelSet(openvdb::FloatGrid& grid, SurfaceFilter filter, int passes) {
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
