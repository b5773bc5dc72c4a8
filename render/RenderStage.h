/// @file RenderStage.h
/// @brief The render stage: preview stills of an output directory OUT
///        (docs/cli.md), the entry point of `cascade render` and of the
///        render step of `cascade run`.
///
/// Reads (stages talk through files only):
///  - OUT/mesh/fluid.NNNN.obj, the water surface, or with `particles` the
///    caches OUT/particles/particles.NNNN.vdb (or .ply) drawn as spheres of
///    radius spacing/2 coloured by speed (white at sqrt(2 g H), H the stage height);
///  - OUT/whitewater/whitewater.NNNN.vdb, where it exists: spray, foam and
///    bubbles as small white spheres (foam the largest);
///  - OUT/geometry/solids.obj, the solids in world coordinates, one group per
///    solid (a group whose name contains "tank" is drawn cut away on the
///    camera's side), if present; where solids move, OUT/geometry/solids.NNNN.obj
///    holds each frame's and is drawn in its place;
///  - OUT/scene.json "camera" and "lights" (and the tank box for framing), if
///    present; otherwise an automatic framing camera and default lights.
/// Writes OUT/render/frame.NNNN.png (sRGB, 8 bit), optionally
/// OUT/render/contact_sheet.png and OUT/render/turntable.NNNN.png, atomically.
///
/// Mesh axes. Scenes are z up. A fluid OBJ may be y-up (surfacing writes
/// (x, y, z) -> (x, z, -y) for y-up importers by default); render turns it
/// back. With MeshUp::Auto the axis of the fluid meshes is, in this order:
///  1. a header comment of the OBJ: "# up: y" / "# up: z" (also "y-up",
///     "up_axis y" ...);
///  2. OUT/manifest.json stages.surface: "obj_up_axis": "y"|"z" or
///     "obj_y_up": true|false;
///  3. the orientation whose bounds fit the scene's domain/tank (or the solids) better;
///  4. otherwise y-up, the surfacing default.
/// solids.obj is always z-up world coordinates (the bake writes it).
///
/// Skipping: unless `force`, a frame whose PNG is newer than its inputs and
/// was made with the same settings (stored in the PNG's text) is not redrawn.
#pragma once

#include "libsph/io/OutputLayout.h"

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace cascade::render {

struct RenderOptions {
  int width = 1280;
  int height = 720;
  int samples = 4;           ///< anti-aliasing samples per pixel (1, 2, 4; more adds supersampling)
  bool particles = false;    ///< draw particle caches instead of the fluid meshes
  bool whitewater = true;    ///< draw OUT/whitewater/whitewater.NNNN.vdb where it exists
  FrameRange frames;         ///< unset bounds: as far as files exist
  bool contactSheet = false; ///< also OUT/render/contact_sheet.png of all frames in the range
  int contactSheetColumns = 0;    ///< 0: automatic
  int contactSheetWidth = 2048;   ///< maximum sheet width, pixels
  int turntableViews = 0;    ///< > 0: also that many views of the first frame around the target
  bool force = false;        ///< redraw frames even if their PNG is up to date
  enum class MeshUp { Auto, Z, Y };
  MeshUp meshUp = MeshUp::Auto;
};

struct RenderReport {
  std::vector<int> rendered;                  ///< frames drawn
  std::vector<int> skipped;                   ///< frames whose PNG was up to date
  std::vector<std::string> errors;            ///< one line per failed frame, naming the file
  bool badInput = false;                      ///< every error was bad input (InputError)
  std::vector<std::filesystem::path> written; ///< files written
  double seconds = 0;                         ///< wall time of the whole stage
  double secondsPerFrame = 0;                 ///< mean over rendered frames (rendering + PNG)
  std::string glDescription;                  ///< OpenGL version and renderer used
  std::string meshUp;                         ///< "z" or "y" and how it was decided

  /// Throws InputError (bad input) or std::runtime_error naming the first
  /// failed file and how many frames failed, if any did.
  void throwIfFailed() const;
};

/// Renders the frames of OUT. A frame that fails (missing or broken mesh or
/// cache) is reported in RenderReport::errors and the others still render.
/// Throws InputError only when nothing can be done at all (no frames, bad
/// scene.json, bad options). `log` receives one progress line per frame.
RenderReport renderOutput(const std::filesystem::path& out, const RenderOptions& options,
                          const std::function<void(const std::string&)>& log = {});

} // namespace cascade::render
