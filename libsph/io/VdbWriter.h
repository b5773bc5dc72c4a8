/// @file VdbWriter.h
/// @brief Writes grids as an OpenVDB file, the bytes io::File::write gives, through
///        one large buffer, and reports any write error.
///
/// io::File writes through a std::ofstream, and libstdc++ passes every write of
/// 1 KiB or more straight to the kernel: one system call per leaf's values, some
/// 36,000 for an 80 MB surface with its "v" grid. Here the archive writes into an
/// 8 MiB buffer over the file descriptor (seekable, as OpenVDB's grid offsets need),
/// and a failed write (a full disk) throws instead of leaving a short file. Float and
/// Vec3s grids write their leaves through ActiveMaskLeafWriter.h (the same bytes, in
/// a fraction of the time).
/// Include only in .cpp files that already use OpenVDB.
#pragma once

#include <openvdb/openvdb.h>

#include <cstdint>
#include <filesystem>

namespace cascade {

/// Writes `grids` to `path` (created or truncated) with OpenVDB `compression` flags
/// (io::COMPRESS_*). Throws std::runtime_error naming the path on failure.
void writeVdbFile(const std::filesystem::path& path, const openvdb::GridCPtrVec& grids, std::uint32_t compression);

} // namespace cascade
