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

#include <cmath>
#include <vector>

namespace cascade {

/// The sum of every rank's terms (collective over `partition`; null: this process's).
/// The terms are scratch: each level leaves in them what its slice did not take.
inline double reproducibleSum(std::vector<double>& terms, DomainPartition* partition) {
  const std::size_t n = terms.size();
  double largest = n > 0 ? parallelMaximum(n, [&](std::size_t i) { return std::abs(terms[i]); }) : 0.0;
  if (partition) largest = partition->maxOverRanks(largest);
  double slices[3] = {0, 0, 0};
  if (!(largest > 0) || !std::isfinite(largest)) {
    // Nothing to cut (all zero), or a term that is not a number: a plain sum, as bad as the terms.
    slices[0] = deterministicSum(n, [&](std::size_t i) { return terms[i]; });
  } else {
    // |term| < 2^e. Slice l takes the multiples of 2^(e_l + k - 52), e_0 = e, with
    // M_l = 1.5 x 2^(e_l + k): (M + x) - M is exact for |x| < 2^(e_l + k - 1), and up to
    // 2^(k - 1) such slices sum exactly. The remainder is below 2^(e_l + k - 53) = 2^e_(l+1).
    constexpr int k = 32;
    int e = 0;
    std::frexp(largest, &e);
    for (int level = 0; level < 3; ++level, e += k - 53) {
      const double M = std::ldexp(1.5, e + k);
      slices[level] = deterministicSum(n, [&](std::size_t i) {
        const double slice = (M + terms[i]) - M;  // IEEE order (no -ffast-math): exact
        terms[i] -= slice;                        // exact: what the next level cuts
        return slice;
      });
    }
  }
  if (partition) partition->sumOverRanks(slices, 3);  // exact: multiples of each slice's unit
  return (slices[0] + slices[1]) + slices[2];
}

} // namespace cascade
