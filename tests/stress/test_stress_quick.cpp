// Quick subset of the stability stress suite (default run, < 1 minute): still
// water for 2,000 steps, CFL 1.0 and overlapping particles on a coarse dam
// break, for each solver; and, end to end, an unstable `cascade bake` exits 3
// with the particle, position and time and keeps the frames before it.
#include "StressCases.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

namespace cascade::stress {

class StressQuick : public ::testing::TestWithParam<std::string> {};

TEST_P(StressQuick, StillWater2000Steps) { expectStableOrStopped(stillWater(GetParam(), 2000), GetParam() + " still water 2000 steps"); }

TEST_P(StressQuick, Cfl1) {
  expectStableOrStopped(damBreak(GetParam(), 0.1, [](SimulationSettings& s) { s.solver.cflFactor = 1; }), GetParam() + " CFL 1.0");
}

TEST_P(StressQuick, OverlappingParticles) {
  expectStableOrStopped(damBreak(GetParam(), 0.1, [](SimulationSettings&) {}, true), GetParam() + " overlapping particles");
}

INSTANTIATE_TEST_SUITE_P(Solvers, StressQuick, ::testing::Values("wcsph", "dfsph"));

// End to end: a dam break whose instability threshold is set below the speeds
// it reaches (expected speed 0.25 m/s, factor 2: stop above 0.5 m/s, reached after
// about 0.1 s) must stop with exit status 3 and a message naming particle,
// position and time, and keep the frames written before.
TEST(StressBake, UnstableBakeExitsThreeAndKeepsEarlierFrames) {
  const std::string binary = std::string(CASCADE_BINARY_DIR) + "/cascade";
  if (!std::filesystem::exists(binary)) GTEST_SKIP() << binary << " not built";
  const std::filesystem::path out = std::filesystem::temp_directory_path() / ("cascade_stress_bake_" + std::to_string(::getpid()));
  std::filesystem::remove_all(out);
  const std::string scene = std::string(CASCADE_SOURCE_DIR) + "/scenes/dambreak.json";
  const std::string log = (out.string() + ".log");
  const std::string command = "'" + binary + "' bake '" + scene + "' -o '" + out.string() +
                              "' --set fluid.spacing=0.007 --set solver.type=dfsph --set solver.expected_speed=0.25"
                              " --set solver.instability_speed_factor=2 > '" + log + "' 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status));
  std::ifstream in(log);
  std::stringstream text;
  text << in.rdbuf();
  std::cout << text.str();
  EXPECT_EQ(WEXITSTATUS(status), 3) << text.str();
  static const std::regex form(R"(particle \d+ at \(.*\), t = [0-9.e+-]+ s)");
  EXPECT_TRUE(std::regex_search(text.str(), form)) << text.str();
  std::size_t frames = 0;
  if (std::filesystem::exists(out / "particles"))
    for (const auto& entry : std::filesystem::directory_iterator(out / "particles"))
      if (entry.path().extension() == ".vdb") ++frames;
  EXPECT_GE(frames, 2u) << "the frames before the instability stay on disk";
  std::filesystem::remove_all(out);
  std::filesystem::remove(log);
}

} // namespace cascade::stress
