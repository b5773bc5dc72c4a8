// `cascade bench step --ranks 1,2`: the WCSPH step of bench step's dam break
// (about 100 k particles) on this machine's cores split three ways: one process
// with every core as threads (no MPI), and for each N in --ranks, N MPI ranks
// (mpirun -np N) with the cores divided among them (--threads cores / N). Each
// MPI run is a child `cascade bench step --mpi-child SIZE` under mpirun; its
// rank 0 prints one line that this parent reads. Columns: particle-steps per
// second in all and per core, the ratio to the threaded run, the ghosts per
// rank and the share of the step spent in MPI exchanges (rank 0).
//
// The MPI runs sort every neighbour list by particle id (Simulation::setPartition),
// which the threaded run does not: the 1-rank row shows that cost alone.
#include "Benchmarks.h"

#include "distributed/MpiRuntime.h"
#include "libsph/Errors.h"
#include "libsph/solver/Simulation.h"

#include <tbb/info.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <thread>
#include <unistd.h>

namespace cascade::cli {

namespace {

struct StepRun {
  std::size_t fluid = 0;
  double msPerStep = 0;
  double ghosts = 0;         ///< received by this rank in the last step
  double commFraction = 0;   ///< rank 0's MPI exchange time / wall time
};

/// bench step's dam break at about `target` particles, timed over 40 steps (8 above
/// 300 k particles) after 5.
StepRun timeDamBreak(long target, DomainPartition* partition) {
  Simulation sim(benchDamBreakSettings());
  addBenchDamBreak(sim, std::size_t(target));
  StepRun run;
  run.fluid = sim.particles().size();
  if (partition) sim.setPartition(partition);
  const int warmup = 5, steps = target > 300000 ? 8 : 40;
  for (int k = 0; k < warmup; ++k) sim.step();
  const double commBefore = partition ? partition->statistics().communicationSeconds : 0;
  const auto start = std::chrono::steady_clock::now();
  for (int k = 0; k < steps; ++k) sim.step();
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  run.msPerStep = 1000 * wall / steps;
  if (partition) {
    run.commFraction = (partition->statistics().communicationSeconds - commBefore) / wall;
    run.ghosts = double(partition->statistics().lastGhosts);
  }
  return run;
}

} // namespace

void benchStepMpiChild(long target) {
  const std::unique_ptr<DomainPartition> partition = distributed::makeWorldPartition(nullptr, "");
  if (!partition) throw InputError("--mpi-child: run under mpirun");
  const StepRun run = timeDamBreak(target, partition.get());
  double ghosts = run.ghosts;
  partition->sumOverRanks(&ghosts, 1);
  if (partition->rank() == 0)
    std::printf("mpi_step %zu %.6g %.6g %.6g\n", run.fluid, run.msPerStep, ghosts / partition->rankCount(),
                run.commFraction);
  std::fflush(stdout);
}

BenchTable benchStepRanks(const std::vector<int>& ranks, long target) {
  BenchTable table("step_ranks", {"mode", "ranks", "threads_per_rank", "n_fluid", "ms_per_step",
                                  "particle_steps_per_s", "per_core", "vs_threaded", "ghosts_per_rank",
                                  "mpi_share"});
  const int cores = std::max(1, tbb::info::default_concurrency());
  std::cerr << "bench step --ranks: threaded reference, " << cores << " threads..." << std::endl;
  const StepRun threaded = timeDamBreak(target, nullptr);
  const double threadedRate = double(threaded.fluid) * 1000 / threaded.msPerStep;
  table.addRow({std::string("threads"), 1LL, static_cast<long long>(cores), static_cast<long long>(threaded.fluid),
                threaded.msPerStep, threadedRate, threadedRate / cores, 1.0, 0.0, 0.0});
  char self[4096];
  const ssize_t length = readlink("/proc/self/exe", self, sizeof self - 1);
  if (length <= 0) throw std::runtime_error("bench step --ranks: cannot find the cascade executable");
  self[length] = '\0';
  for (int n : ranks) {
    const int threads = std::max(1, cores / n);
    std::ostringstream command;
    command << "mpirun " << (geteuid() == 0 ? "--allow-run-as-root " : "") << (n > cores ? "--oversubscribe " : "")
            << "--bind-to none -np " << n << " '" << self << "' bench step --mpi-child " << target << " --threads "
            << threads << " 2>&1";
    std::cerr << "bench step --ranks: " << n << " rank" << (n > 1 ? "s" : "") << " x " << threads << " thread"
              << (threads > 1 ? "s" : "") << "..." << std::endl;
    FILE* pipe = popen(command.str().c_str(), "r");
    if (pipe == nullptr) throw std::runtime_error("bench step --ranks: cannot run mpirun");
    std::string output;
    char buffer[4096];
    while (std::fgets(buffer, sizeof buffer, pipe)) output += buffer;
    const int status = pclose(pipe);
    StepRun run;
    double ghosts = 0;
    const std::size_t at = output.find("mpi_step ");
    if (status != 0 || at == std::string::npos ||
        std::sscanf(output.c_str() + at, "mpi_step %zu %lf %lf %lf", &run.fluid, &run.msPerStep, &ghosts,
                    &run.commFraction) != 4)
      throw std::runtime_error("bench step --ranks: mpirun -np " + std::to_string(n) + " failed:\n" + output);
    const double rate = double(run.fluid) * 1000 / run.msPerStep;
    const int used = n * threads;
    table.addRow({std::string("mpi"), static_cast<long long>(n), static_cast<long long>(threads),
                  static_cast<long long>(run.fluid), run.msPerStep, rate, rate / used,
                  (rate / used) / (threadedRate / cores), ghosts, run.commFraction});
  }
  return table;
}

} // namespace cascade::cli
