// cascade: the one program of the Cascade pipeline (docs/cli.md).
#include "Commands.h"

#include "libsph/Errors.h"
#include "libsph/io/VdbFile.h"
#include "libsph/scene/SceneJson.h"

#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  using namespace cascade;
  installVdbAbortGuard();  // OpenVDB's assertions on corrupt files: exit 2 (VdbFile.h)
  CLI::App app{"cascade: SPH water simulation, surfacing and preview rendering"};
  app.name("cascade");
  app.require_subcommand(1);
  app.set_version_flag("--version", cli::versionText(), "Print the version of cascade and of its libraries");
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
  if (argc > 1 && argv[1][0] != '-') {
    std::vector<std::string> names;
    for (const CLI::App* command : app.get_subcommands([](const CLI::App*) { return true; })) names.push_back(command->get_name());
    const std::string given = argv[1];
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
    std::cerr << "cascade: " << error.what() << " (see cascade --help)\n";
    return kExitBadInput;
  } catch (const InputError& error) {
    std::cerr << error.what() << '\n';
    return kExitBadInput;
  } catch (const InstabilityError& error) {
    std::cerr << error.what() << '\n';
    return kExitUnstable;
  } catch (const NotImplementedError& error) {
    std::cerr << "cascade: " << error.what() << '\n';
    return kExitFailure;
  } catch (const std::exception& error) {
    std::cerr << "cascade: " << error.what() << '\n';
    return kExitFailure;
  }
  return kExitSuccess;
}
