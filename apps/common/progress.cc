#include "apps/common/progress.h"

#include <unistd.h>

#include <cmath>

#include "dfo_core/error.h"

namespace dfo::apps {

ProgressMode ParseProgressMode(const std::string& name) {
  if (name == "auto") return ProgressMode::kAuto;
  if (name == "terminal") return ProgressMode::kTerminal;
  if (name == "plain") return ProgressMode::kPlain;
  if (name == "none") return ProgressMode::kNone;
  throw InputError("progress mode '" + name + "' is unknown, expected auto|terminal|plain|none");
}

ProgressReporter::ProgressReporter(std::FILE* stream, ProgressMode mode, size_t total,
                                   double interval_s, std::string label)
    : stream_(stream),
      mode_(mode),
      total_(total),
      interval_s_(interval_s > 0.0 ? interval_s : 5.0),
      label_(std::move(label)),
      start_(std::chrono::steady_clock::now()) {
  if (mode_ == ProgressMode::kAuto) {
    mode_ = stream_ != nullptr && isatty(fileno(stream_)) ? ProgressMode::kTerminal
                                                          : ProgressMode::kPlain;
  }
  if (stream_ == nullptr) mode_ = ProgressMode::kNone;
}

std::string FormatDuration(double seconds) {
  if (seconds < 120.0) return std::to_string(static_cast<int>(std::ceil(seconds))) + " s";
  const int minutes = static_cast<int>(seconds / 60.0);
  return std::to_string(minutes) + " min " +
         std::to_string(static_cast<int>(seconds - 60.0 * minutes)) + " s";
}

std::string ProgressReporter::FormatLine(const std::string& label, size_t done, size_t total,
                                         double elapsed_s, const std::string& extra) {
  char buf[256];
  const double fps = elapsed_s > 0.0 ? static_cast<double>(done) / elapsed_s : 0.0;
  const double pct =
      total > 0 ? 100.0 * static_cast<double>(done) / static_cast<double>(total) : 100.0;
  std::string eta = "?";
  if (fps > 0.0 && total >= done) eta = FormatDuration(static_cast<double>(total - done) / fps);
  std::snprintf(buf, sizeof(buf), "%s: frame %zu/%zu (%.0f%%)  %.1f fps  ETA %s", label.c_str(),
                done, total, pct, fps, eta.c_str());
  std::string line = buf;
  if (!extra.empty()) line += "  " + extra;
  return line;
}

void ProgressReporter::Update(size_t done, const std::string& extra) {
  if (mode_ == ProgressMode::kNone) return;
  const double now_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const double spacing = mode_ == ProgressMode::kTerminal ? 0.1 : interval_s_;
  if (now_s - last_print_s_ < spacing) return;
  last_print_s_ = now_s;
  const std::string line = FormatLine(label_, done, total_, now_s, extra);
  if (mode_ == ProgressMode::kTerminal) {
    // "\033[K" clears what a longer previous line left on the right.
    std::fprintf(stream_, "\r%s\033[K", line.c_str());
    line_open_ = true;
  } else {
    std::fprintf(stream_, "%s\n", line.c_str());
  }
  std::fflush(stream_);
}

void ProgressReporter::Finish(size_t done, const std::string& extra) {
  if (mode_ == ProgressMode::kNone) return;
  const double now_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  const std::string line = FormatLine(label_, done, total_, now_s, extra);
  if (mode_ == ProgressMode::kTerminal) {
    std::fprintf(stream_, "\r%s\033[K\n", line.c_str());
  } else {
    std::fprintf(stream_, "%s\n", line.c_str());
  }
  line_open_ = false;
  std::fflush(stream_);
}

}  // namespace dfo::apps
