#include "libsph/Errors.h"
#include "libsph/io/OutputLayout.h"

#include <gtest/gtest.h>

#include <fstream>

using namespace cascade;

TEST(OutputLayout, FramesArePaddedToFourDigits) {
  const OutputLayout layout("out/x");
  EXPECT_EQ(layout.particles(7).string(), "out/x/particles/particles.0007.vdb");
  EXPECT_EQ(layout.mesh(12345).string(), "out/x/mesh/fluid.12345.obj");
  EXPECT_EQ(layout.render(1).string(), "out/x/render/frame.0001.png");
}

TEST(FrameRange, ParsesInclusiveRanges) {
  const FrameRange range = parseFrameRange("3-5");
  EXPECT_FALSE(range.contains(2));
  EXPECT_TRUE(range.contains(3));
  EXPECT_TRUE(range.contains(5));
  EXPECT_FALSE(range.contains(6));
  const FrameRange single = parseFrameRange("4");
  EXPECT_TRUE(single.contains(4));
  EXPECT_FALSE(single.contains(5));
}

TEST(FrameRange, RejectsBadRanges) {
  for (const char* bad : {"0-3", "5-2", "a-b", "", "1-", "-3", "99999999999-1"})
    EXPECT_THROW(parseFrameRange(bad), InputError) << bad;
}

TEST(OutputLayout, ListsOnlyMatchingFrames) {
  const auto dir = std::filesystem::temp_directory_path() / "cascade_list_frames_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  for (const char* name : {"fluid.0003.obj", "fluid.0001.obj", "fluid.0002.obj.tmp", "x.0004.obj",
                           ".fluid.0005.obj.tmp1_0"})
    std::ofstream(dir / name) << "x";
  EXPECT_EQ(listFrames(dir, "fluid", "obj"), (std::vector<int>{1, 3}));
  std::filesystem::remove_all(dir);
}

TEST(OutputLayout, FrameOfFileNameNeedsPrefixFourDigitsAndExtension) {
  EXPECT_EQ(frameOfFileName("fluid.0007.obj", "fluid", "obj"), std::optional<int>(7));
  EXPECT_EQ(frameOfFileName("fluid.12345.obj", "fluid", "obj"), std::optional<int>(12345));
  for (const char* bad : {"fluid.007.obj", "fluid.00a7.obj", "fluid.0007.objx", "fluidx0007.obj", "fluid.0007xobj",
                          "fluid..obj", "fluid.obj", "xfluid.0007.obj", "fluid.99999999999.obj"})
    EXPECT_EQ(frameOfFileName(bad, "fluid", "obj"), std::nullopt) << bad;
  EXPECT_TRUE(matchesPrefixAndExtension("particles.0001.ply", "particles", "ply"));
  EXPECT_FALSE(matchesPrefixAndExtension("particles.ply", "particles", "ply"));
}
