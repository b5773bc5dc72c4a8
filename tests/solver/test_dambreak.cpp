// Dam break against Martin & Moyce (1952), n^2 = 2: the surge front Z(T),
// Z = x_front / a, T = t sqrt(2 g / a), for T in [0, 3], measured with the
// `front` probe, within 10 % RMS (relative to the experiment).
#include "SolverTestScenes.h"

#include "libsph/probes/Probes.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>

namespace cascade::test {

namespace {

struct FrontPoint { double T, Z; };

std::vector<FrontPoint> experimentalFront(double maxT) {
  std::vector<FrontPoint> points;
  for (const auto& row : readCsv(dataPath("martin_moyce_1952_n2_2_surge_front_table.csv"))) {
    const double Z = std::stod(row.at(0)), T = std::stod(row.at(1));
    if (T <= maxT) points.push_back({T, Z});
  }
  return points;
}

/// Runs the dam break and returns the RMS relative front error over the table points with T <= 3.
double frontRmsError(double spacing, bool print) {
  const std::vector<FrontPoint> experiment = experimentalFront(3.0);
  EXPECT_GE(experiment.size(), 10u) << "validation table not found or short";
  const double a = kMartinMoyceA;
  const double timeScale = std::sqrt(2 * kStandardGravity / a);  // T = t * timeScale
  auto sim = makeDamBreak(damBreakSettings(spacing));
  double sum = 0;
  for (const FrontPoint& p : experiment) {
    sim->advanceTo(p.T / timeScale);
    const double Z = surgeFront(sim->particles().position, Vec3r::UnitX(), sim->settings().fluid.spacing) / a;
    const double error = (Z - p.Z) / p.Z;
    sum += error * error;
    if (print)
      std::cout << "T " << p.T << "  Z_sph " << Z << "  Z_exp " << p.Z << "  rel " << error << "  steps "
                << sim->stepCount() << "\n";
  }
  return std::sqrt(sum / experiment.size());
}

} // namespace

TEST(DamBreak, SurgeFrontMatchesMartinMoyceWithinTenPercentRms) {
  const double spacing = kMartinMoyceA / 20;  // CI resolution: 20 particles across the column
  const double rms = frontRmsError(spacing, true);
  std::cout << "dam break front RMS error (a/s = 20): " << rms * 100 << " %\n";
  EXPECT_LT(rms, 0.10);
}

} // namespace cascade::test
