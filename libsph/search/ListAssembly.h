/// @file ListAssembly.h
/// @brief Builds neighbour rows (NeighborLists) from queries that a spatial
///        search processes in its own order (along the Z curve, in parallel
///        chunks), writing every list straight into its place.
///
/// Each chunk gets a region of the output with room for its queries at the last
/// call's mean list length plus a quarter, and appends its lists there, so the
/// lists need no second copy (on a 206 k-particle step the copy moved 28 MB, about
/// 2.3 ms on two cores). The rows then have room between them (NeighborLists::ends).
/// A chunk that fills its region writes the rest of its lists to a buffer of its
/// own, copied in after the region ends. The lists, and their order, are what the
/// search writes either way.
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
  std::vector<std::vector<std::uint32_t>> buffers;  ///< per chunk, for lists past its region
  std::vector<std::vector<std::uint32_t>> spilled;  ///< per chunk, the queries written there
  double meanCount = 0;                             ///< the last call's entries per query
};

/// Append-only writer for one chunk's lists: into its region of the output while
/// there is room, then into its own buffer.
class ChunkWriter {
public:
  ChunkWriter(std::uint32_t* region, std::size_t regionBase, std::size_t capacity, std::vector<std::uint32_t>& buffer,
              std::vector<std::uint32_t>& spilled, std::uint32_t* begins, std::uint32_t* ends)
      : mRegion(region), mBase(regionBase), mCapacity(capacity), mBuffer(buffer), mSpilled(spilled), mBegins(begins),
        mEnds(ends) {}
  /// Room for `extra` more indices (plus 16 spare: vector stores) at the cursor.
  std::uint32_t* reserve(std::size_t extra) {
    if (!mSpilling) {
      if (mUsed + mOpen + extra + 16 <= mCapacity) return mRegion + mUsed + mOpen;
      // The region is full: the rest goes to the buffer, the open list with it.
      mSpilling = true;
      if (mBuffer.size() < mOpen + extra + 16) mBuffer.resize(mOpen + extra + 4096);
      if (mOpen) std::memcpy(mBuffer.data(), mRegion + mUsed, mOpen * sizeof(std::uint32_t));
      mUsed = 0;
    }
    if (mUsed + mOpen + extra + 16 > mBuffer.size())
      mBuffer.resize(std::max(2 * mBuffer.size(), mUsed + mOpen + extra + 4096));
    return mBuffer.data() + mUsed + mOpen;
  }
  /// Adds `found` indices just written at the cursor to the open list.
  void advance(std::uint32_t found) { mOpen += found; }
  /// Closes the open list as query q's. Spilled lists get offsets into the buffer
  /// for now (assembleLists moves them).
  void finishQuery(std::uint32_t q) {
    const std::size_t begin = mSpilling ? mUsed : mBase + mUsed;
    mBegins[q] = static_cast<std::uint32_t>(begin);
    mEnds[q] = static_cast<std::uint32_t>(begin + mOpen);
    if (mSpilling) mSpilled.push_back(q);
    mPairs += mOpen;
    mUsed += mOpen;
    mOpen = 0;
  }
  /// Entries written to the buffer (past the region).
  std::size_t spilledEntries() const { return mSpilling ? mUsed : 0; }
  std::size_t pairs() const { return mPairs; }

private:
  std::uint32_t* mRegion;
  std::size_t mBase, mCapacity;
  std::vector<std::uint32_t>& mBuffer;
  std::vector<std::uint32_t>& mSpilled;
  std::uint32_t *mBegins, *mEnds;
  bool mSpilling = false;
  std::size_t mUsed = 0, mOpen = 0, mPairs = 0;
};

/// Runs process(chunk, placeBegin, placeEnd, writer) for every chunk in
/// parallel (chunk c covers query places [chunkStart[c], chunkStart[c+1])),
/// where the process must call writer.finishQuery(queryOrder[place]) once per
/// place, in place order; `out` gets the lists with room between them, in place
/// order in memory (out.order).
template <typename Process>
void assembleLists(std::size_t queryCount, const std::uint32_t* queryOrder,
                   const std::vector<std::uint32_t>& chunkStart, ListScratch& scratch, NeighborLists& out,
                   Process&& process) {
  const std::size_t chunks = chunkStart.size() - 1;
  if (scratch.buffers.size() < chunks) {
    scratch.buffers.resize(chunks);
    scratch.spilled.resize(chunks);
  }
  // Regions: the last call's mean length and a quarter more, and room for a first reserve.
  const double perQuery = scratch.meanCount * 1.25;
  std::vector<std::size_t> regionStart(chunks + 1, 0);
  for (std::size_t c = 0; c < chunks; ++c) {
    const double queries = double(chunkStart[c + 1] - chunkStart[c]);
    regionStart[c + 1] = regionStart[c] + static_cast<std::size_t>(queries * perQuery) + 1024;
  }
  if (regionStart[chunks] >= std::size_t(UINT32_MAX))
    throw std::length_error("neighbour search: more than 2^32 neighbour pairs");
  if (out.indices.size() < regionStart[chunks]) {
    if (out.indices.capacity() < regionStart[chunks]) {
      out.indices.clear();  // nothing to keep: no copy on growing
      out.indices.reserve(regionStart[chunks] + regionStart[chunks] / 8);
    }
    out.indices.resize(regionStart[chunks]);
  }
  out.offsets.resize(queryCount + 1);
  out.ends.resize(queryCount);
  std::vector<std::size_t> spilledEntries(chunks, 0), pairs(chunks, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
    for (std::size_t c = range.begin(); c != range.end(); ++c) {
      scratch.spilled[c].clear();
      ChunkWriter writer(out.indices.data() + regionStart[c], regionStart[c], regionStart[c + 1] - regionStart[c],
                         scratch.buffers[c], scratch.spilled[c], out.offsets.data(), out.ends.data());
      process(c, chunkStart[c], chunkStart[c + 1], writer);
      spilledEntries[c] = writer.spilledEntries();
      pairs[c] = writer.pairs();
    }
  });
  // Spilled lists go after the regions, chunk by chunk.
  std::size_t total = regionStart[chunks], pairTotal = 0;
  std::vector<std::size_t> spillStart(chunks, 0);
  for (std::size_t c = 0; c < chunks; ++c) {
    spillStart[c] = total;
    total += spilledEntries[c];
    pairTotal += pairs[c];
  }
  if (total >= std::size_t(UINT32_MAX))
    throw std::length_error("neighbour search: more than 2^32 neighbour pairs");
  if (total > regionStart[chunks]) {
    out.indices.resize(total);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, chunks, 1), [&](const auto& range) {
      for (std::size_t c = range.begin(); c != range.end(); ++c) {
        if (scratch.spilled[c].empty()) continue;
        if (spilledEntries[c])
          std::memcpy(out.indices.data() + spillStart[c], scratch.buffers[c].data(),
                      spilledEntries[c] * sizeof(std::uint32_t));
        const std::uint32_t shift = static_cast<std::uint32_t>(spillStart[c]);
        for (std::uint32_t q : scratch.spilled[c]) {
          out.offsets[q] += shift;
          out.ends[q] += shift;
        }
      }
    });
  }
  out.offsets[queryCount] = static_cast<std::uint32_t>(out.indices.size());
  out.pairs = pairTotal;
  out.order.assign(queryOrder, queryOrder + queryCount);
  scratch.meanCount = queryCount ? double(pairTotal) / double(queryCount) : 0.0;
}

} // namespace cascade::search
