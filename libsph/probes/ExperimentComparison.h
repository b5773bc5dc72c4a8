/// @file ExperimentComparison.h
/// @brief A probe's time series against an experiment's table
///        (`cascade bench accuracy`): the relative RMS error
///        sqrt(mean_k ((s(x_k / timeScale - delay) - y_k) / y_k)^2) over the table
///        rows (x_k, y_k) the series covers, with s the series linearly
///        interpolated in time. x is the table's dimensionless time (e.g. Martin
///        & Moyce's T = t sqrt(2 g / a): timeScale = sqrt(2 g / a)); `delay` (s)
///        moves the experiment's time origin, so a row at x is compared with the
///        simulation at x / timeScale - delay (a late release of the column).
///        And an impact pressure series against an experiment's percentile band
///        (Lobovsky et al. 2014): first peak, time in the band, noise.
#pragma once

#include <filesystem>
#include <utility>
#include <vector>

namespace cascade {

/// (time, value) samples in increasing time.
using TimeSeries = std::vector<std::pair<double, double>>;

/// The series linearly interpolated at t; NaN before its first or after its last sample.
double interpolateSeries(const TimeSeries& series, double t);

struct TableError {
  double rms = 0;  ///< relative RMS error; NaN if no row is covered
  int points = 0;  ///< table rows the series covers
};

/// Relative RMS error of `series` against `table` (rows (x, y) with x = t * timeScale, y != 0).
TableError relativeRmsError(const TimeSeries& table, double timeScale, const TimeSeries& series, double delay = 0);

/// An experiment's percentile band over repeated runs: rows (time, low, median, high).
struct PercentileBand {
  std::vector<double> time, low, median, high;
};
/// Reads a CSV of `time,low,median,high` rows ('#' comment lines and one header line
/// skipped). Throws InputError naming the file and line on anything else.
PercentileBand readPercentileBand(const std::filesystem::path& file);

/// The first impact of a series: its onset, the first sample at or above `threshold`, and
/// its peak, the largest value within `duration` after the onset. NaN if never reached.
struct ImpactPeak {
  double onset = 0, time = 0, value = 0;
};
ImpactPeak firstImpact(const TimeSeries& series, double threshold, double duration);

/// Centred moving average of total width `window` (series time units), each sample
/// averaged with the samples within window / 2 of it.
TimeSeries movingAverage(const TimeSeries& series, double window);

/// A pressure series (dimensionless time and pressure, as the band's) against the band.
struct BandComparison {
  /// The series' first impact (of its moving average, the noise window wide: a
  /// transducer's time response), the raw series' and the median's.
  ImpactPeak peak, rawPeak, reference;
  double peakError = 0;        ///< (peak - median peak) / median peak
  double rawPeakError = 0;     ///< the same for the raw series
  double peakTimeError = 0;    ///< peak time - median peak time
  double bandFraction = 0;     ///< samples in [bandFrom, bandTo] within [low, high]
  double noise = 0;            ///< RMS of (series - moving average) over [noiseFrom, noiseTo]
};
struct BandWindows {
  double impactDuration = 0.25;     ///< peak search after the onset (half the median's peak)
  double bandFrom = 2.3, bandTo = 7;
  double noiseFrom = 3, noiseTo = 7;
  double noiseWindow = 0.0286;      ///< moving-average width (5 ms at T = 0.175 s)
};
BandComparison compareWithBand(const TimeSeries& series, const PercentileBand& band, const BandWindows& windows = {});

} // namespace cascade
