/// @file MpiRuntime.h
/// @brief MPI for the `cascade` program. MPI starts only when an MPI launcher
///        (mpirun, or srun --mpi=pmix) started the process, so a plain
///        `cascade bake` runs as before; a build without MPI (CASCADE_MPI off, or
///        no OpenMPI found at configure time) refuses to run under a launcher
///        with more than one rank instead of baking the scene once per rank.
#pragma once

#include "libsph/solver/DomainPartition.h"

#include <memory>
#include <ostream>
#include <string>
#include <vector>

namespace cascade::distributed {

/// Whether this build has MPI.
bool mpiBuilt();
/// The rank count an MPI launcher gave this process (Open MPI's OMPI_COMM_WORLD_SIZE,
/// PMIx's PMIX_SIZE or PMI's PMI_SIZE), 0 when no launcher started it.
int launcherRankCount();

/// Worker threads for one rank: this machine's hardware threads divided among the
/// ranks the launcher put on it (OMPI_COMM_WORLD_LOCAL_SIZE), at least 1.
int threadsPerRank();

/// MPI_Init at construction if a launcher started the process, MPI_Finalize at destruction.
class MpiSession {
public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
  bool active() const { return mActive; }
  int rank() const { return mRank; }
  int size() const { return mSize; }
  /// Stops every rank at once with `code` (after a failure on this rank alone, which
  /// would leave the others waiting in their next exchange).
  [[noreturn]] void abort(int code) const;

private:
  bool mActive = false;
  int mRank = 0, mSize = 1;
};

/// The session of this process (null before main made one, or after it ended).
const MpiSession* currentSession();

/// The slab partition over MPI_COMM_WORLD (MpiSlabPartition.h); null without an
/// active session. `cuts`: slab cuts placed by hand and kept ("x=0.4,0.8"; "" for balanced ones
/// that follow the fluid).
/// Throws InputError for malformed cuts.
std::unique_ptr<DomainPartition> makeWorldPartition(std::ostream* log, const std::string& cuts);

/// One line on this rank's exchanges so far: time, ghosts, migrations and rebalances.
std::string partitionSummary(const DomainPartition& partition);

} // namespace cascade::distributed
