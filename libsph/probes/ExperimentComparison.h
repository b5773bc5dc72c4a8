/// @file ExperimentComparison.h
/// @brief A probe's time series against an experiment's table
///        (`cascade bench accuracy`): the relative RMS error
///        sqrt(mean_k ((s(x_k / timeScale - delay) - y_k) / y_k)^2) over the table
///        rows (x_k, y_k) the series covers, with s the series linearly
///        interpolated in time. x is the table's dimensionless time (e.g. Martin
///        & Moyce's T = t sqrt(2 g / a): timeScale = sqrt(2 g / a)); `delay` (s)
///        moves the experiment's time origin, so a row at x is compared with the
///        simulation at x / timeScale - delay (a late release of the column).
#pragma once

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

} // namespace cascade
