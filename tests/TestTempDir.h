#pragma once
// A fresh, empty scratch directory under the system temp folder for one test,
// named after the test and the process so parallel ctest runs do not collide.
#include <filesystem>
#include <string>

#include <unistd.h>

namespace cascade::test {

inline std::filesystem::path freshTempDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cascade_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

} // namespace cascade::test
