// The relative RMS error of a probe series against an experiment's table
// (libsph/probes/ExperimentComparison.h), the metric of `cascade bench accuracy`:
// linear series are interpolated exactly, so each case has a closed-form answer.
#include "libsph/Errors.h"
#include "libsph/probes/ExperimentComparison.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

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

namespace {

/// A synthetic band: median m(t) = a triangle peak 2 at t = 2.6 (rising from 0 at 2.4,
/// back to 1 at 2.8, then 1), low = m - 0.2, high = m + 0.2, every 1e-3.
PercentileBand syntheticBand() {
  PercentileBand band;
  for (int k = 0; k <= 7000; ++k) {
    const double t = 1e-3 * k;
    double m = 0;
    if (t >= 2.4 && t <= 2.6) m = 10 * (t - 2.4);
    else if (t > 2.6 && t <= 2.8) m = 2 - 5 * (t - 2.6);
    else if (t > 2.8) m = 1;
    band.time.push_back(t);
    band.median.push_back(m);
    band.low.push_back(m - 0.2);
    band.high.push_back(m + 0.2);
  }
  return band;
}

} // namespace

TEST(ExperimentComparison, BandFileIsReadAndBadRowsAreNamed) {
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "cascade_band_test.csv";
  std::ofstream(file) << "# source\nt,lo,med,hi\n0,-1,0,1\n0.5,0,1,2\n";
  const PercentileBand band = readPercentileBand(file);
  ASSERT_EQ(band.time.size(), 2u);
  EXPECT_DOUBLE_EQ(band.median[1], 1.0);
  EXPECT_DOUBLE_EQ(band.high[0], 1.0);
  std::ofstream(file) << "t,lo,med,hi\n0,-1,0,1\n0,0,1,2\n";  // time not increasing
  try {
    readPercentileBand(file);
    FAIL() << "a repeated time was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cascade_band_test.csv:3"), std::string::npos) << e.what();
  }
  std::filesystem::remove(file);
  EXPECT_THROW(readPercentileBand(file), InputError);
}

// The median itself: no peak error, all in the band. A copy 10 % high and 0.05 late:
// peak error +10 %, time error +0.05. A sine of amplitude 0.1 at 400 /unit (many periods in
// the 5 ms window) on top: noise 0.1 / sqrt(2) (the moving average removes it), and the
// samples outside the band are those where the sine exceeds the band's +-0.2: none.
TEST(ExperimentComparison, ImpactPeakBandFractionAndNoiseOfKnownSeries) {
  const PercentileBand band = syntheticBand();
  TimeSeries median, late, noisy;
  for (std::size_t k = 0; k < band.time.size(); k += 2) {
    const double t = band.time[k];
    median.emplace_back(t, band.median[k]);
    noisy.emplace_back(t, band.median[k] + 0.1 * std::sin(2 * M_PI * 400 * t));
  }
  for (std::size_t k = 0; k < band.time.size(); ++k) {
    const double t = band.time[k] + 0.05;
    if (t <= 7) late.emplace_back(t, 1.1 * band.median[k]);
  }
  const BandComparison exact = compareWithBand(median, band);
  EXPECT_NEAR(exact.reference.value, 2.0, 1e-9);
  EXPECT_NEAR(exact.reference.time, 2.6, 1e-9);
  EXPECT_NEAR(exact.rawPeakError, 0.0, 1e-9);
  // The 5 ms average (half width a = 0.0143) rounds the apex off: its largest value, a / 3
  // after the apex, is 2 - 10 a / 3 (slopes 10 and 5), 5 a / 3 = 2.4 % low.
  EXPECT_NEAR(exact.peakError, -5 * 0.0143 / 3, 0.003);
  EXPECT_NEAR(exact.peakTimeError, 0.0, 0.01);
  EXPECT_DOUBLE_EQ(exact.bandFraction, 1.0);
  EXPECT_NEAR(exact.noise, 0.0, 1e-9);  // a constant 1 over [3, 7]

  const BandComparison shifted = compareWithBand(late, band);
  EXPECT_NEAR(shifted.rawPeakError, 0.10, 1e-9);
  EXPECT_NEAR(shifted.rawPeak.time - shifted.reference.time, 0.05, 1e-6);
  EXPECT_NEAR(shifted.peakTimeError, 0.05, 0.01);
  EXPECT_LT(shifted.bandFraction, 1.0);  // the rise comes late: below the band there

  const BandComparison wobbly = compareWithBand(noisy, band);
  EXPECT_NEAR(wobbly.noise, 0.1 / std::sqrt(2.0), 0.005);
  EXPECT_DOUBLE_EQ(wobbly.bandFraction, 1.0);
}

TEST(ExperimentComparison, MovingAverageOfALineIsTheLine) {
  TimeSeries line;
  for (int k = 0; k <= 100; ++k) line.emplace_back(0.01 * k, 3.0 * 0.01 * k);
  const TimeSeries average = movingAverage(line, 0.05);
  for (std::size_t k = 5; k + 5 < line.size(); ++k) EXPECT_NEAR(average[k].second, line[k].second, 1e-12);
}
