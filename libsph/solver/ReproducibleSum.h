/// @file ReproducibleSum.h
/// @brief A sum over the terms of every MPI rank whose bits do not depend on how the
///        terms are split among ranks or ordered: pre-rounding (Rump, Ogita & Oishi
///        2008, "Accurate floating-point summation part I", SIAM J. Sci. Comput.
///        31(1); Demmel & Nguyen 2013, "Fast reproducible floating-point summation",
///        ARITH 21). Each term is cut into three slices at fixed bit positions set by
///        the largest term over all ranks; the sum of each slice is exact in double,
///        hence independent of the order, and the three slice sums are added last,
///        in a fixed order. About 2^-60 of the largest term is dropped.
#pragma once

#include "libsph/solver/DomainPartition.h"
#include "libsph/solver/ParallelSum.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace cascade {

/// Column sums of a table of `rows` x `width` terms (row-major) over the rows of every
/// rank: sums[c] is column c's sum (collective over `partition`; null: this process's
/// rows). Columns are cut independently, each by its own largest term, with the bits
/// reproducibleSum() gives that column alone.
inline void reproducibleSums(const double* table, std::size_t rows, std::size_t width, double* sums,
                             DomainPartition* partition) {
  const std::size_t chunks = (rows + kSumChunk - 1) / kSumChunk;
  std::vector<double> partials(chunks * width);
  // |term| per column, the largest (a maximum is order-independent).
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t chunk) {
    double* most = partials.data() + chunk * width;
    std::fill(most, most + width, 0.0);
    for (std::size_t i = chunk * kSumChunk; i < std::min(rows, (chunk + 1) * kSumChunk); ++i)
      for (std::size_t c = 0; c < width; ++c) most[c] = std::max(most[c], std::abs(table[i * width + c]));
  });
  std::vector<double> largest(width, 0.0);
  for (std::size_t chunk = 0; chunk < chunks; ++chunk)
    for (std::size_t c = 0; c < width; ++c) largest[c] = std::max(largest[c], partials[chunk * width + c]);
  if (partition) partition->maxOverRanks(largest.data(), width);
  // |term| < 2^e. Slice l takes the multiples of 2^(e_l + k - 52), e_0 = e, with
  // M_l = 1.5 x 2^(e_l + k): (M + x) - M is exact for |x| < 2^(e_l + k - 1), and up to
  // 2^(k - 1) such slices sum exactly. The remainder is below 2^(e_l + k - 53) = 2^e_(l+1).
  // A column with nothing to cut (all zero) or a term that is not a number: a plain sum
  // (as bad as the terms) in slice 0.
  constexpr int k = 32;
  std::vector<int> exponent(width, 0);
  std::vector<char> cut(width, 0);
  for (std::size_t c = 0; c < width; ++c) {
    cut[c] = largest[c] > 0 && std::isfinite(largest[c]);
    if (cut[c]) std::frexp(largest[c], &exponent[c]);
  }
  std::vector<double> magic(3 * width, 0.0);
  for (int level = 0; level < 3; ++level)
    for (std::size_t c = 0; c < width; ++c)
      magic[std::size_t(level) * width + c] = std::ldexp(1.5, exponent[c] + level * (k - 53) + k);
  // One pass over the table for the three levels: each slice's partial sums in row
  // order within a chunk, then the chunks in order (the order is immaterial: exact).
  partials.assign(chunks * 3 * width, 0.0);
  tbb::parallel_for(std::size_t(0), chunks, [&](std::size_t chunk) {
    double* partial = partials.data() + chunk * 3 * width;
    for (std::size_t i = chunk * kSumChunk; i < std::min(rows, (chunk + 1) * kSumChunk); ++i)
      for (std::size_t c = 0; c < width; ++c) {
        double term = table[i * width + c];
        if (!cut[c]) {
          partial[c] += term;
          continue;
        }
        for (std::size_t level = 0; level < 3; ++level) {
          const double M = magic[level * width + c];
          const double slice = (M + term) - M;  // IEEE order (no -ffast-math): exact
          term -= slice;                        // exact: what the next level cuts
          partial[level * width + c] += slice;
        }
      }
  });
  std::vector<double> slices(3 * width, 0.0);
  for (std::size_t chunk = 0; chunk < chunks; ++chunk)
    for (std::size_t j = 0; j < 3 * width; ++j) slices[j] += partials[chunk * 3 * width + j];
  if (partition) partition->sumOverRanks(slices.data(), slices.size());  // exact: multiples of each slice's unit
  for (std::size_t c = 0; c < width; ++c) sums[c] = (slices[c] + slices[width + c]) + slices[2 * width + c];
}

/// The sum of every rank's terms (collective over `partition`; null: this process's).
inline double reproducibleSum(const std::vector<double>& terms, DomainPartition* partition) {
  double sum = 0;
  reproducibleSums(terms.data(), terms.size(), 1, &sum, partition);
  return sum;
}

} // namespace cascade
