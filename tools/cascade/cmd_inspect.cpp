#include "Commands.h"

#include "libsph/Errors.h"

namespace cascade::cli {

void addInspectCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("inspect", "inspect (not implemented yet: issue #4)");
  command->allow_extras();
  command->callback([] { throw NotImplementedError("inspect: not implemented yet (issue #4)"); });
}

} // namespace cascade::cli
