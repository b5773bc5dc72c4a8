#include "Commands.h"

#include "libsph/Errors.h"

namespace cascade::cli {

void addBakeCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("bake", "bake (not implemented yet: issue #4)");
  command->allow_extras();
  command->callback([] { throw NotImplementedError("bake: not implemented yet (issue #4)"); });
}

} // namespace cascade::cli
