/// @file SurfaceStage.h
/// @brief The surfacing stage: particle caches to OpenVDB narrow-band level sets
///        and triangle meshes (docs/cli.md layout).
///
/// For every frame of a range, OUT/particles/particles.NNNN.vdb (or .ply) is
/// turned into OUT/surface/surface.NNNN.vdb (a level set grid named "surface",
/// class GRID_LEVEL_SET, voxel size in its transform; a vector grid "v", the
/// fluid velocity over the band, when the particles carry velocities; optionally
/// a "density" fog grid, and a "foam" fog grid from OUT/whitewater) and OUT/mesh/fluid.NNNN.obj or .ply (triangles with
/// outward per-vertex normals; the PLY also with per-vertex velocities).
/// Pipeline per frame:
///   1. rasterize the particles into a narrow-band level set with one of the
///      methods below (surfacing/LevelSetMethods.h says what each computes), and
///      their velocities into "v" with the same kernel weights;
///   2. filter the level set (mean curvature passes, leaf-parallel, or Gaussian
///      or Laplacian passes with OpenVDB LevelSetFilter; LevelSetFiltering.h);
///   3. mesh it (OpenVDB volumeToMesh with adaptivity);
///   4. clean the mesh (surfacing/MeshCleanup.h: degenerate faces, small
///      components, outward orientation, optional CGAL remeshing or
///      decimation to a triangle budget, normals), and sample "v" at its
///      vertices (trilinear).
/// The voxel lattice is world aligned (voxel centres at integer multiples of
/// the voxel size), so consecutive frames do not shimmer. Frames are
/// independent and run in parallel (TBB), each parallel inside; the output
/// depends only on the input and the options.
///
/// Axes (scenes are z-up): the mesh is written y-up by default, a scene point
/// (x, y, z) stored as (x, z, -y) with an "up: y" header comment, so Blender's and
/// Houdini's default OBJ imports show it upright (meshYUp = false keeps scene
/// axes, "up: z"); the VDB keeps the scene's z-up coordinates by default,
/// which Blender shows upright (vdbYUp = true rotates its transform for Houdini).
///
/// This header has no OpenVDB or CGAL includes, so any stage can call it.
#pragma once

#include "libsph/Types.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/io/TriangleMesh.h"
#include "libsph/scene/Scene.h"

#include <cstddef>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace cascade {

/// How particles become a level set.
enum class SurfaceMethod {
  UnionOfSpheres,      ///< OpenVDB ParticlesToLevelSet: union of spheres
  SmoothSpheres,       ///< Zhu & Bridson 2005: distance to the weighted mean of neighbours
  AnisotropicKernels,  ///< Yu & Turk 2013: density of anisotropic kernels (default)
};

/// Level-set filter applied `smoothingPasses` times.
enum class SurfaceFilter { None, MeanCurvature, Gaussian, Laplacian };

/// "union", "smooth", "anisotropic" <-> SurfaceMethod; throws InputError on an unknown name.
SurfaceMethod parseSurfaceMethod(const std::string& name);
std::string surfaceMethodName(SurfaceMethod method);
/// The fluid mesh's file format.
enum class MeshFormat {
  Obj,  ///< Wavefront OBJ, ASCII: v, vn, f (every tool reads it; no velocities)
  Ply,  ///< PLY, binary little-endian: x y z nx ny nz vx vy vz, faces
};
/// "obj", "ply" <-> MeshFormat; throws InputError on an unknown name.
MeshFormat parseMeshFormat(const std::string& name);
std::string meshFormatName(MeshFormat format);

/// "none", "mean-curvature", "gaussian", "laplacian" <-> SurfaceFilter.
SurfaceFilter parseSurfaceFilter(const std::string& name);
std::string surfaceFilterName(SurfaceFilter filter);

struct SurfaceOptions {
  /// Voxel edge (m). 0: half the particle spacing (ParticleFrame::spacing, else
  /// the median nearest-neighbour distance of the frame).
  double voxelSize = 0;
  /// Particle spacing (m) to use when > 0, overriding the cache's.
  double particleSpacing = 0;
  /// Particle radius (m). 0: the method's default, a multiple of the spacing
  /// chosen so that a flat lattice of particles keeps its volume (union of
  /// spheres: 1.0 spacing, as vdb_tool's radius=2 voxels; smooth spheres:
  /// calibrated; anisotropic: the iso-value is calibrated instead).
  double particleRadius = 0;
  SurfaceMethod method = SurfaceMethod::AnisotropicKernels;
  SurfaceFilter filter = SurfaceFilter::MeanCurvature;
  int smoothingPasses = 1;
  /// volumeToMesh adaptivity in [0, 1]: 0 uniform, 1 fully adaptive (LevelSetMesher.h
  /// bounds its error; scene::kDefaultMeshAdaptivity says why this default).
  double adaptivity = scene::kDefaultMeshAdaptivity;
  /// If > 0, decimate (CGAL edge collapse) meshes with more triangles than this.
  std::size_t triangleBudget = 0;
  /// If > 0, isotropic remeshing (CGAL) to this target edge length (m).
  double remeshEdgeLength = 0;
  /// Drop mesh components whose enclosed volume is below this (m^3).
  /// < 0: the volume of one particle (spacing^3) / 8.
  double minComponentVolume = -1;
  /// Narrow-band half width, voxels.
  int halfWidth = 3;
  bool writeVdb = true;      ///< OUT/surface/surface.NNNN.vdb ("surface" grid)
  bool writeDensity = false; ///< also a "density" fog grid in that file
  /// Also a "foam" fog grid in that file, from OUT/whitewater (FoamDensity.h):
  /// foam particles per spacing^3. surfaceFrames() reads the frame's whitewater file.
  bool foamDensity = false;
  bool writeMesh = true;     ///< OUT/mesh/fluid.NNNN.obj or .ply
  MeshFormat meshFormat = MeshFormat::Obj;
  /// The "v" grid and per-vertex mesh velocities, when the particles have velocities.
  bool velocity = true;
  /// Write mesh vertices, normals and velocities y-up ((x, y, z) -> (x, z, -y)), so
  /// that importers assuming y-up show the z-up scene upright. See docs/surfacing.md, "Axes".
  bool meshYUp = true;
  /// Give the VDB a y-up transform (a lattice rotation, for Houdini); default z-up
  /// (Blender reads VDB coordinates as they are).
  bool vdbYUp = false;
  /// Blosc-compress the VDB's voxel values on top of OpenVDB's active-mask
  /// compression (OpenVDB's own default). Off by default: on surfacing level
  /// sets it saves ~3 % of the file and costs about a second of writing per
  /// 0.9 M-particle frame; readers need no option either way.
  bool vdbBlosc = false;
  bool force = false;        ///< rewrite outputs that already exist
};

/// Seconds spent per stage of one frame. The VDB is written by a thread of its
/// own while the mesh is extracted, cleaned and written, so `write` is the time
/// the frame spent writing after the clean-up (the OBJ, and waiting for the VDB
/// if it was not done yet) and total() is the frame's wall time; `vdbWrite` is
/// how long the VDB writer ran (overlapped, not part of total()).
struct SurfaceTimings {
  double rasterize = 0, filter = 0, mesh = 0, cleanup = 0, write = 0;
  double vdbWrite = 0;
  /// Process CPU seconds (all threads) during each stage; the VDB writer's count
  /// in the stages it overlapped (mesh, cleanup, write).
  struct Cpu {
    double rasterize = 0, filter = 0, mesh = 0, cleanup = 0, write = 0;
  } cpu;
  double total() const { return rasterize + filter + mesh + cleanup + write; }
};

/// What surfacing one set of particles produced (in memory).
struct SurfaceResult {
  TriangleMesh mesh;           ///< cleaned, outward normals, z-up world coordinates; velocities with "v"
  bool hasVelocity = false;    ///< a "v" grid was made
  double voxelSize = 0;
  double particleSpacing = 0;
  std::size_t activeVoxels = 0;
  SurfaceTimings timings;
};

/// The least memory a frame's level set takes, bytes: a band two voxels thick (one on
/// each side of the zero crossing; the narrow band is wider) over the least surface enclosing the particles' volume (particles x spacing^3, a
/// sphere's), 4 bytes a voxel (16 with the velocity grid). A lower bound, so a frame
/// refused for it could never have fitted (surfaceParticles throws InputError).
double leastSurfaceBytes(std::size_t particles, double spacing, double voxelSize, bool velocity);

/// Surfaces particle positions (and, if not empty and options.velocity, their
/// velocities) in memory and, if `vdbPath` is not empty, writes the level set (and
/// "v", density, and with `foam` the "foam" grid of those foam particles) there
/// atomically; if `meshPath` is not empty, also the mesh (writeSurfaceMesh with
/// options.meshYUp, the format by the path's extension). `spacing` 0 means estimate it.
/// A frame that cannot fit in the available memory (leastSurfaceBytes) is an InputError.
SurfaceResult surfaceParticles(const std::vector<Vec3r>& positions, const std::vector<Vec3r>& velocities,
                               double spacing, const SurfaceOptions& options,
                               const std::filesystem::path& vdbPath = {},
                               const std::filesystem::path& meshPath = {},
                               const std::vector<Vec3r>* foam = nullptr);
/// The same without velocities.
SurfaceResult surfaceParticles(const std::vector<Vec3r>& positions, double spacing,
                               const SurfaceOptions& options,
                               const std::filesystem::path& vdbPath = {},
                               const std::filesystem::path& meshPath = {});

/// Writes a mesh as OBJ or PLY (by the path's extension), atomically, y-up
/// ((x, y, z) -> (x, z, -y)) if `yUp`, with an "up: y|z" header comment.
void writeSurfaceMesh(const std::filesystem::path& path, const TriangleMesh& mesh, bool yUp);

/// One frame's outcome in surfaceFrames().
struct SurfaceFrameReport {
  int frame = 0;
  bool skipped = false;   ///< outputs already complete and not forced
  std::string error;      ///< one-line error if the frame failed
  bool badInput = false;  ///< the error was bad input (exit 2)
  std::size_t particles = 0, triangles = 0;
  SurfaceTimings timings;
};

/// Surfaces the frames of `range` found in OUT/particles (.vdb preferred over .ply
/// for the same number). Frames run in parallel; a frame whose cache is missing,
/// truncated or foreign gets its error in the report while the others still
/// surface. `progress` (may be empty) is called after each frame, serially.
std::vector<SurfaceFrameReport> surfaceFrames(
    const OutputLayout& layout, const FrameRange& range, const SurfaceOptions& options,
    const std::function<void(const SurfaceFrameReport&)>& progress = {});

} // namespace cascade
