#include "distributed/MpiRuntime.h"

#include "libsph/Errors.h"

#ifdef CASCADE_WITH_MPI
#include "distributed/MpiSlabPartition.h"
#include <mpi.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <thread>

#include <sched.h>

namespace cascade::distributed {

namespace {
const MpiSession* gSession = nullptr;
} // namespace

bool mpiBuilt() {
#ifdef CASCADE_WITH_MPI
  return true;
#else
  return false;
#endif
}

int launcherRankCount() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE"})
    if (const char* value = std::getenv(name)) return std::max(1, std::atoi(value));
  if (std::getenv("PMIX_RANK") || std::getenv("PMI_RANK")) return 1;
  return 0;
}

int threadsPerRank() {
  // A Slurm job step gives each task its cores (sbatch --cpus-per-task).
  if (const char* perTask = std::getenv("SLURM_CPUS_PER_TASK")) return std::max(1, std::atoi(perTask));
  // The cores this process may run on (an MPI launcher may bind it), shared with the
  // other ranks on this machine when it is not bound.
  int cores = std::max(1, int(std::thread::hardware_concurrency()));
  cpu_set_t mask;
  if (sched_getaffinity(0, sizeof mask, &mask) == 0 && CPU_COUNT(&mask) > 0 && CPU_COUNT(&mask) < cores)
    return CPU_COUNT(&mask);
  int local = 1;
  for (const char* name : {"OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS", "SLURM_STEP_TASKS_PER_NODE"})
    if (const char* value = std::getenv(name)) {
      local = std::max(1, std::atoi(value));  // Slurm's "2(x3)": 2 on each node
      break;
    }
  return std::max(1, cores / local);
}

MpiSession::MpiSession(int& argc, char**& argv) {
  gSession = this;
#ifdef CASCADE_WITH_MPI
  if (launcherRankCount() == 0) return;
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);  // TBB threads never call MPI
  MPI_Comm_rank(MPI_COMM_WORLD, &mRank);
  MPI_Comm_size(MPI_COMM_WORLD, &mSize);
  mActive = true;
#else
  (void)argc;
  (void)argv;
#endif
}

MpiSession::~MpiSession() {
#ifdef CASCADE_WITH_MPI
  if (mActive) MPI_Finalize();
#endif
  gSession = nullptr;
}

void MpiSession::abort(int code) const {
#ifdef CASCADE_WITH_MPI
  if (mActive) MPI_Abort(MPI_COMM_WORLD, code);
#endif
  std::exit(code);
}

const MpiSession* currentSession() { return gSession; }

std::unique_ptr<DomainPartition> makeWorldPartition(std::ostream* log, const std::string& cuts) {
#ifdef CASCADE_WITH_MPI
  if (gSession == nullptr || !gSession->active()) return nullptr;
  auto partition = std::make_unique<MpiSlabPartition>(MPI_COMM_WORLD, gSession->rank() == 0 ? log : nullptr);
  if (!cuts.empty()) {
    const std::string axes = "xyz";
    const std::size_t equals = cuts.find('=');
    if (equals != 1 || axes.find(cuts[0]) == std::string::npos)
      throw InputError("--rank-cuts: expected AXIS=C1,C2,... (AXIS x, y or z; metres), got '" + cuts + "'");
    std::vector<Real> values;
    std::stringstream list(cuts.substr(2));
    std::string item;
    while (std::getline(list, item, ',')) {
      char* end = nullptr;
      const double value = std::strtod(item.c_str(), &end);
      if (item.empty() || *end != '\0' || !std::isfinite(value))
        throw InputError("--rank-cuts: '" + item + "' is not a coordinate in metres");
      values.push_back(Real(value));
    }
    partition->setFirstCuts(int(axes.find(cuts[0])), values);
  }
  return partition;
#else
  (void)log;
  (void)cuts;
  return nullptr;
#endif
}

std::string partitionSummary(const DomainPartition& partition) {
  const DomainPartition::Statistics done = partition.statistics();
  std::ostringstream line;
  line.precision(3);
  line << "bake: rank " << partition.rank() << " of " << partition.rankCount() << ": " << done.communicationSeconds
       << " s in MPI exchanges, " << done.lastGhosts << " ghosts in the last step, " << done.migrated
       << " particles migrated, " << done.rebalances << " rebalances";
  return line.str();
}

} // namespace cascade::distributed
