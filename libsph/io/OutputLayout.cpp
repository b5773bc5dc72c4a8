#include "libsph/io/OutputLayout.h"

#include "libsph/Errors.h"

#include <algorithm>
#include <cstdio>
#include <cctype>
#include <stdexcept>
#include <vector>

namespace cascade {

std::string OutputLayout::pad(int frame) {
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "%04d", frame);
  return buffer;
}

namespace {
/// Reads the digits at text[pos...] (after spaces) into `digits`, skipping trailing spaces; false if there are none.
bool readNumber(const std::string& text, std::size_t& pos, std::string& digits) {
  while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
  const std::size_t start = pos;
  while (pos < text.size() && std::isdigit(static_cast<unsigned char>(text[pos]))) ++pos;
  digits = text.substr(start, pos - start);
  while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
  return !digits.empty();
}
} // namespace

FrameRange parseFrameRange(const std::string& text) {
  const std::string expected = "--frames: expected A-B with 1 <= A <= B (got '" + text + "')";
  std::size_t pos = 0;
  std::string first, last;
  if (!readNumber(text, pos, first)) throw InputError(expected);
  if (pos < text.size()) {
    if (text[pos] != '-') throw InputError(expected);
    ++pos;
    if (!readNumber(text, pos, last) || pos != text.size()) throw InputError(expected);
  }
  FrameRange range;
  try {
    range.first = std::stoi(first);
    range.last = last.empty() ? *range.first : std::stoi(last);
  } catch (const std::out_of_range&) {
    throw InputError("--frames: frame number out of range (got '" + text + "')");
  }
  if (*range.first < 1 || *range.last < *range.first)
    throw InputError("--frames: expected A-B with 1 <= A <= B (got '" + text + "')");
  return range;
}

bool matchesPrefixAndExtension(const std::string& name, const std::string& prefix, const std::string& extension) {
  const std::size_t head = prefix.size() + 1, tail = extension.size() + 1;
  return name.size() > head + tail && name.compare(0, prefix.size(), prefix) == 0 && name[prefix.size()] == '.' &&
         name.compare(name.size() - extension.size(), extension.size(), extension) == 0 &&
         name[name.size() - tail] == '.';
}

std::optional<int> frameOfFileName(const std::string& name, const std::string& prefix,
                                   const std::string& extension) {
  if (!matchesPrefixAndExtension(name, prefix, extension)) return std::nullopt;
  const std::string digits = name.substr(prefix.size() + 1, name.size() - prefix.size() - extension.size() - 2);
  if (digits.size() < 4 || !std::all_of(digits.begin(), digits.end(),
                                        [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
    return std::nullopt;
  try {
    return std::stoi(digits);
  } catch (const std::out_of_range&) {
    return std::nullopt;
  }
}

std::vector<int> listFrames(const std::filesystem::path& dir, const std::string& prefix,
                            const std::string& extension) {
  std::vector<int> frames;
  std::error_code error;
  if (!std::filesystem::is_directory(dir, error)) return frames;
  for (const auto& entry : std::filesystem::directory_iterator(dir, error))
    if (const auto frame = frameOfFileName(entry.path().filename().string(), prefix, extension))
      frames.push_back(*frame);
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  return frames;
}

void removeFrameFiles(const std::filesystem::path& dir, const std::string& prefix, const std::string& extension) {
  std::error_code error;
  for (int f : listFrames(dir, prefix, extension))
    std::filesystem::remove(dir / (prefix + "." + OutputLayout::pad(f) + "." + extension), error);
}

} // namespace cascade
