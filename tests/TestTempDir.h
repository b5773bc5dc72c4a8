#pragma once
// A fresh, empty scratch directory under the system temp folder for one test,
// named after the test and the process so parallel ctest runs do not collide.
// The directories a test process made are removed when it exits, unless
// CASCADE_KEEP_TEST_DATA is set (to look at what a test wrote).
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <system_error>
#include <vector>

#include <unistd.h>

namespace cascade::test {

namespace detail {
/// Removes the registered directories at static destruction (process exit).
class ScratchRegistry {
public:
  void add(const std::filesystem::path& dir) {
    std::lock_guard<std::mutex> lock(mutex_);
    dirs_.push_back(dir);
  }
  ~ScratchRegistry() {
    if (std::getenv("CASCADE_KEEP_TEST_DATA")) return;
    std::error_code ignored;
    for (const auto& dir : dirs_) std::filesystem::remove_all(dir, ignored);
  }

private:
  std::mutex mutex_;
  std::vector<std::filesystem::path> dirs_;
};

inline ScratchRegistry& scratchRegistry() {
  static ScratchRegistry registry;
  return registry;
}
} // namespace detail

inline std::filesystem::path freshTempDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("cascade_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  detail::scratchRegistry().add(dir);
  return dir;
}

} // namespace cascade::test
