// libFuzzer harness: the mesh readers: Cascade's OBJ and PLY readers (TriangleMesh.h,
// what `cascade inspect` and `render` read) and the obstacle loader (assimp,
// MeshBoundary.h) on OBJ, PLY and STL. A bad file must end in InputError; a mesh
// that reads must index only its own vertices.
#include "FuzzInput.h"

#include "libsph/Errors.h"
#include "libsph/boundary/MeshBoundary.h"
#include "libsph/io/TriangleMesh.h"

#include <cstdlib>

namespace {
void check(const cascade::TriangleMesh& mesh) {
  for (const auto& triangle : mesh.triangles)
    for (std::uint32_t v : triangle)
      if (v >= mesh.vertices.size()) std::abort();
  if (!mesh.normals.empty() && mesh.normals.size() != mesh.vertices.size()) std::abort();
  if (!mesh.velocities.empty() && mesh.velocities.size() != mesh.vertices.size()) std::abort();
}
} // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace cascade;
  const auto attempt = [](auto&& read) {
    try {
      check(read());
    } catch (const InputError&) {
    }
  };
  attempt([&] { return readObj(fuzz::asFile(data, size, ".obj")); });
  attempt([&] { return readPly(fuzz::asFile(data, size, ".ply")); });
  for (const char* extension : {".obj", ".ply", ".stl"})
    attempt([&] { return loadMeshFile(fuzz::asFile(data, size, extension)); });
  return 0;
}
