// The relative RMS error of a probe series against an experiment's table
// (libsph/probes/ExperimentComparison.h), the metric of `cascade bench accuracy`:
// linear series are interpolated exactly, so each case has a closed-form answer.
#include "libsph/probes/ExperimentComparison.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace cascade;

namespace {

/// s(t) = 1 + 2 t sampled every millisecond over [0, 0.6] s.
TimeSeries linearSeries() {
  TimeSeries series;
  for (int k = 0; k <= 600; ++k) series.emplace_back(1e-3 * k, 1.0 + 2.0 * 1e-3 * k);
  return series;
}

} // namespace

TEST(ExperimentComparison, InterpolatesLinearlyAndIsUndefinedOutsideTheSeries) {
  const TimeSeries series = {{0.0, 0.0}, {1.0, 2.0}, {2.0, 2.0}};
  EXPECT_DOUBLE_EQ(interpolateSeries(series, 0.25), 0.5);
  EXPECT_DOUBLE_EQ(interpolateSeries(series, 1.5), 2.0);
  EXPECT_DOUBLE_EQ(interpolateSeries(series, 2.0), 2.0);
  EXPECT_TRUE(std::isnan(interpolateSeries(series, -0.01)));
  EXPECT_TRUE(std::isnan(interpolateSeries(series, 2.01)));
  EXPECT_TRUE(std::isnan(interpolateSeries({}, 0.0)));
}

TEST(ExperimentComparison, RelativeRmsOfAScaledSeriesAndOfALateRelease) {
  const double timeScale = 10;  // x = 10 t
  const double delay = 0.05;    // s: the experiment started this late
  const TimeSeries series = linearSeries();
  // The experiment's rows: the same flow released `delay` later, y = s(x / 10 - delay).
  TimeSeries table;
  for (double x : {1.0, 2.0, 3.0, 4.0, 5.0}) table.emplace_back(x, 1.0 + 2.0 * (x / timeScale - delay));

  const TableError shifted = relativeRmsError(table, timeScale, series, delay);
  EXPECT_EQ(shifted.points, 5);
  EXPECT_NEAR(shifted.rms, 0.0, 1e-12);

  // Raw, the simulation leads by s(t) - s(t - delay) = 2 delay = 0.1 at every row.
  double sum = 0;
  for (const auto& [x, y] : table) sum += (0.1 / y) * (0.1 / y);
  const TableError raw = relativeRmsError(table, timeScale, series);
  EXPECT_EQ(raw.points, 5);
  EXPECT_NEAR(raw.rms, std::sqrt(sum / 5), 1e-12);

  // A series 10 % high everywhere is 10 % off at every row.
  TimeSeries high = series;
  for (auto& sample : high) sample.second *= 1.1;
  EXPECT_NEAR(relativeRmsError(table, timeScale, high, delay).rms, 0.1, 1e-12);
}

TEST(ExperimentComparison, RowsTheSeriesDoesNotCoverAreLeftOut) {
  const TimeSeries series = linearSeries();                              // t in [0, 0.6] s
  const TimeSeries table = {{2.0, 1.4}, {6.0, 2.2}, {7.0, 9.9}, {9.0, 9.9}};  // x = 7, 9: t = 0.7, 0.9 s
  const TableError error = relativeRmsError(table, 10, series);
  EXPECT_EQ(error.points, 2);
  EXPECT_NEAR(error.rms, 0.0, 1e-12);
  EXPECT_TRUE(std::isnan(relativeRmsError(table, 10, {}).rms));
  EXPECT_EQ(relativeRmsError(table, 10, {}).points, 0);
}
