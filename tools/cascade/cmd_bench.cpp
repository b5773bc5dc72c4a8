#include "Benchmarks.h"
#include "Commands.h"

#include "distributed/MpiRuntime.h"
#include "libsph/Errors.h"

#include <iostream>
#include <map>
#include <memory>

namespace cascade::cli {

BenchPaths& benchPaths() {
  static BenchPaths paths;
  return paths;
}

void addBenchCommand(CLI::App& app) {
  struct Options {
    std::string kind;
    std::string json;
    std::string plot;
    std::vector<int> ranks;
    std::string from;
    int steps = 0;  // 0: not given (20)
    long mpiChild = 0;
  };
  auto options = std::make_shared<Options>();
  CLI::App* bench = app.add_subcommand("bench", "Run a benchmark and print its table");
  bench->add_option("kind", options->kind, "The benchmark: neighbors|step|accuracy|surface|render|bodies|whitewater")
      ->required()
      ->check(CLI::IsMember({"neighbors", "step", "accuracy", "surface", "render", "bodies", "whitewater"}));
  bench->add_option("--json", options->json, "Also write the table as JSON to FILE");
  bench->add_option("--plot", options->plot, "With accuracy: write the error/run-time plot (PNG) to FILE, the Lobovsky one to FILE-lobovsky (default: next to --json)");
  bench->add_option("--ranks", options->ranks,
                    "With step: MPI rank counts to compare with threads, e.g. 1,2 (runs mpirun -np N)")
      ->delimiter(',')
      ->check(CLI::Range(1, 4096));
  bench->add_option("--from", options->from,
                    "With step: time the bake in OUT from its checkpoint (its last baked frame) instead of the dam breaks");
  bench->add_option("--steps", options->steps, "With step --from: steps to time (default 20, after 2 untimed)")
      ->check(CLI::Range(1, 1000000));
  bench->add_option("--mpi-child", options->mpiChild, "With step under mpirun: one run of --ranks (internal)")
      ->group("");
  bench->callback([options] {
    const distributed::MpiSession* session = distributed::currentSession();
    if (session && session->active() && (options->kind != "step" || options->mpiChild <= 0))
      throw InputError("bench: under mpirun only `bench step --mpi-child SIZE` runs (use `bench step --ranks 1,2`)");
    if (options->mpiChild > 0) {
      benchStepMpiChild(options->mpiChild);
      return;
    }
    if (!options->ranks.empty() && options->kind != "step") throw InputError("--ranks: only with `bench step`");
    if (!options->from.empty() && options->kind != "step") throw InputError("--from: only with `bench step`");
    if (!options->from.empty() && !options->ranks.empty()) throw InputError("--from: not with --ranks");
    if (options->steps > 0 && options->from.empty()) throw InputError("--steps: only with `bench step --from`");
    static const std::map<std::string, BenchTable (*)()> kinds = {
        {"neighbors", benchNeighbors}, {"step", benchStep}, {"accuracy", benchAccuracy},
        {"surface", benchSurface},     {"render", benchRender},     {"bodies", benchBodies},
        {"whitewater", benchWhitewater}};
    benchPaths() = BenchPaths{options->json, options->plot};
    const BenchTable table = !options->from.empty()   ? benchStepFrom(options->from, options->steps > 0 ? options->steps : 20)
                             : options->ranks.empty() ? kinds.at(options->kind)()
                                                      : benchStepRanks(options->ranks, 100000);
    std::cout << table.format() << std::flush;
    if (!options->json.empty()) table.writeJson(options->json);
    table.finish();
  });
}

} // namespace cascade::cli
