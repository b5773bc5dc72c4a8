/// @file ReactionSums.h
/// @brief What the fluid next to the solids does to each solid in a step (force,
///        moment, ...), summed over the boundary layer's particles so that the sum
///        does not depend on the thread schedule and, over MPI ranks, not on how
///        the particles are split among the ranks either.
///
/// Each entry of the boundary layer (a fluid particle next to the solids;
/// BoundaryParticles::layer) adds its share to a record of `quantities` vectors per
/// solid, quantity q of solid b at record[q * solids + b]. In one process a record
/// serves a fixed chunk of kChunk entries, and the chunks' records are added in
/// chunk order (as ParallelSum.h does). Over ranks every entry has its own record
/// and the records of every rank are summed by pre-rounding (ReproducibleSum.h), so
/// every rank gets the bits one rank would: what a rigid body needs to move the same
/// on any rank count (Akinci et al. 2012's coupling over a DomainPartition).
#pragma once

#include "libsph/Types.h"
#include "libsph/solver/DomainPartition.h"
#include "libsph/solver/ReproducibleSum.h"

#include <cstddef>
#include <vector>

namespace cascade {

class ReactionSums {
public:
  /// Entries per record in one process, and per task of the loops that fill them.
  static constexpr std::size_t kChunk = 256;

  /// `entries` layer entries; `partition` null: one process (a record per chunk).
  ReactionSums(std::size_t entries, std::size_t solids, std::size_t quantities, DomainPartition* partition)
      : mSolids(solids), mWidth(solids * quantities), mPerEntry(partition != nullptr), mPartition(partition),
        mRecords((mPerEntry ? entries : chunks(entries)) * mWidth, Vec3d::Zero()) {}

  static std::size_t chunks(std::size_t entries) { return (entries + kChunk - 1) / kChunk; }

  /// The record entry `k` adds to. One process: the entries of a chunk share it, so a
  /// chunk of entries must be one task's.
  Vec3d* record(std::size_t k) { return mRecords.data() + (mPerEntry ? k : k / kChunk) * mWidth; }

  /// Quantity `q` of solid `b`, summed over every entry (and every rank: collective then).
  /// Call once; the records are scratch.
  std::vector<Vec3d> totals() {
    std::vector<Vec3d> sums(mWidth, Vec3d::Zero());
    if (mWidth == 0) return sums;
    const std::size_t rows = mRecords.size() / mWidth;
    if (!mPerEntry) {
      for (std::size_t row = 0; row < rows; ++row)
        for (std::size_t c = 0; c < mWidth; ++c) sums[c] += mRecords[row * mWidth + c];
    } else {
      static_assert(sizeof(Vec3d) == 3 * sizeof(double), "Vec3d is three packed doubles");
      // A rank with no layer entries has no records (still a collective call).
      const double* records = mRecords.empty() ? nullptr : mRecords.data()->data();
      reproducibleSums(records, rows, 3 * mWidth, sums.data()->data(), mPartition);
    }
    return sums;
  }
  std::size_t index(std::size_t quantity, std::size_t solid) const { return quantity * mSolids + solid; }

private:
  std::size_t mSolids, mWidth;
  bool mPerEntry;
  DomainPartition* mPartition;
  std::vector<Vec3d> mRecords;
};

} // namespace cascade
