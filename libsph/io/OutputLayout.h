/// @file OutputLayout.h
/// @brief Where each stage's files live under OUT (docs/cli.md), and frame ranges.
#pragma once

#include <filesystem>
#include <optional>
#include <vector>
#include <string>

namespace cascade {

/// Paths of one output directory OUT; frames are numbered from 1, padded to 4 digits.
struct OutputLayout {
  std::filesystem::path root;

  explicit OutputLayout(std::filesystem::path outRoot) : root(std::move(outRoot)) {}

  std::filesystem::path scene() const { return root / "scene.json"; }
  std::filesystem::path manifest() const { return root / "manifest.json"; }
  std::filesystem::path probes() const { return root / "probes.csv"; }
  std::filesystem::path particlesDir() const { return root / "particles"; }
  std::filesystem::path surfaceDir() const { return root / "surface"; }
  std::filesystem::path meshDir() const { return root / "mesh"; }
  std::filesystem::path renderDir() const { return root / "render"; }
  std::filesystem::path geometryDir() const { return root / "geometry"; }
  std::filesystem::path whitewaterDir() const { return root / "whitewater"; }
  /// The solids at rest (written once) and, when any solid moves, at each frame.
  std::filesystem::path solids() const { return geometryDir() / "solids.obj"; }

  std::filesystem::path particles(int frame) const { return particlesDir() / ("particles." + pad(frame) + ".vdb"); }
  std::filesystem::path particlesPly(int frame) const { return particlesDir() / ("particles." + pad(frame) + ".ply"); }
  std::filesystem::path surface(int frame) const { return surfaceDir() / ("surface." + pad(frame) + ".vdb"); }
  std::filesystem::path mesh(int frame) const { return mesh(frame, "obj"); }
  /// The fluid mesh of a frame in a format: "obj" or "ply".
  std::filesystem::path mesh(int frame, const std::string& extension) const {
    return meshDir() / ("fluid." + pad(frame) + "." + extension);
  }
  std::filesystem::path solids(int frame) const { return geometryDir() / ("solids." + pad(frame) + ".obj"); }
  std::filesystem::path whitewater(int frame) const { return whitewaterDir() / ("whitewater." + pad(frame) + ".vdb"); }
  std::filesystem::path whitewaterPly(int frame) const { return whitewaterDir() / ("whitewater." + pad(frame) + ".ply"); }
  std::filesystem::path render(int frame) const { return renderDir() / ("frame." + pad(frame) + ".png"); }

  static std::string pad(int frame);
};

/// An inclusive, 1-based frame range. An unset bound means "as far as exists".
struct FrameRange {
  std::optional<int> first, last;

  bool contains(int frame) const {
    return (!first || frame >= *first) && (!last || frame <= *last);
  }
};

/// Parses "A-B" or "A" (1-based, A <= B); throws InputError("--frames: ...").
FrameRange parseFrameRange(const std::string& text);

/// True if `name` is PREFIX.<anything>.EXTENSION (at least one character between).
bool matchesPrefixAndExtension(const std::string& name, const std::string& prefix, const std::string& extension);

/// The frame number of a file named PREFIX.NNNN.EXTENSION (four or more digits), else none.
std::optional<int> frameOfFileName(const std::string& name, const std::string& prefix,
                                   const std::string& extension);

/// Frame numbers of the files in `dir` named PREFIX.NNNN.EXT, sorted.
std::vector<int> listFrames(const std::filesystem::path& dir, const std::string& prefix,
                            const std::string& extension);

/// Removes every file of `dir` named PREFIX.NNNN.EXT (a stage's frames made from
/// other inputs); files that cannot be removed are left.
void removeFrameFiles(const std::filesystem::path& dir, const std::string& prefix, const std::string& extension);

} // namespace cascade
