#include "Commands.h"

#include "libsph/Errors.h"

namespace cascade::cli {

void addRunCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("run", "run (not implemented yet: issue #4)");
  command->allow_extras();
  command->callback([] { throw NotImplementedError("run: not implemented yet (issue #4)"); });
}

} // namespace cascade::cli
