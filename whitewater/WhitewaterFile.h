/// @file WhitewaterFile.h
/// @brief One frame of whitewater on disk: OUT/whitewater/whitewater.NNNN.vdb,
///        an OpenVDB point data grid named "whitewater" (docs/whitewater.md).
///
/// Attributes: P (16-bit fixed point in its voxel), v (float, m/s), id (int32),
/// type (int32: 0 spray, 1 foam, 2 bubble) and age (float, s). Grid metadata:
/// cascade_time (s), cascade_next_id (the id the next birth gets),
/// cascade_spacing (the bake's particle spacing, m) and cascade_input_hash (the
/// settings and bake it was made from). The file is the stage's state: a run
/// resumed at frame k continues from what whitewater.k.vdb holds, so a resumed
/// run and an unbroken one write the same particles. The optional PLY form
/// (binary little-endian points with x y z vx vy vz id type age) is for Blender,
/// which reads no VDB points. OpenVDB headers stay in WhitewaterFile.cpp.
#pragma once

#include "whitewater/DiffuseParticles.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace cascade::whitewater {

struct WhitewaterFrame {
  DiffuseParticles particles;
  std::vector<DiffuseType> type;  ///< per particle
  double time = 0;                ///< s
  std::uint32_t nextId = 0;
  double spacing = 0;             ///< the bake's particle spacing, m
  std::string inputHash;

  /// Particles of each type, indexed by DiffuseType.
  std::array<std::size_t, kDiffuseTypeCount> counts() const;
};

/// Writes atomically (whole or not at all).
void writeWhitewaterVdb(const std::filesystem::path& path, const WhitewaterFrame& frame);
/// Reads a whitewater VDB; a missing, truncated or foreign file throws InputError naming it.
WhitewaterFrame readWhitewaterVdb(const std::filesystem::path& path);
/// Only the metadata (time, next id, spacing, input hash) and, from the type
/// attribute, the counts; throws like readWhitewaterVdb.
WhitewaterFrame readWhitewaterHeader(const std::filesystem::path& path);
/// Rounds positions as writing and reading a whitewater VDB does (P in 16-bit
/// fixed point within voxels of 2 spacings): readWhitewaterVdb of a file written
/// from `frame` holds exactly these positions. So a run can go on from a frame
/// in memory while its file is written, and still equal a run resumed from it.
void roundPositionsAsStored(WhitewaterFrame& frame);
/// Writes the PLY point form, atomically.
void writeWhitewaterPly(const std::filesystem::path& path, const WhitewaterFrame& frame);

/// FNV-1a over positions, velocities, ids, types and ages in id order: equal
/// frames give equal sums whatever the particle order (`cascade inspect`).
std::uint64_t whitewaterChecksum(const WhitewaterFrame& frame);

} // namespace cascade::whitewater
