/// @file ParticleCache.h
/// @brief One output frame of particles on disk (docs/cli.md:
///        OUT/particles/particles.NNNN.vdb, or .ply from other tools).
///
/// The .vdb form is an OpenVDB point data grid named "particles" with the
/// attributes P, v, id, density and pressure (positions and velocities
/// compressed with OpenVDB's codecs, the file with Blosc). The .ply form
/// (read only) takes vertices with float x, y, z and optional vx, vy, vz.
/// OpenVDB headers stay in ParticleCache.cpp.
#pragma once

#include "libsph/Types.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace cascade {

/// The particles of one frame, as arrays in file order.
struct ParticleFrame {
  std::vector<Vec3r> position;
  std::vector<Vec3r> velocity;  ///< empty if the file has none
  std::vector<ParticleId> id;   ///< empty if the file has none
  std::vector<Real> density;    ///< empty if the file has none
  std::vector<Real> pressure;   ///< empty if the file has none
  double time = 0;              ///< simulated time of the frame, s
  Real spacing = 0;             ///< particle spacing of the bake (0 if unknown), m
  std::map<std::string, std::string> metadata;  ///< extra string metadata

  std::size_t size() const { return position.size(); }
  void getPos(std::size_t i, Vec3r& pos) const { pos = position[i]; }
};

/// Writes a frame as an OpenVDB point data grid, atomically (whole or not at all).
/// `voxelSize` sets the point grid's voxel size; 0 picks one from the spacing.
void writeParticleFrame(const std::filesystem::path& path, const ParticleFrame& frame,
                        double voxelSize = 0);

/// Reads a .vdb or .ply frame. A missing, truncated or foreign file throws
/// InputError naming the file.
ParticleFrame readParticleFrame(const std::filesystem::path& path);

/// Writes a frame as a binary little-endian PLY point file (float x, y, z and,
/// when present, vx, vy, vz), atomically: the interchange form other tools read.
void writeParticlePly(const std::filesystem::path& path, const ParticleFrame& frame);

/// Checksum over positions and velocities in id order (FNV-1a over the raw
/// float bits), the one `cascade inspect` prints; equal frames give equal sums.
std::uint64_t particleChecksum(const ParticleFrame& frame);

} // namespace cascade
