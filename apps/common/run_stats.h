// Small measurement helpers for the apps: timing statistics (median, 95th percentile) of per-frame
// stage times, the process's peak resident memory and the other processes' load.
#ifndef DFO_APPS_COMMON_RUN_STATS_H_
#define DFO_APPS_COMMON_RUN_STATS_H_

#include <chrono>
#include <cstddef>
#include <string>
#include <vector>

#include "dfo_io/json.h"

namespace dfo::apps {

// The p-th percentile (p in [0, 100]) of `values` with linear interpolation between the closest
// ranks (numpy.percentile's default). NaN for an empty list; NaN values are ignored.
double Percentile(std::vector<double> values, double p);

// Statistics of a list of durations in milliseconds.
struct TimingSummary {
  size_t count = 0;
  double median_ms = 0.0;  // NaN when count == 0
  double p95_ms = 0.0;     // 95th percentile, NaN when count == 0
  double mean_ms = 0.0;    // NaN when count == 0
  double max_ms = 0.0;     // NaN when count == 0
};

// Summarises `times_ms` (NaN entries, e.g. stages that did not run for a frame, are skipped).
TimingSummary SummariseTimes(const std::vector<double>& times_ms);

// {"median": .., "p95": .., "mean": .., "max": ..} in milliseconds (null when no sample).
io::JsonValue TimingToJson(const TimingSummary& summary);

// Peak resident set size of this process in MiB (getrusage ru_maxrss), 0 when unknown.
double PeakRssMb();

// How busy other processes kept the cores while a benchmark ran: the machine's busy CPU time
// (/proc/stat) minus this process's own (getrusage) between construction and Describe(). The
// benchmarks print it beside their times, which are not comparable when other work shares the
// cores (e.g. a training run makes the networks ~1.4x slower on 2 cores).
class OtherLoadMeter {
 public:
  OtherLoadMeter();  // starts measuring
  // Fraction of all cores' time used by other processes since construction (0 = idle machine;
  // NaN when /proc/stat cannot be read).
  double OtherFraction() const;
  // "other processes used 3% of the 2 cores meanwhile" (+ a warning above 10%).
  std::string Describe() const;

 private:
  std::chrono::steady_clock::time_point start_;
  double start_busy_s_ = 0.0;  // machine-wide, NaN when unknown
  double start_self_s_ = 0.0;
};

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_RUN_STATS_H_
