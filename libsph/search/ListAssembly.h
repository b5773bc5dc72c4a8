/// @file ListAssembly.h
/// @brief Builds compressed neighbour rows (NeighborLists) from queries that a
///        spatial search processes in its own order (along the Z curve, in
///        parallel chunks): each chunk appends its queries' lists to a buffer of
///        its own, then the rows are laid out in query order and the buffers
///        copied in (one block copy per chunk when its queries are consecutive).
#pragma once

#include "libsph/NeighborSearch.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace cascade::search {

/// Scratch memory reused between calls (the buffers keep their capacity).
struct ListScratch {
  std::vector<std::vector<std::uint32_t>> buffers;
  std::vector<std::uint32_t> counts;
};

/// Append-only writer for one chunk's lists.
class ChunkWriter {
public:
  ChunkWriter(std::vector<std::uint32_t>& buffer, std::uint32_t* counts)
      : mBuffer(buffer), mCounts(counts) {}
  /// Room for `extra` more indices (plus 16 spare: vector stores) at the cursor.
  std::uint32_t* reserve(std::size_t extra) {
    if (mUsed + mOpen + extra + 16 > mBuffer.size())
      mBuffer.resize(std::max(2 * mBuffer.size(), mUsed + mOpen + extra + 4096));
    return mBuffer.data() + mUsed + mOpen;
  }
  /// Adds `found` indices just written at the cursor to the open list.
  void advance(std::uint32_t found) { mOpen += found; }
  /// Closes the open list as query q's.
  void finishQuery(std::uint32_t q) {
    mCounts[q] = static_cast<std::uint32_t>(mOpen);
    mUsed += mOpen;
    mOpen = 0;
  }
  std::size_t used() const { return mUsed; }

private:
  std::vector<std::uint32_t>& mBuffer;
  std::uint32_t* mCounts;
  std::size_t mUsed = 0, mOpen = 0;
};

/// Runs process(chunk, placeBegin, placeEnd, writer) for every chunk in
/// parallel (chunk c covers query places [chunkStart[c], chunkStart[c+1])),
/// where the process must call writer.finishQuery(queryOrder[place]) once per
/// place in order; then assembles `out` in query order.
template <typename Process>
void assembleLists(std::size_t queryCount, const std::uint32_t* queryOrder,
                   const std::vector<std::uint32_t>& chunkStart, ListScratch& scratch,
                   NeighborLists& out, Process&& process) {
  const std::size_t chunks = chunkStart.size() - 1;
  if (scratch.buffers.size() < chunks) scratch.buffers.resize(chunks);
  scratch.counts.resize(queryCount);
  std::vector<std::size_t> used(chunks, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      ChunkWriter writer(scratch.buffers[c], scratch.counts.data());
      process(c, chunkStart[c], chunkStart[c + 1], writer);
      used[c] = writer.used();
    }
  });
  out.offsets.resize(queryCount + 1);
  std::uint64_t total = 0;
  for (std::size_t q = 0; q < queryCount; ++q) {
    out.offsets[q] = static_cast<std::uint32_t>(total);
    total += scratch.counts[q];
  }
  if (total >= std::uint64_t(UINT32_MAX))
    throw std::length_error("neighbour search: more than 2^32 neighbour pairs");
  out.offsets[queryCount] = static_cast<std::uint32_t>(total);
  out.indices.resize(total);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      const std::uint32_t first = chunkStart[c], last = chunkStart[c + 1];
      if (first == last) continue;
      const std::uint32_t* source = scratch.buffers[c].data();
      bool consecutive = true;
      for (std::uint32_t s = first + 1; s < last && consecutive; ++s)
        consecutive = queryOrder[s] == queryOrder[s - 1] + 1;
      if (consecutive) {
        if (used[c])
          std::memcpy(out.indices.data() + out.offsets[queryOrder[first]], source,
                      used[c] * sizeof(std::uint32_t));
        continue;
      }
      for (std::uint32_t s = first; s < last; ++s) {
        const std::uint32_t q = queryOrder[s];
        const std::uint32_t n = scratch.counts[q];
        if (n) std::memcpy(out.indices.data() + out.offsets[q], source, n * sizeof(std::uint32_t));
        source += n;
      }
    }
  });
}

} // namespace cascade::search
