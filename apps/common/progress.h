// Progress line for long runs: frame count, frames per second and the estimated time left.
//
// On a terminal the line is redrawn in place with '\r' (at most 10 times a second); otherwise
// (a log file, a pipe, CI) a plain line is printed every `interval_s` seconds and at the end, so
// logs stay readable.
#ifndef DFO_APPS_COMMON_PROGRESS_H_
#define DFO_APPS_COMMON_PROGRESS_H_

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <string>

namespace dfo::apps {

// How progress is shown.
enum class ProgressMode {
  kAuto,      // kTerminal when the stream is a terminal (isatty), else kPlain
  kTerminal,  // one line redrawn with '\r'
  kPlain,     // a new line every interval
  kNone,      // nothing
};

// "auto" | "terminal" | "plain" | "none" -> mode; InputError naming the value otherwise.
ProgressMode ParseProgressMode(const std::string& name);

// A time left or taken as "42 s" (under two minutes, rounded up) or "3 min 5 s".
std::string FormatDuration(double seconds);

// Prints progress of `total` steps (frames) to `stream` (not owned; usually stdout).
class ProgressReporter {
 public:
  // `label` starts every line (e.g. "dfo_run"); interval_s > 0 is the spacing of plain lines.
  ProgressReporter(std::FILE* stream, ProgressMode mode, size_t total, double interval_s,
                   std::string label);

  // Reports that `done` of the total steps are finished; `extra` is appended to the line (e.g.
  // "lost 0"). Cheap when nothing is printed.
  void Update(size_t done, const std::string& extra = "");
  // Prints the final line (a plain line; ends the '\r' line on a terminal).
  void Finish(size_t done, const std::string& extra = "");

  // The mode actually used (kAuto resolved).
  ProgressMode mode() const { return mode_; }

  // The text of one progress line, e.g. "dfo_run: frame 120/500 (24%)  35.2 fps  ETA 11 s".
  static std::string FormatLine(const std::string& label, size_t done, size_t total,
                                double elapsed_s, const std::string& extra);

 private:
  std::FILE* stream_;
  ProgressMode mode_;
  size_t total_;
  double interval_s_;
  std::string label_;
  std::chrono::steady_clock::time_point start_;
  double last_print_s_ = -1e9;
  bool line_open_ = false;  // terminal: a '\r' line is on screen
};

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_PROGRESS_H_
