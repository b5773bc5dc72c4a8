/// @file MortonCode.h
/// @brief Z-order (Morton) codes of integer cell coordinates: the bits of x, y
///        and z interleaved (x in bit 0), so that cells close in space are
///        mostly close along the curve (Morton 1966; the memory layout of
///        CompactNSearch, Band et al. 2017, and of linear octrees).
#pragma once

#include <cstdint>

namespace cascade::search {

/// Largest coordinate a 63-bit code holds per axis (21 bits).
constexpr std::uint32_t kMortonMaxCoord = (1u << 21) - 1;

/// Spreads the low 21 bits of v so that bit k moves to bit 3k.
inline std::uint64_t mortonSpreadBits(std::uint32_t v) {
  std::uint64_t x = v & kMortonMaxCoord;
  x = (x | (x << 32)) & 0x1f00000000ffffULL;
  x = (x | (x << 16)) & 0x1f0000ff0000ffULL;
  x = (x | (x << 8)) & 0x100f00f00f00f00fULL;
  x = (x | (x << 4)) & 0x10c30c30c30c30c3ULL;
  x = (x | (x << 2)) & 0x1249249249249249ULL;
  return x;
}

/// Inverse of mortonSpreadBits: gathers every third bit.
inline std::uint32_t mortonCompactBits(std::uint64_t x) {
  x &= 0x1249249249249249ULL;
  x = (x | (x >> 2)) & 0x10c30c30c30c30c3ULL;
  x = (x | (x >> 4)) & 0x100f00f00f00f00fULL;
  x = (x | (x >> 8)) & 0x1f0000ff0000ffULL;
  x = (x | (x >> 16)) & 0x1f00000000ffffULL;
  x = (x | (x >> 32)) & 0x1fffffULL;
  return static_cast<std::uint32_t>(x);
}

/// mortonSpreadBits of every byte value: encoding by table (three lookups per
/// coordinate) is several times faster than the shift-and-mask sequence.
struct MortonSpreadTable {
  std::uint64_t spread[256];
  MortonSpreadTable() {
    for (std::uint32_t v = 0; v < 256; ++v) spread[v] = mortonSpreadBits(v);
  }
};
inline const MortonSpreadTable& mortonSpreadTable() {
  static const MortonSpreadTable table;
  return table;
}

/// Morton code of cell (x, y, z), each coordinate at most kMortonMaxCoord.
inline std::uint64_t mortonEncode(std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  const std::uint64_t* spread = mortonSpreadTable().spread;
  auto spreadCoord = [spread](std::uint32_t v) {
    v &= kMortonMaxCoord;
    return spread[v & 0xff] | (spread[(v >> 8) & 0xff] << 24) | (spread[v >> 16] << 48);
  };
  return spreadCoord(x) | (spreadCoord(y) << 1) | (spreadCoord(z) << 2);
}

inline void mortonDecode(std::uint64_t code, std::uint32_t& x, std::uint32_t& y, std::uint32_t& z) {
  x = mortonCompactBits(code);
  y = mortonCompactBits(code >> 1);
  z = mortonCompactBits(code >> 2);
}

} // namespace cascade::search
