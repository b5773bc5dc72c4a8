#include "Commands.h"

#include "libsph/Errors.h"

namespace cascade::cli {

void addSurfaceCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("surface", "surface (not implemented yet: issue #5)");
  command->allow_extras();
  command->callback([] { throw NotImplementedError("surface: not implemented yet (issue #5)"); });
}

} // namespace cascade::cli
