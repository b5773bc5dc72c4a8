// cascade: the one program of the Cascade pipeline (docs/cli.md).
#include "Commands.h"
#include "HugePages.h"

#include "distributed/MpiRuntime.h"
#include "libsph/Errors.h"
#include "libsph/io/VdbFile.h"
#include "libsph/scene/SceneJson.h"

#include <tbb/global_control.h>

#include <algorithm>
#include <cstdlib>
#include <memory>
#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  using namespace cascade;
  // The subcommand, and --threads N (or --threads=N) anywhere on the line: the worker
  // threads are fixed before any work starts.
  std::string command, threadsText;
  for (int k = 1; k < argc; ++k) {
    const std::string word = argv[k];
    if (word == "--threads" && k + 1 < argc) threadsText = argv[++k];
    else if (word.rfind("--threads=", 0) == 0) threadsText = word.substr(10);
    else if (command.empty() && !word.empty() && word[0] != '-') command = word;
  }
  // Before anything else: the heap on transparent huge pages for the subcommands that
  // surface (restarts this program once; HugePages.h).
  cli::preferHugePages(command, argv);
  installVdbAbortGuard();  // OpenVDB's assertions on corrupt files: exit 2 (VdbFile.h)
  // Under mpirun (or srun --mpi=pmix): MPI for `cascade bake` (distributed/MpiRuntime.h).
  const distributed::MpiSession mpi(argc, argv);
  const bool ranks = mpi.active() && mpi.size() > 1;
  int threads = 0;
  if (!threadsText.empty()) {
    char* end = nullptr;
    const long value = std::strtol(threadsText.c_str(), &end, 10);
    if (*end != '\0' || value < 1 || value > 4096) {
      if (!ranks || mpi.rank() == 0) std::cerr << "cascade: --threads: expected a count of 1 or more, got '" << threadsText << "'\n";
      return kExitBadInput;
    }
    threads = int(value);
  } else if (mpi.active()) {
    threads = distributed::threadsPerRank();  // this machine's cores shared among its ranks
  }
  std::unique_ptr<tbb::global_control> threadLimit;
  if (threads > 0)
    threadLimit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, std::size_t(threads));
  if (distributed::launcherRankCount() > 1 && !distributed::mpiBuilt()) {
    if (std::getenv("OMPI_COMM_WORLD_RANK") == nullptr || std::string(std::getenv("OMPI_COMM_WORLD_RANK")) == "0")
      std::cerr << "cascade: this build has no MPI (configure with OpenMPI installed); run it without mpirun\n";
    return kExitBadInput;
  }
  if (ranks && command != "bake" && command != "bench") {
    if (mpi.rank() == 0)
      std::cerr << "cascade: only `cascade bake` and `cascade bench step` run over MPI ranks; run `cascade " << command
                << "` without mpirun\n";
    return kExitBadInput;
  }
  // Over ranks, bad input and instabilities are found by every rank alike (rank 0 says
  // so); any other failure is one rank's, and stops the others at once.
  const bool speaks = !ranks || mpi.rank() == 0;
  CLI::App app{"cascade: SPH water simulation, surfacing and preview rendering"};
  app.name("cascade");
  app.require_subcommand(1);
  app.set_version_flag("--version", cli::versionText(), "Print the version of cascade and of its libraries");
  app.add_option("--threads", threads,
                 "Worker threads (default: every core; under mpirun, this machine's cores shared among its ranks)");
  app.fallthrough();  // --threads after the subcommand too
  cli::addBakeCommand(app);
  cli::addSurfaceCommand(app);
  cli::addWhitewaterCommand(app);
  cli::addRenderCommand(app);
  cli::addRunCommand(app);
  cli::addBenchCommand(app);
  cli::addInspectCommand(app);
  cli::addSchemaCommand(app);
  cli::addFarmCommand(app);
  app.footer(
      "Exit status: 0 success; 2 bad input; 3 the simulation became unstable; 1 anything else.");

  // A mistyped subcommand is named, with the nearest one (CLI11 alone says only that one is required).
  if (!command.empty()) {
    std::vector<std::string> names;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) names.push_back(sub->get_name());
    const std::string& given = command;
    if (std::find(names.begin(), names.end(), given) == names.end()) {
      const std::string near = scene::nearestWord(given, names);
      std::cerr << "cascade: unknown subcommand '" << given << "'"
                << (near.empty() ? "" : " (did you mean '" + near + "'?)") << " (see cascade --help)\n";
      return kExitBadInput;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& success) {  // --help: printed by CLI11, exit 0
    return app.exit(success);
  } catch (const CLI::ParseError& error) {
    if (speaks) std::cerr << "cascade: " << error.what() << " (see cascade --help)\n";
    return kExitBadInput;
  } catch (const InputError& error) {
    if (speaks) std::cerr << error.what() << '\n';
    return kExitBadInput;
  } catch (const InstabilityError& error) {
    if (speaks) std::cerr << error.what() << '\n';
    return kExitUnstable;
  } catch (const NotImplementedError& error) {
    std::cerr << "cascade: " << error.what() << '\n';
    if (ranks) mpi.abort(kExitFailure);
    return kExitFailure;
  } catch (const std::exception& error) {
    std::cerr << "cascade: " << (ranks ? "rank " + std::to_string(mpi.rank()) + ": " : std::string()) << error.what()
              << '\n';
    if (ranks) mpi.abort(kExitFailure);
    return kExitFailure;
  }
  return kExitSuccess;
}
