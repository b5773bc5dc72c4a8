// `cascade render OUT [--frames A-B] [--width W] [--height H] [--particles]
//  [--samples N] [--contact-sheet] [--columns C] [--turntable N] [--force]
//  [--mesh-up auto|y|z]`: preview stills (render/RenderStage.h).
#include "Commands.h"

#include "libsph/Errors.h"
#include "render/RenderStage.h"

#include <cstdio>
#include <iostream>
#include <memory>

// LeakSanitizer (CASCADE_SANITIZE builds): Mesa's OSMesa keeps a few small
// per-context buffers until process exit; they are not ours to free.
extern "C" const char* __lsan_default_suppressions() { return "leak:libOSMesa\nleak:libLLVM\n"; }

namespace cascade::cli {

void addRenderCommand(CLI::App& app) {
  struct Options {
    std::string out;
    std::string frames;
    std::string meshUp = "auto";
    render::RenderOptions render;
  };
  auto options = std::make_shared<Options>();
  CLI::App* command = app.add_subcommand(
      "render", "Render preview stills OUT/render/frame.NNNN.png of the fluid meshes (or particles), headless");
  command->add_option("out", options->out, "Output directory of a bake/surface run")->required();
  command->add_option("--frames", options->frames, "Frames A-B (inclusive, 1-based); default: all on disk");
  command->add_option("--width", options->render.width, "Image width in pixels")->capture_default_str();
  command->add_option("--height", options->render.height, "Image height in pixels")->capture_default_str();
  command->add_flag("--particles", options->render.particles,
                    "Draw the particle caches as spheres coloured by speed (a preview before surfacing)");
  command->add_flag("--no-whitewater", [options](std::int64_t) { options->render.whitewater = false; },
                    "Do not draw OUT/whitewater (drawn as white spheres where it exists)");
  command->add_option("--samples", options->render.samples,
                      "Anti-aliasing samples per pixel (1, 2, 4 multisampling; 8 or 16 add 2x2 supersampling)")
      ->capture_default_str();
  command->add_flag("--contact-sheet", options->render.contactSheet,
                    "Also tile all frames of the range into OUT/render/contact_sheet.png");
  command->add_option("--columns", options->render.contactSheetColumns, "Contact sheet columns (0: automatic)");
  command->add_option("--turntable", options->render.turntableViews,
                      "Also render N views around the first frame: OUT/render/turntable.NNNN.png");
  command->add_flag("--force", options->render.force, "Redraw frames whose PNG is already up to date");
  command->add_option("--mesh-up", options->meshUp,
                      "Up axis of the fluid mesh files: auto (header comment, manifest, fit), y or z")
      ->check(CLI::IsMember({"auto", "y", "z"}))
      ->capture_default_str();
  command->callback([options] {
    if (!options->frames.empty()) options->render.frames = parseFrameRange(options->frames);
    options->render.meshUp = options->meshUp == "y"   ? render::RenderOptions::MeshUp::Y
                             : options->meshUp == "z" ? render::RenderOptions::MeshUp::Z
                                                      : render::RenderOptions::MeshUp::Auto;
    const render::RenderReport report = render::renderOutput(
        options->out, options->render, [](const std::string& line) { std::cerr << line << '\n' << std::flush; });
    char summary[512];
    std::snprintf(summary, sizeof summary,
                  "render: %zu frames rendered, %zu up to date, %zu failed; %.3f s per frame, %.1f s in all "
                  "(%dx%d, %d samples, mesh up %s%s%s)\n",
                  report.rendered.size(), report.skipped.size(), report.errors.size(), report.secondsPerFrame,
                  report.seconds, options->render.width, options->render.height, options->render.samples,
                  report.meshUp.c_str(), report.glDescription.empty() ? "" : "; ",
                  report.glDescription.c_str());
    std::cout << summary << std::flush;
    report.throwIfFailed();
  });
}

} // namespace cascade::cli
