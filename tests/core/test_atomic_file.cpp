#include "libsph/io/AtomicFile.h"

#include <gtest/gtest.h>

#include <fstream>
#include <stdexcept>

using namespace cascade;
namespace fs = std::filesystem;

namespace {
fs::path freshDir(const char* name) {
  const fs::path dir = fs::temp_directory_path() / name;
  fs::remove_all(dir);
  return dir;
}
} // namespace

TEST(AtomicFile, WritesWholeFileAndCreatesDirectories) {
  const fs::path dir = freshDir("cascade_atomic_write");
  const fs::path path = dir / "a" / "b.txt";
  writeTextAtomically(path, "hello\n");
  EXPECT_EQ(readTextFile(path), "hello\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(path.parent_path()), fs::directory_iterator{}), 1);
  fs::remove_all(dir);
}

TEST(AtomicFile, FailedWriteKeepsTheOldFileAndLeavesNoTemporary) {
  const fs::path dir = freshDir("cascade_atomic_fail");
  const fs::path path = dir / "keep.txt";
  writeTextAtomically(path, "old");
  EXPECT_THROW(writeFileAtomically(path,
                                   [](const fs::path& temp) {
                                     std::ofstream(temp) << "partial";
                                     throw std::runtime_error("disk full");
                                   }),
               std::runtime_error);
  EXPECT_EQ(readTextFile(path), "old");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}), 1);
  fs::remove_all(dir);
}
