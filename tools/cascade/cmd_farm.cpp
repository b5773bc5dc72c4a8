// `cascade farm submit|status|resume|cancel` (docs/farm.md): a shot's stages as Slurm jobs.
#include "Commands.h"

#include "distributed/MpiRuntime.h"
#include "libsph/Errors.h"
#include "SceneCommand.h"

#include "farm/FarmSubmit.h"
#include "libsph/scene/SceneJson.h"

#include <iostream>
#include <memory>

namespace cascade::cli {

void addFarmCommand(CLI::App& app) {
  CLI::App* farm = app.add_subcommand("farm", "Run a shot's stages as Slurm jobs on a cluster: submit, status, resume, cancel");
  farm->require_subcommand(1);

  CLI::App* submit = farm->add_subcommand(
      "submit", "Set up OUT for a scene and submit its bake chunks, whitewater, surface and render jobs");
  struct SubmitArgs {
    std::string scene, out;
    std::vector<std::string> sets;
    farm::SubmitSettings settings;
    bool noWhitewater = false, noRender = false;
  };
  auto s = std::make_shared<SubmitArgs>();
  farm::JobOptions& o = s->settings.options;
  o.bakeCpus = 0;
  submit->add_option("scene", s->scene, "Scene file (JSON)")->required();
  submit->add_option("-o,--out", s->out, "Output folder, on storage every node mounts at the same path (default out/<scene name>)");
  submit->add_option("--set", s->sets, "Override a scene value: KEY=VALUE (dotted path)")->take_all();
  submit->add_option("--chunk", s->settings.chunk, "Frames per bake (and whitewater) job")->capture_default_str();
  submit->add_option("--task-frames", s->settings.taskFrames, "Frames per surface and render array task")
      ->capture_default_str();
  submit->add_option("--partition", o.partition, "Slurm partition (default: the cluster's default)");
  submit->add_option("--account", o.account, "Slurm account to charge");
  submit->add_option("--time", o.bakeTime, "Time limit of each bake and whitewater job (sbatch --time)");
  submit->add_option("--task-time", o.taskTime, "Time limit of each surface and render task");
  submit->add_option("--bake-cpus", o.bakeCpus,
                     "Cores of each bake and whitewater job, of each rank with --ranks (default: a node's, shared)");
  submit->add_option("--ranks", o.bakeRanks,
                     "MPI ranks of each bake job (srun --mpi=pmix; docs/distributed.md)")->capture_default_str();
  submit->add_option("--task-cpus", o.taskCpus, "Cores of each surface and render task")->capture_default_str();
  submit->add_option("--bake-mem", o.bakeMemory, "Memory of each bake and whitewater job (sbatch --mem, e.g. 16G)");
  submit->add_option("--sbatch", o.sbatch, "One more sbatch option for every job, e.g. --sbatch=--qos=high")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->allow_extra_args(false);
  submit->add_option("--setup", o.setup, "A shell line every job runs first, e.g. --setup 'module load cascade'")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll)
      ->allow_extra_args(false);
  submit->add_option("--cascade", s->settings.cascade, "The cascade program the jobs run (default: this one)");
  submit->add_flag("--no-whitewater", s->noWhitewater, "Skip the whitewater stage of a scene that has one");
  submit->add_flag("--no-render", s->noRender, "Stop after surfacing");
  submit->add_flag("--dry-run", s->settings.dryRun, "Print the job scripts; write and submit nothing");
  submit->callback([s] {
    if (s->settings.options.bakeRanks > 1 && !distributed::mpiBuilt())
      throw InputError("--ranks: this cascade was built without MPI (install openmpi-bin and libopenmpi-dev, then "
                       "configure again)");
    const scene::Scene scene = scene::loadScene(s->scene, s->sets);
    s->settings.out = defaultOutDir(scene, s->out);
    s->settings.whitewater = !s->noWhitewater;
    s->settings.render = !s->noRender;
    farm::submitShot(scene, s->settings, std::cout);
  });

  CLI::App* status = farm->add_subcommand(
      "status", "Each stage's frames of a farmed shot: done, running, pending, failed (with the job), not submitted");
  struct StatusArgs {
    std::string out;
    bool json = false, record = false;
  };
  auto t = std::make_shared<StatusArgs>();
  status->add_option("OUT", t->out, "Output folder set up by farm submit")->required();
  status->add_flag("--json", t->json, "Print the frames of each state as JSON");
  status->add_flag("--record", t->record, "Mark the stages whose frames are all done in OUT/manifest.json");
  status->callback([t] { farm::printStatus(t->out, t->json, t->record, std::cout); });

  CLI::App* resume = farm->add_subcommand(
      "resume", "Submit again what is missing or failed (nothing that is done, queued or running)");
  struct ResumeArgs {
    std::string out;
    bool dryRun = false;
  };
  auto r = std::make_shared<ResumeArgs>();
  resume->add_option("OUT", r->out, "Output folder set up by farm submit")->required();
  resume->add_flag("--dry-run", r->dryRun, "Print the job scripts; submit nothing");
  resume->callback([r] { farm::resumeShot(r->out, r->dryRun, std::cout); });

  CLI::App* cancel = farm->add_subcommand(
      "cancel", "Cancel every job of a farmed shot that is queued or running (what is on disk stays)");
  auto c = std::make_shared<std::string>();
  cancel->add_option("OUT", *c, "Output folder set up by farm submit")->required();
  cancel->callback([c] { farm::cancelShot(*c, std::cout); });
}

} // namespace cascade::cli
