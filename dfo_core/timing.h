// Wall time on the steady clock, in milliseconds (the timings dfo reports).
#ifndef DFO_CORE_TIMING_H_
#define DFO_CORE_TIMING_H_

#include <chrono>

namespace dfo {

// Milliseconds from `start` to `end`.
inline double MsBetween(std::chrono::steady_clock::time_point start,
                        std::chrono::steady_clock::time_point end) {
  return std::chrono::duration<double, std::milli>(end - start).count();
}

// Milliseconds since `start`.
inline double MsSince(std::chrono::steady_clock::time_point start) {
  return MsBetween(start, std::chrono::steady_clock::now());
}

}  // namespace dfo

#endif  // DFO_CORE_TIMING_H_
