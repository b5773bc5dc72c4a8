/// @file RadixSort.h
/// @brief Stable least-significant-digit radix sort of (key, value) pairs,
///        parallel over blocks with TBB (per-block histograms, then scatter).
///        Sorts Morton keys for the grid, the octree and the Z-order permutation.
#pragma once

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace cascade::search {

/// Sorts keys[0..n) ascending and applies the same permutation to values;
/// only bits [lowBit, keyBits) of each key are looked at. Stable. The scratch
/// vectors are resized as needed (pass them again to reuse their memory).
template <typename Key, typename Value>
void radixSortPairs(std::vector<Key>& keys, std::vector<Value>& values, int keyBits,
                    std::vector<Key>& keyScratch, std::vector<Value>& valueScratch,
                    int lowBit = 0) {
  // 8-bit digits (measured faster here than 11-bit ones, for 21- and 63-bit keys).
  constexpr int kDigitBits = 8;
  constexpr std::size_t kBuckets = std::size_t(1) << kDigitBits;
  const std::size_t n = keys.size();
  if (n < 2) return;
  keyScratch.resize(n);
  valueScratch.resize(n);
  const std::size_t blockCount = std::min<std::size_t>(64, std::max<std::size_t>(1, n / 16384));
  const std::size_t blockSize = (n + blockCount - 1) / blockCount;
  std::vector<std::array<std::size_t, kBuckets>> histograms(blockCount);

  for (int shift = lowBit; shift < keyBits; shift += kDigitBits) {
    tbb::parallel_for(std::size_t(0), blockCount, [&](std::size_t b) {
      auto& histogram = histograms[b];
      histogram.fill(0);
      const std::size_t end = std::min(n, (b + 1) * blockSize);
      for (std::size_t i = b * blockSize; i < end; ++i) ++histogram[(keys[i] >> shift) & (kBuckets - 1)];
    });
    // Exclusive prefix over (digit, block): stable.
    std::size_t total = 0;
    bool singleDigit = false;
    for (std::size_t d = 0; d < kBuckets; ++d) {
      std::size_t digitTotal = 0;
      for (std::size_t b = 0; b < blockCount; ++b) {
        const std::size_t count = histograms[b][d];
        histograms[b][d] = total;
        total += count;
        digitTotal += count;
      }
      if (digitTotal == n) singleDigit = true;
    }
    if (singleDigit) continue;  // every key has this digit: the pass would not move anything
    tbb::parallel_for(std::size_t(0), blockCount, [&](std::size_t b) {
      auto& next = histograms[b];
      const std::size_t end = std::min(n, (b + 1) * blockSize);
      for (std::size_t i = b * blockSize; i < end; ++i) {
        const std::size_t slot = next[(keys[i] >> shift) & (kBuckets - 1)]++;
        keyScratch[slot] = keys[i];
        valueScratch[slot] = values[i];
      }
    });
    keys.swap(keyScratch);
    values.swap(valueScratch);
  }
}

/// Number of bits needed to hold value (0 for 0).
inline int bitWidth(std::uint64_t value) {
  int bits = 0;
  while (value) {
    ++bits;
    value >>= 1;
  }
  return bits;
}

} // namespace cascade::search
