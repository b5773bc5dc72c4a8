/// @file ActiveMaskLeafWriter.h
/// @brief A leaf's values as OpenVDB writes them with active-mask compression, the
///        same bytes for the cases a level set and a velocity grid give, made in a
///        fraction of the time: writeActiveMaskLeaf(), and LeafWritingGrid, a grid
///        whose buffers are written by it.
///
/// OpenVDB's LeafNode::writeBuffers (io::writeCompressedValues, format of
/// OpenVDB 10's io/Compression.h) writes per leaf: the value mask (64 bytes), one
/// metadata byte that says what the inactive values are, what that case needs of
/// them, and then only the active values, in voxel order, as floats or IEEE halves.
/// It finds the inactive values' case by iterating over them one by one, copies the
/// active ones through a heap array, and converts halves through a table: 0.27 s of
/// serial work (with the file writes) for the 31,000 leaves of a benchmark splash's "v".
/// Here one pass over the mask's words classifies the inactive values and gathers
/// the active ones into a stack buffer, and halves come from halvesFromFloats
/// (HalfFloat.h: F16C where the processor has it, round to nearest even, as OpenVDB's
/// half rounds every finite value; 2-2.7x faster for a whole grid, docs/surfacing.md). Only the cases whose inactive values are all +background, all -background,
/// or both (a level set's outside and inside; a velocity grid's zero) take this path;
/// any other leaf, a NaN to store as half, and any compression but the active mask
/// alone go to OpenVDB's own writer. tests/io/test_vdb_writer.cpp compares the bytes
/// with OpenVDB's leaf by leaf. Include only in .cpp files that already use OpenVDB.
#pragma once

#include "libsph/solver/HalfFloat.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/Compression.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <ostream>
#include <type_traits>

namespace cascade {

/// Writes `leaf` (a LeafNode of float or Vec3s) as `leaf.writeBuffers(os, toHalf)`
/// does on a stream whose compression is io::COMPRESS_ACTIVE_MASK and whose grid
/// background is `background`. False when it left the leaf to that writer.
template <typename LeafT>
bool writeActiveMaskLeaf(std::ostream& os, const LeafT& leaf, const typename LeafT::ValueType& background, bool toHalf) {
  using ValueT = typename LeafT::ValueType;
  using Mask = typename LeafT::NodeMaskType;
  static_assert(std::is_same_v<ValueT, float> || std::is_same_v<ValueT, openvdb::Vec3s>, "float or Vec3s leaves");
  constexpr int kSize = int(LeafT::SIZE), kWords = kSize / 64;
  const ValueT* values = leaf.buffer().data();
  const Mask& active = leaf.getValueMask();
  const ValueT minusBackground = -background;
  constexpr int kComponents = std::is_same_v<ValueT, float> ? 1 : 3;

  // The inactive values' case (io::MaskCompress's metadata): +background only (or no
  // inactive value), -background only, or both (then a mask selects +background);
  // and the active values in voxel order.
  bool plus = false, minus = false, other = false;
  Mask selection(false);  // inactive voxels holding +background
  float gathered[kSize * kComponents];
  int count = 0;
  for (int w = 0; w < kWords && !other; ++w) {
    const std::uint64_t on = active.template getWord<std::uint64_t>(openvdb::Index(w));
    std::uint64_t plusBits = 0;
    for (std::uint64_t bits = ~on; bits != 0; bits &= bits - 1) {
      const int bit = __builtin_ctzll(bits);
      const ValueT& value = values[64 * w + bit];
      if (value == background) {
        plusBits |= std::uint64_t(1) << bit;
      } else if (value == minusBackground) {
        minus = true;
      } else {
        other = true;
        break;
      }
    }
    plus = plus || plusBits != 0;
    selection.template getWord<std::uint64_t>(openvdb::Index(w)) = plusBits;
    for (std::uint64_t bits = on; bits != 0; bits &= bits - 1, ++count)
      std::memcpy(gathered + count * kComponents, &values[64 * w + __builtin_ctzll(bits)], sizeof(ValueT));
  }
  if (!other && toHalf)  // halves: a NaN's payload is OpenVDB's to round
    for (int k = 0; k < count * kComponents && !other; ++k) other = std::isnan(gathered[k]);
  if (other) {  // any other case: OpenVDB's own writer
    leaf.writeBuffers(os, toHalf);
    return false;
  }
  const std::int8_t metadata = plus && minus ? std::int8_t(openvdb::io::MASK_AND_NO_INACTIVE_VALS)
                               : minus       ? std::int8_t(openvdb::io::NO_MASK_AND_MINUS_BG)
                                             : std::int8_t(openvdb::io::NO_MASK_OR_INACTIVE_VALS);
  active.save(os);
  os.write(reinterpret_cast<const char*>(&metadata), 1);
  if (plus && minus) selection.save(os);
  if (count == 0) return true;
  if (!toHalf) {
    os.write(reinterpret_cast<const char*>(gathered), std::streamsize(sizeof(float)) * count * kComponents);
    return true;
  }
  std::uint16_t halves[kSize * kComponents];
  halvesFromFloats(gathered, halves, std::size_t(count * kComponents));
  os.write(reinterpret_cast<const char*>(halves), std::streamsize(sizeof(std::uint16_t)) * count * kComponents);
  return true;
}

/// A grid (FloatGrid or Vec3SGrid) sharing another's tree, transform and metadata,
/// whose buffers are written leaf by leaf with writeActiveMaskLeaf() when the stream's
/// compression is the active mask alone (else as GridT writes them). The leaves are
/// taken in the order Tree::writeBuffers takes them (the root's table, then each
/// internal node's children in offset order), which is the leaf iterator's.
template <typename GridT>
class LeafWritingGrid final : public GridT {
public:
  // OpenVDB's shallow copy takes a non-const grid; neither grid is changed.
  explicit LeafWritingGrid(const GridT& grid) : GridT(const_cast<GridT&>(grid), openvdb::ShallowCopy()) {}

  void writeBuffers(std::ostream& os) const override {
    using ValueT = typename GridT::ValueType;
    if (openvdb::io::getDataCompression(os) != openvdb::io::COMPRESS_ACTIVE_MASK) {
      GridT::writeBuffers(os);
      return;
    }
    ValueT background = openvdb::zeroVal<ValueT>();  // as io::writeCompressedValues finds it
    if (const void* stored = openvdb::io::getGridBackgroundValuePtr(os)) background = *static_cast<const ValueT*>(stored);
    const bool toHalf = this->saveFloatAsHalf();
    for (auto leaf = this->tree().cbeginLeaf(); leaf; ++leaf) writeActiveMaskLeaf(os, *leaf, background, toHalf);
  }
};

} // namespace cascade
