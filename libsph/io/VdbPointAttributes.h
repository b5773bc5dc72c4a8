/// @file VdbPointAttributes.h
/// @brief Fills an attribute of an OpenVDB point data grid from an array given
///        in the order of the positions the grid was made from (the order its
///        point index tree refers to). For the .cpp files that write OpenVDB
///        points (particle caches, whitewater).
#pragma once

#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointDataGrid.h>
#include <openvdb/tools/PointIndexGrid.h>

#include <vector>

namespace cascade {

template <typename T>
void populatePointAttribute(openvdb::points::PointDataTree& tree, const openvdb::tools::PointIndexTree& indexTree,
                            const char* name, const std::vector<T>& values) {
  openvdb::points::PointAttributeVector<T> wrapper(values);
  openvdb::points::populateAttribute(tree, indexTree, name, wrapper);
}

} // namespace cascade
