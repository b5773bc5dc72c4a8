// `cascade whitewater OUT [--frames A-B] [options]` (docs/cli.md, docs/whitewater.md):
// spray, foam and bubbles over the bake's particle caches. Defaults from
// OUT/scene.json's "whitewater" block, overridden by the options given.
#include "Commands.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/io/OutputLayout.h"
#include "libsph/scene/SceneJson.h"
#include "whitewater/WhitewaterStage.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <sstream>

namespace cascade::cli {

namespace {

/// A command-line option and the scene key it sets.
struct WhitewaterOption {
  const char* flag;
  const char* key;
  const char* help;
  bool pair;         ///< takes MIN,MAX
  const char* type;  ///< shown in --help
};

const std::vector<WhitewaterOption>& whitewaterOptions() {
  static const std::vector<WhitewaterOption> options{
      {"--limits", "limits", "Clamping ranges: auto (from the bake's statistics) | fixed (the ranges below)", false, "auto|fixed"},
      {"--trapped-air", "trapped_air", "Trapped-air clamping range MIN,MAX, m/s (with --limits fixed)", true, "MIN,MAX"},
      {"--wave-crest", "wave_crest", "Wave-crest clamping range MIN,MAX (with --limits fixed)", true, "MIN,MAX"},
      {"--kinetic-energy", "kinetic_energy", "Kinetic energy clamping range MIN,MAX, J/kg (with --limits fixed)", true, "MIN,MAX"},
      {"--trapped-air-rate", "trapped_air_rate", "Births per second of a fluid particle at full trapped-air potential", false, "FLOAT"},
      {"--wave-crest-rate", "wave_crest_rate", "Births per second of a fluid particle at full wave-crest potential", false, "FLOAT"},
      {"--rate-scale", "rate_scale", "Multiplies both birth rates", false, "FLOAT"},
      {"--rates-per", "rates_per", "What the rates are per: particle (the paper) | area | volume (at --reference-spacing)", false, "particle|area|volume"},
      {"--reference-spacing", "reference_spacing", "The particle spacing, m, that rates per area or volume are for", false, "FLOAT"},
      {"--lifetime", "lifetime", "Foam lifetime range MIN,MAX, s", true, "MIN,MAX"},
      {"--spray-neighbors", "spray_neighbors", "Fewer fluid neighbours than this: spray", false, "INT"},
      {"--bubble-neighbors", "bubble_neighbors", "More fluid neighbours than this: a bubble", false, "INT"},
      {"--buoyancy", "buoyancy", "Bubble buoyancy, in units of |g|", false, "FLOAT"},
      {"--bubble-drag", "bubble_drag", "Bubble drag towards the fluid velocity, 1/s", false, "FLOAT"},
      {"--air-drag", "air_drag", "Spray drag towards still air, 1/s (0: ballistic)", false, "FLOAT"},
      {"--substeps", "substeps", "Sub-steps per frame (0: from the fluid's speed)", false, "INT"},
      {"--seed", "seed", "Random seed", false, "INT"},
  };
  return options;
}

struct WhitewaterCommandOptions {
  std::string out, frames;
  std::map<std::string, std::string> given;  ///< flag -> text
  bool ply = false, force = false;
  double spacing = 0;
};

/// The settings: OUT/scene.json's block (or the defaults) with the options given.
whitewater::WhitewaterStageOptions stageOptions(const WhitewaterCommandOptions& command) {
  const OutputLayout layout(command.out);
  whitewater::WhitewaterStageOptions options;
  nlohmann::json block = nlohmann::json::object();
  std::error_code error;
  if (std::filesystem::is_regular_file(layout.scene(), error)) {
    nlohmann::json scene;
    try {
      scene = nlohmann::json::parse(readTextFile(layout.scene()));
    } catch (const nlohmann::json::exception& failure) {
      throw InputError(layout.scene().string() + ": not valid JSON (" + failure.what() + ")");
    }
    if (scene.contains("whitewater") && scene["whitewater"].is_object()) block = scene["whitewater"];
    const auto vector3 = [&](const nlohmann::json& value) {
      return Vec3r(Real(value.at(0).get<double>()), Real(value.at(1).get<double>()), Real(value.at(2).get<double>()));
    };
    try {
      if (scene.contains("gravity")) options.gravity = vector3(scene["gravity"]);
      if (scene.contains("output") && scene["output"].contains("fps")) options.fps = scene["output"]["fps"].get<double>();
      if (scene.contains("output") && scene["output"].contains("fps") && scene["output"].contains("end_time")) {
        scene::Output output;
        output.fps = scene["output"]["fps"].get<double>();
        output.endTime = scene["output"]["end_time"].get<double>();
        options.bakeLastFrame = output.frameCount();
      }
      const nlohmann::json& boundaries = scene.value("boundaries", nlohmann::json::object());
      // Removal: the scene's domain, else the tank raised by its own height (spray rises above it).
      if (boundaries.contains("domain") && boundaries["domain"].is_object()) {
        options.domain = whitewater::RemovalBox{vector3(boundaries["domain"]["min"]), vector3(boundaries["domain"]["max"])};
      } else if (boundaries.contains("tank") && boundaries["tank"].is_object()) {
        whitewater::RemovalBox box{vector3(boundaries["tank"]["min"]), vector3(boundaries["tank"]["max"])};
        box.max.z() += box.max.z() - box.min.z();
        options.domain = box;
      }
    } catch (const nlohmann::json::exception& failure) {
      throw InputError(layout.scene().string() + ": " + failure.what());
    }
  }
  for (const WhitewaterOption& option : whitewaterOptions()) {
    const auto it = command.given.find(option.flag);
    if (it == command.given.end()) continue;
    const std::string& text = it->second;
    nlohmann::json value;
    if (option.pair) {
      const auto comma = text.find(',');
      try {
        if (comma == std::string::npos) throw std::invalid_argument("no comma");
        std::size_t used = 0;
        const double low = std::stod(text.substr(0, comma), &used);
        const double high = std::stod(text.substr(comma + 1));
        value = nlohmann::json::array({low, high});
      } catch (const std::exception&) {
        throw InputError(std::string(option.flag) + ": expected MIN,MAX (got \"" + text + "\")");
      }
    } else {
      try {
        value = nlohmann::json::parse(text);
      } catch (const nlohmann::json::exception&) {
        value = text;
      }
    }
    block[option.key] = value;
  }
  if (command.ply) block["ply"] = true;
  try {
    options.settings = scene::parseWhitewaterSettings(block, "cascade whitewater");
  } catch (const InputError& failure) {
    // Name the option when the bad value came from the command line.
    std::string message = failure.what();
    for (const WhitewaterOption& option : whitewaterOptions()) {
      const std::string path = std::string("whitewater.") + option.key + ":";
      const auto at = message.find(path);
      if (at != std::string::npos && command.given.count(option.flag))
        throw InputError(std::string(option.flag) + ":" + message.substr(at + path.size()));
    }
    throw InputError(layout.scene().string() + ": " + message.substr(message.find(':') + 2));
  }
  options.frames = command.frames.empty() ? FrameRange{} : parseFrameRange(command.frames);
  options.force = command.force;
  if (!(command.spacing >= 0)) {
    std::ostringstream message;
    message << "--spacing: must be > 0 (got " << command.spacing << ")";
    throw InputError(message.str());
  }
  options.spacing = command.spacing;
  return options;
}

void runWhitewaterCommand(const WhitewaterCommandOptions& command) {
  whitewater::keepFreedMemory();
  const OutputLayout layout(command.out);
  if (!std::filesystem::is_directory(layout.root))
    throw InputError(layout.root.string() + ": no such output directory");
  const whitewater::WhitewaterStageOptions options = stageOptions(command);
  const auto start = std::chrono::steady_clock::now();
  std::size_t made = 0;
  const auto progress = [&](const whitewater::WhitewaterFrameReport& report) {
    char line[320];
    if (report.skipped) {
      std::snprintf(line, sizeof line, "whitewater: frame %s kept (made with these inputs; --force remakes it)",
                    OutputLayout::pad(report.frame).c_str());
    } else {
      ++made;
      const auto& c = report.counts;
      std::snprintf(line, sizeof line,
                    "whitewater: frame %s %zu fluid -> %zu spray, %zu foam, %zu bubbles (+%zu born, -%zu dissolved, "
                    "-%zu left; %d substeps) in %.2f s",
                    OutputLayout::pad(report.frame).c_str(), report.fluid, c[0], c[1], c[2], report.stats.born,
                    report.stats.dissolved, report.stats.left, report.stats.substeps, report.seconds);
    }
    std::cerr << line << std::endl;
  };
  const auto log = [](const std::string& line) { std::cerr << line << std::endl; };
  whitewater::runWhitewater(layout, options, progress, log);
  std::fprintf(stderr, "whitewater: %zu frames in %.1f s -> %s\n", made,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
               layout.whitewaterDir().string().c_str());
}

} // namespace

void addWhitewaterCommand(CLI::App& app) {
  auto command = std::make_shared<WhitewaterCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "whitewater", "Spray, foam and bubbles over particle caches: OUT/particles -> OUT/whitewater/*.vdb (Ihmsen 2012)");
  sub->add_option("OUT", command->out, "Output directory of a bake (reads OUT/particles)")->required();
  sub->add_option("--frames", command->frames, "Frame range A-B (inclusive, 1-based); default all");
  for (const WhitewaterOption& option : whitewaterOptions()) {
    const std::string flag = option.flag;
    sub->add_option_function<std::string>(
        flag, [command, flag](const std::string& value) { command->given[flag] = value; }, option.help)
        ->type_name(option.type);
  }
  sub->add_option("--spacing", command->spacing,
                  "The fluid's particle spacing, m (default: from the caches; needed for PLY caches of other tools)");
  sub->add_flag("--ply", command->ply, "Also write OUT/whitewater/*.ply points (Blender reads PLY, not VDB points)");
  sub->add_flag("--force", command->force, "Remake frames of the range made before with the same inputs");
  sub->footer("Defaults: OUT/scene.json's \"whitewater\" block, else those in docs/whitewater.md.");
  sub->callback([command] { runWhitewaterCommand(*command); });
}

} // namespace cascade::cli
