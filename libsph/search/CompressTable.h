/// @file CompressTable.h
/// @brief For each 8-bit lane mask, the indices of its set lanes first, in order:
///        the permutation that packs the kept lanes of an eight-wide compare to the
///        front (AVX2 has no compress instruction; _mm256_permutevar8x32 with this row).
#pragma once

#include <cstdint>

namespace cascade::search {

/// compressTable()[mask] lists the lanes set in mask first (for a permute), then zeros.
struct CompressTable {
  alignas(32) std::uint32_t lanes[256][8];
  CompressTable() {
    for (unsigned mask = 0; mask < 256; ++mask) {
      unsigned k = 0;
      for (unsigned lane = 0; lane < 8; ++lane)
        if (mask & (1u << lane)) lanes[mask][k++] = lane;
      for (; k < 8; ++k) lanes[mask][k] = 0;
    }
  }
};
inline const CompressTable& compressTable() {
  static const CompressTable table;
  return table;
}

} // namespace cascade::search
