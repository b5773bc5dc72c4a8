/// @file WhitewaterStage.h
/// @brief The whitewater stage: OUT/particles -> OUT/whitewater/whitewater.NNNN.vdb
///        (and .ply), a simulation over the bake's caches, never inside the bake.
///
/// Frame k's file holds the diffuse particles at frame k's time. The first
/// cached frame has none (whitewater needs a past); each later frame advances
/// the one before it over the interval between the two caches
/// (WhitewaterSolver, FluidInterval), with birth rates from the earlier
/// frame's potentials (Potentials.h). So frames are made in order: a range
/// A-B starts from the latest good file before A (one made with the same
/// inputs: its cascade_input_hash), or from the first frame, and writes every
/// frame it makes. Frames in the range that are already good are kept unless
/// forced. Each file is written atomically, behind the next frame, which
/// starts from exactly what the file holds (roundPositionsAsStored), so a run
/// killed at any point and started again writes the same particles as an
/// unbroken one.
///
/// Limits "auto": the clamping ranges come from the potentials of up to 16
/// frames spread over all the caches (Potentials.h, limitsFromStatistics),
/// kept in OUT/whitewater/limits.json with the input hash and the cached
/// frames they were made from. The limits enter the frames' input hash: when
/// more of the bake is cached (a run on a bake still going), they are made
/// again, and frames made with other limits are remade, never kept.
#pragma once

#include "libsph/io/OutputLayout.h"
#include "libsph/scene/Scene.h"
#include "whitewater/Potentials.h"
#include "whitewater/WhitewaterSolver.h"

#include <array>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace cascade::whitewater {

struct WhitewaterStageOptions {
  scene::WhitewaterSettings settings;
  Vec3r gravity{0, 0, Real(-9.81)};
  /// Diffuse particles outside it are removed; none: the first frame's fluid
  /// bounds grown by their largest extent on every side.
  std::optional<RemovalBox> domain;
  double fps = 0;      ///< frame times when the caches carry none (0: 30 fps)
  double spacing = 0;  ///< the fluid's particle spacing, m (0: the caches')
  FrameRange frames;   ///< frames to make (unset bounds: the caches')
  bool force = false;  ///< remake frames of the range that are already good
  /// The bake's last frame (the scene's frame count), when known: automatic
  /// limits made while the caches stop before it say so.
  std::optional<int> bakeLastFrame;
};

struct WhitewaterFrameReport {
  int frame = 0;
  bool skipped = false;  ///< already good, kept
  std::size_t fluid = 0;
  std::array<std::size_t, kDiffuseTypeCount> counts{};
  IntervalStats stats;
  double seconds = 0;        ///< wall time of the frame
  double potentialSeconds = 0;  ///< of which the fluid's potentials
};

struct WhitewaterRunReport {
  PotentialLimits limits;
  bool limitsFromStatistics = false;
  /// Automatic limits from a bake that is not finished (its caches stop before
  /// bakeLastFrame): the frames made with them are remade once it is.
  bool limitsFromPartialBake = false;
  std::string inputHash;  ///< of the frames: the stage's inputs and its limits
  std::vector<WhitewaterFrameReport> frames;
};

/// Makes this process keep freed memory for reuse (glibc: no mmap, no trim).
/// The stage allocates the same large arrays every frame; fresh pages for them
/// cost page faults worth about a tenth of its time (measured on the bench splash).
void keepFreedMemory();

/// What a bake at particle spacing `spacing` gives each particle of the rates:
/// (spacing / reference_spacing)^2 for rates per area of water surface, ^3 per
/// volume of water (so that a finer bake, with more particles on the same
/// surface or in the same water, makes as many births a second from the same
/// potentials), 1 per particle.
double spacingRateFactor(const scene::WhitewaterSettings& settings, double spacing);

/// The factor on both birth rates (eq. 7): rate_scale times spacingRateFactor().
double birthRateScale(const scene::WhitewaterSettings& settings, double spacing);

/// The input hash of the stage: its settings, gravity and domain, chained on
/// the caches' "bake_hash" (empty for caches from other tools).
std::string whitewaterHash(const WhitewaterStageOptions& options, const std::string& bakeHash);

/// Runs the stage. Throws InputError for bad input (no caches in the range, a
/// cache without velocities, a gap in the frames, unreadable files) naming
/// the file; frames written before the error stay. `log` gets one line per
/// frame and the limits.
WhitewaterRunReport runWhitewater(const OutputLayout& layout, const WhitewaterStageOptions& options,
                                  const std::function<void(const WhitewaterFrameReport&)>& progress = {},
                                  const std::function<void(const std::string&)>& log = {});

} // namespace cascade::whitewater
