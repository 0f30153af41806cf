#include "apps/common/run_stats.h"

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace dfo::apps {

double Percentile(std::vector<double> values, double p) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return std::isnan(v); }),
               values.end());
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  p = std::clamp(p, 0.0, 100.0);
  // numpy's "linear" method: rank (n - 1) * p / 100 between the two closest order statistics.
  const double rank = (static_cast<double>(values.size()) - 1.0) * p / 100.0;
  const size_t lo = static_cast<size_t>(std::floor(rank));
  const size_t hi = std::min(lo + 1, values.size() - 1);
  const double w = rank - static_cast<double>(lo);
  return values[lo] + w * (values[hi] - values[lo]);
}

TimingSummary SummariseTimes(const std::vector<double>& times_ms) {
  TimingSummary s;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  double sum = 0.0, max = -std::numeric_limits<double>::infinity();
  for (const double t : times_ms) {
    if (std::isnan(t)) continue;
    ++s.count;
    sum += t;
    max = std::max(max, t);
  }
  s.median_ms = Percentile(times_ms, 50.0);
  s.p95_ms = Percentile(times_ms, 95.0);
  s.mean_ms = s.count > 0 ? sum / static_cast<double>(s.count) : nan;
  s.max_ms = s.count > 0 ? max : nan;
  return s;
}

io::JsonValue TimingToJson(const TimingSummary& summary) {
  io::JsonValue out = io::JsonValue::Object();
  out.Set("median", summary.median_ms);
  out.Set("p95", summary.p95_ms);
  out.Set("mean", summary.mean_ms);
  out.Set("max", summary.max_ms);
  return out;
}

double PeakRssMb() {
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  return static_cast<double>(usage.ru_maxrss) / 1024.0;  // Linux reports kilobytes
}

}  // namespace dfo::apps
