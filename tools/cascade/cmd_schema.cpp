// `cascade schema [--markdown]` (docs/cli.md): the scene format as a JSON Schema
// for editors, or as the reference page docs/scenes.md (libsph/scene/SceneSchema.h).
#include "Commands.h"

#include "libsph/scene/SceneSchema.h"

#include <iostream>
#include <memory>

namespace cascade::cli {

void addSchemaCommand(CLI::App& app) {
  CLI::App* command = app.add_subcommand("schema", "Print the scene format as a JSON Schema (or as docs/scenes.md)");
  auto markdown = std::make_shared<bool>(false);
  command->add_flag("--markdown", *markdown, "Print the reference page docs/scenes.md instead");
  command->callback([markdown] {
    if (*markdown) std::cout << scene::sceneKeysMarkdown();
    else std::cout << scene::sceneJsonSchema().dump(2) << "\n";
  });
}

} // namespace cascade::cli
