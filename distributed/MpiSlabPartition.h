/// @file MpiSlabPartition.h
/// @brief DomainPartition over MPI ranks (OpenMPI): the fluid cut into slabs
///        (SlabDecomposition.h), particles migrated to the rank of their slab
///        after every step and ghosts one support radius deep exchanged before
///        it, both with MPI_Alltoallv (a particle that crosses several slabs in
///        one step goes straight to its owner). When the largest share drifts
///        more than 10 % above the mean, the cuts move to the quantiles of a
///        histogram summed over ranks (MPI_Allreduce) and the particles follow.
///        Reductions that feed the state are exact (max) or summed in rank
///        order from MPI_Allgather, never in MPI_Allreduce's unspecified order.
#pragma once

#include "distributed/SlabDecomposition.h"
#include "libsph/solver/DomainPartition.h"

#include <mpi.h>

#include <cstdint>
#include <ostream>
#include <vector>

namespace cascade::distributed {

class MpiSlabPartition final : public DomainPartition {
public:
  /// `log`: the rank count, the shares at the start and at every rebalance (rank 0
  /// writes; null: silent). `tolerance`: the drift of the largest share above the
  /// mean that rebalances.
  explicit MpiSlabPartition(MPI_Comm comm, std::ostream* log = nullptr, double tolerance = 0.1);

  /// Cuts placed by hand (rankCount - 1 ascending coordinates along `axis`), kept for
  /// the whole run: no rebalancing (a rank boundary through an obstacle or an emitter).
  void setFirstCuts(int axis, std::vector<Real> cuts);

  int rank() const override { return mRank; }
  int rankCount() const override { return mSize; }
  bool owns(const Vec3r& position) const override;
  void start(const Particles& all, Real supportRadius, const Vec3r& lo, const Vec3r& hi,
             const Vec3r& gravity) override;
  void migrate(Particles& particles, std::vector<Real>* state = nullptr, std::size_t width = 0) override;
  void addGhosts(Particles& particles, Real halo) override;
  void refreshGhosts(Real* values, std::size_t ownedCount) override;
  void refreshGhosts(Vec3r* values, std::size_t ownedCount) override;
  using DomainPartition::maxOverRanks;
  void maxOverRanks(double* values, std::size_t count) override;
  void sumOverRanks(double* values, std::size_t count) override;
  std::string firstMessage(const std::string& local) override;
  Particles gatherToFirst(const Particles& owned, const std::vector<Real>* state = nullptr, std::size_t width = 0,
                          std::vector<Real>* gatheredState = nullptr) override;

  Statistics statistics() const override { return {mCommunicationSeconds, mGhostCount, mMigrated, mRebalances}; }

  const SlabDecomposition& slabs() const { return mSlabs; }

  /// One particle as it travels between ranks.
  struct Record;

private:
  /// Particle records to each rank; receives theirs into `received` (in rank order).
  /// With `width` > 0 also the Reals of outgoingState (width per record) into receivedState.
  void exchange(const std::vector<std::vector<Record>>& outgoing, std::vector<Record>& received,
                std::vector<int>* receivedCounts, const std::vector<std::vector<Real>>* outgoingState = nullptr,
                std::vector<Real>* receivedState = nullptr, std::size_t width = 0);
  template <typename T>
  void refresh(T* values, std::size_t ownedCount);
  void logShares(const char* when, const std::vector<std::uint64_t>& counts) const;
  void rebalance(const Particles& particles);

  MPI_Comm mComm;
  int mRank = 0, mSize = 1;
  std::ostream* mLog = nullptr;
  double mTolerance = 0.1;
  SlabDecomposition mSlabs;
  int mFirstAxis = -1;
  std::vector<Real> mFirstCuts;
  // The last addGhosts: owned indices sent to each rank, ghosts received from each.
  std::vector<std::vector<std::uint32_t>> mGhostSends;
  std::vector<int> mGhostReceives;
  std::size_t mGhostCount = 0;
  std::uint64_t mRebalances = 0, mMigrated = 0;
  double mCommunicationSeconds = 0;
};

} // namespace cascade::distributed
