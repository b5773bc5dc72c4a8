#include "libsph/probes/ExperimentComparison.h"

#include <cmath>

namespace cascade {

double interpolateSeries(const TimeSeries& series, double t) {
  if (series.empty() || t < series.front().first) return std::nan("");
  for (std::size_t k = 1; k < series.size(); ++k)
    if (series[k].first >= t) {
      const auto& [t0, v0] = series[k - 1];
      const auto& [t1, v1] = series[k];
      const double w = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
      return v0 + w * (v1 - v0);
    }
  return t == series.back().first ? series.back().second : std::nan("");
}

TableError relativeRmsError(const TimeSeries& table, double timeScale, const TimeSeries& series, double delay) {
  TableError result;
  double sum = 0;
  for (const auto& [x, expected] : table) {
    const double value = interpolateSeries(series, x / timeScale - delay);
    if (!std::isfinite(value) || expected == 0) continue;
    const double error = (value - expected) / expected;
    sum += error * error;
    ++result.points;
  }
  result.rms = result.points > 0 ? std::sqrt(sum / result.points) : std::nan("");
  return result;
}

} // namespace cascade
