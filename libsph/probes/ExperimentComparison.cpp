#include "libsph/probes/ExperimentComparison.h"

#include "libsph/Errors.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

namespace cascade {

double interpolateSeries(const TimeSeries& series, double t) {
  if (series.empty() || !(t >= series.front().first) || t > series.back().first) return std::nan("");
  if (series.size() == 1) return series.front().second;
  // The first sample at or after t (k >= 1: t is past the first sample's time).
  const auto after = std::lower_bound(series.begin() + 1, series.end(), t,
                                      [](const std::pair<double, double>& s, double value) { return s.first < value; });
  const auto& [t0, v0] = *(after - 1);
  const auto& [t1, v1] = *after;
  const double w = t1 > t0 ? (t - t0) / (t1 - t0) : 1.0;
  return v0 + w * (v1 - v0);
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

PercentileBand readPercentileBand(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError(file.string() + ": cannot open the percentile band");
  PercentileBand band;
  std::string line;
  int number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || line[0] == '#') continue;
    if (!header) {  // the column names
      header = true;
      continue;
    }
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream row(line);
    double t, low, median, high;
    if (!(row >> t >> low >> median >> high) || !std::isfinite(t) || !std::isfinite(low) || !std::isfinite(median) ||
        !std::isfinite(high) || (!band.time.empty() && !(t > band.time.back())))
      throw InputError(file.string() + ":" + std::to_string(number) +
                       ": expected time,low,median,high with increasing time");
    band.time.push_back(t);
    band.low.push_back(low);
    band.median.push_back(median);
    band.high.push_back(high);
  }
  if (band.time.size() < 2) throw InputError(file.string() + ": fewer than two rows in the percentile band");
  return band;
}

ImpactPeak firstImpact(const TimeSeries& series, double threshold, double duration) {
  ImpactPeak peak{std::nan(""), std::nan(""), std::nan("")};
  for (std::size_t k = 0; k < series.size(); ++k) {
    if (!(series[k].second >= threshold)) continue;
    peak.onset = series[k].first;
    peak.time = series[k].first;
    peak.value = series[k].second;
    for (std::size_t m = k + 1; m < series.size() && series[m].first <= peak.onset + duration; ++m)
      if (series[m].second > peak.value) peak.value = series[m].second, peak.time = series[m].first;
    break;
  }
  return peak;
}

TimeSeries movingAverage(const TimeSeries& series, double window) {
  TimeSeries average(series.size());
  std::size_t lo = 0, hi = 0;
  double sum = 0;
  for (std::size_t k = 0; k < series.size(); ++k) {
    const double t = series[k].first;
    while (hi < series.size() && series[hi].first <= t + 0.5 * window) sum += series[hi++].second;
    while (series[lo].first < t - 0.5 * window) sum -= series[lo++].second;
    average[k] = {t, sum / double(hi - lo)};
  }
  return average;
}

BandComparison compareWithBand(const TimeSeries& series, const PercentileBand& band, const BandWindows& windows) {
  BandComparison result;
  TimeSeries median(band.time.size()), low(band.time.size()), high(band.time.size());
  for (std::size_t k = 0; k < band.time.size(); ++k) {
    median[k] = {band.time[k], band.median[k]};
    low[k] = {band.time[k], band.low[k]};
    high[k] = {band.time[k], band.high[k]};
  }
  // The median's first impact: onset at half its largest value.
  double largest = 0;
  for (double v : band.median) largest = std::max(largest, v);
  result.reference = firstImpact(median, 0.5 * largest, windows.impactDuration);
  const TimeSeries smooth = movingAverage(series, windows.noiseWindow);
  result.peak = firstImpact(smooth, 0.5 * result.reference.value, windows.impactDuration);
  result.rawPeak = firstImpact(series, 0.5 * result.reference.value, windows.impactDuration);
  result.peakError = (result.peak.value - result.reference.value) / result.reference.value;
  result.rawPeakError = (result.rawPeak.value - result.reference.value) / result.reference.value;
  result.peakTimeError = result.peak.time - result.reference.time;
  int inside = 0, counted = 0;
  for (const auto& [t, p] : series) {
    if (t < windows.bandFrom || t > windows.bandTo) continue;
    const double lo = interpolateSeries(low, t), hi = interpolateSeries(high, t);
    if (!std::isfinite(lo) || !std::isfinite(hi)) continue;
    ++counted;
    if (p >= lo && p <= hi) ++inside;
  }
  result.bandFraction = counted > 0 ? double(inside) / counted : std::nan("");
  double sum = 0;
  int n = 0;
  for (std::size_t k = 0; k < series.size(); ++k) {
    if (series[k].first < windows.noiseFrom || series[k].first > windows.noiseTo) continue;
    const double d = series[k].second - smooth[k].second;
    sum += d * d;
    ++n;
  }
  result.noise = n > 0 ? std::sqrt(sum / n) : std::nan("");
  return result;
}

} // namespace cascade
