#include "Commands.h"

#include "libsph/Errors.h"

namespace cascade::cli {

void addRenderCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("render", "render (not implemented yet: issue #6)");
  command->allow_extras();
  command->callback([] { throw NotImplementedError("render: not implemented yet (issue #6)"); });
}

} // namespace cascade::cli
