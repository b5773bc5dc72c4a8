#include "libsph/io/OutputLayout.h"

#include "libsph/Errors.h"

#include <algorithm>
#include <cstdio>
#include <regex>
#include <vector>

namespace cascade {

std::string OutputLayout::pad(int frame) {
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "%04d", frame);
  return buffer;
}

FrameRange parseFrameRange(const std::string& text) {
  static const std::regex pattern(R"(^\s*(\d+)\s*(?:-\s*(\d+)\s*)?$)");
  std::smatch match;
  if (!std::regex_match(text, match, pattern))
    throw InputError("--frames: expected A-B with 1 <= A <= B (got '" + text + "')");
  FrameRange range;
  try {
    range.first = std::stoi(match[1].str());
    range.last = match[2].matched ? std::stoi(match[2].str()) : *range.first;
  } catch (const std::out_of_range&) {
    throw InputError("--frames: frame number out of range (got '" + text + "')");
  }
  if (*range.first < 1 || *range.last < *range.first)
    throw InputError("--frames: expected A-B with 1 <= A <= B (got '" + text + "')");
  return range;
}

std::vector<int> listFrames(const std::filesystem::path& dir, const std::string& prefix,
                            const std::string& extension) {
  std::vector<int> frames;
  std::error_code error;
  if (!std::filesystem::is_directory(dir, error)) return frames;
  const std::regex pattern("^" + prefix + R"(\.(\d{4,})\.)" + extension + "$");
  for (const auto& entry : std::filesystem::directory_iterator(dir, error)) {
    std::smatch match;
    const std::string name = entry.path().filename().string();
    if (std::regex_match(name, match, pattern)) frames.push_back(std::stoi(match[1].str()));
  }
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  return frames;
}

} // namespace cascade
