/// @file DeformingTestSequences.h
/// @brief OBJ sequences for the deforming-mesh tests: a box whose corners move
///        frame by frame, written as "NAME.####.obj" in a folder.
#pragma once

#include "BodyTestScenes.h"

#include "libsph/bodies/DeformingMesh.h"
#include "libsph/io/TriangleMesh.h"

#include <filesystem>
#include <functional>
#include <string>

namespace cascade::test {

/// Writes frames first..last of a box sequence: frame k is the box [lo(k), hi(k)].
/// Returns the pattern ("DIR/NAME.####.obj").
inline std::string writeBoxSequence(const std::filesystem::path& dir, const std::string& name, int first, int last,
                                    const std::function<void(int, Vec3r&, Vec3r&)>& boxOfFrame) {
  const std::string pattern = (dir / (name + ".####.obj")).string();
  for (int k = first; k <= last; ++k) {
    Vec3r lo, hi;
    boxOfFrame(k, lo, hi);
    writeObj(sequenceFramePath(pattern, k), boxMesh(lo, hi));
  }
  return pattern;
}

} // namespace cascade::test
