#pragma once
// Shared by the libFuzzer harnesses: the input as a file (the readers take paths),
// written to a per-process scratch file under /dev/shm (or the temp folder).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

namespace cascade::fuzz {

/// Writes `data` to a scratch file with `extension` and returns its path (the same
/// path for every call of this process and extension).
inline std::filesystem::path asFile(const std::uint8_t* data, std::size_t size, const std::string& extension) {
  static const std::filesystem::path folder =
      std::filesystem::exists("/dev/shm") ? std::filesystem::path("/dev/shm") : std::filesystem::temp_directory_path();
  const std::filesystem::path path = folder / ("cascade-fuzz-" + std::to_string(::getpid()) + extension);
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
  return path;
}

} // namespace cascade::fuzz
