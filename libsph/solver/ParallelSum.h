/// @file ParallelSum.h
/// @brief Parallel loops over particle indices whose results do not depend on the
///        thread schedule: sums in fixed chunks added in order (so a resumed bake
///        stays bit-identical to an uninterrupted one).
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

namespace cascade {

/// Indices per chunk of deterministicSum(): the chunking, not the threads, fixes the order.
constexpr std::size_t kSumChunk = 1024;

/// Sum over [0, n) of f(i) in double, in fixed chunks added in order.
template <typename F>
double deterministicSum(std::size_t n, F&& f) {
  const std::size_t chunks = (n + kSumChunk - 1) / kSumChunk;
  std::vector<double> partial(chunks, 0.0);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    double sum = 0;
    const std::size_t end = std::min(n, (c + 1) * kSumChunk);
    for (std::size_t i = c * kSumChunk; i < end; ++i) sum += f(i);
    partial[c] = sum;
  });
  double total = 0;
  for (double p : partial) total += p;
  return total;
}

/// Largest f(i) over [0, n) (-infinity for n = 0); a maximum is order-independent.
template <typename F>
double parallelMaximum(std::size_t n, F&& f) {
  const std::size_t chunks = (n + kSumChunk - 1) / kSumChunk;
  std::vector<double> partial(chunks, -std::numeric_limits<double>::infinity());
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t c) {
    double most = -std::numeric_limits<double>::infinity();
    const std::size_t end = std::min(n, (c + 1) * kSumChunk);
    for (std::size_t i = c * kSumChunk; i < end; ++i) most = std::max(most, f(i));
    partial[c] = most;
  });
  double most = -std::numeric_limits<double>::infinity();
  for (double p : partial) most = std::max(most, p);
  return most;
}

/// f(i) for every i in [0, n), in parallel blocks of 512.
template <typename F>
void forEachIndex(std::size_t n, F&& f) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 512), [&](const auto& range) {
    for (std::size_t i = range.begin(); i != range.end(); ++i) f(i);
  });
}

} // namespace cascade
