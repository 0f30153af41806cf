#include "apps/common/run_stats.h"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <thread>

#include "dfo_core/timing.h"

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

namespace {

// Busy CPU seconds of all cores since boot (the first line of /proc/stat: everything but idle and
// iowait), NaN when unreadable.
double MachineBusySeconds() {
  std::ifstream stat("/proc/stat");
  std::string cpu;
  unsigned long long user = 0, nice = 0, system = 0, idle = 0, iowait = 0, irq = 0, softirq = 0,
                     steal = 0;
  if (!(stat >> cpu >> user >> nice >> system >> idle >> iowait >> irq >> softirq >> steal) ||
      cpu != "cpu") {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const long ticks = sysconf(_SC_CLK_TCK);
  if (ticks <= 0) return std::numeric_limits<double>::quiet_NaN();
  return static_cast<double>(user + nice + system + irq + softirq + steal) /
         static_cast<double>(ticks);
}

double SelfCpuSeconds() {
  struct rusage usage {};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

}  // namespace

OtherLoadMeter::OtherLoadMeter()
    : start_(std::chrono::steady_clock::now()),
      start_busy_s_(MachineBusySeconds()),
      start_self_s_(SelfCpuSeconds()) {}

double OtherLoadMeter::OtherFraction() const {
  const double wall = MsSince(start_) / 1000.0;
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const double other =
      (MachineBusySeconds() - start_busy_s_) - (SelfCpuSeconds() - start_self_s_);
  if (!(wall > 0.0) || std::isnan(other)) return std::numeric_limits<double>::quiet_NaN();
  return std::clamp(other / (wall * cores), 0.0, 1.0);
}

std::string OtherLoadMeter::Describe() const {
  const double fraction = OtherFraction();
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  std::ostringstream out;
  if (std::isnan(fraction)) {
    out << "load of other processes unknown (/proc/stat unreadable)";
    return out.str();
  }
  out << "other processes used " << std::lround(100.0 * fraction) << "% of the " << cores
      << " cores meanwhile";
  if (fraction > 0.10) out << ": NOT an idle machine, these times are slower than idle ones";
  return out.str();
}

}  // namespace dfo::apps
