// cascade: the one program of the Cascade pipeline (CONTRACT.md).
#include "Commands.h"

#include "libsph/Errors.h"

#include <iostream>

int main(int argc, char** argv) {
  using namespace cascade;
  CLI::App app{"cascade: SPH water simulation, surfacing and preview rendering"};
  app.name("cascade");
  app.require_subcommand(1);
  cli::addBakeCommand(app);
  cli::addSurfaceCommand(app);
  cli::addRenderCommand(app);
  cli::addRunCommand(app);
  cli::addBenchCommand(app);
  cli::addInspectCommand(app);
  app.footer(
      "Exit status: 0 success; 2 bad input; 3 the simulation became unstable; 1 anything else.");

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
