#include "Benchmarks.h"
#include "Commands.h"

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
  };
  auto options = std::make_shared<Options>();
  CLI::App* bench = app.add_subcommand("bench", "Run a benchmark and print its table");
  bench->add_option("kind", options->kind, "The benchmark: neighbors|step|accuracy|surface|render|bodies|whitewater")
      ->required()
      ->check(CLI::IsMember({"neighbors", "step", "accuracy", "surface", "render", "bodies", "whitewater"}));
  bench->add_option("--json", options->json, "Also write the table as JSON to FILE");
  bench->add_option("--plot", options->plot, "With accuracy: write the error/run-time plot (PNG) to FILE, the Lobovsky one to FILE-lobovsky (default: next to --json)");
  bench->callback([options] {
    static const std::map<std::string, BenchTable (*)()> kinds = {
        {"neighbors", benchNeighbors}, {"step", benchStep}, {"accuracy", benchAccuracy},
        {"surface", benchSurface},     {"render", benchRender},     {"bodies", benchBodies},
        {"whitewater", benchWhitewater}};
    benchPaths() = BenchPaths{options->json, options->plot};
    const BenchTable table = kinds.at(options->kind)();
    std::cout << table.format() << std::flush;
    if (!options->json.empty()) table.writeJson(options->json);
    table.finish();
  });
}

} // namespace cascade::cli
