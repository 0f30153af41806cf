#include "dfo_io/curve_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_io/image_file_writer.h"

namespace dfo::io {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
// Distinct BGR colours (tab10-like).
const cv::Scalar kColours[] = {{180, 119, 31},  {14, 127, 255}, {44, 160, 44},   {40, 39, 214},
                               {189, 103, 148}, {75, 86, 140},  {194, 119, 227}, {127, 127, 127},
                               {34, 189, 188},  {207, 190, 23}};

double NiceStep(double range, int target) {
  const double raw = range / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double r = raw / magnitude;
  return (r < 1.5 ? 1.0 : r < 3.5 ? 2.0 : r < 7.5 ? 5.0 : 10.0) * magnitude;
}

std::string Format(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4g", std::abs(v) < 1e-12 ? 0.0 : v);
  return buf;
}

// Axes shared by the curve and scatter plots: data ranges (y optionally in log10), the mapping to
// pixels, grid, tick labels, frame, axis labels and title, and writing the PNG.
class PlotAxes {
 public:
  // `extra_bottom` pixels are kept free under the x axis label (for notes).
  PlotAxes(int width, int height, bool log_y, bool has_title, int extra_bottom = 0)
      : width_(width),
        height_(height),
        log_y_(log_y),
        top_(has_title ? 52 : 20),
        bottom_(50 + extra_bottom) {}

  bool Drawable(double x, double y) const {
    return std::isfinite(x) && std::isfinite(y) && (!log_y_ || y > 0.0);
  }
  // Widens the ranges to hold (x, y) when drawable.
  void Include(double x, double y) {
    if (!Drawable(x, y)) return;
    x_min_ = std::min(x_min_, x);
    x_max_ = std::max(x_max_, x);
    y_min_ = std::min(y_min_, Ty(y));
    y_max_ = std::max(y_max_, Ty(y));
  }
  bool Empty() const { return !std::isfinite(x_min_); }
  // Pads the ranges: `x_pad` and `y_pad` as fractions of each span (degenerate spans widened).
  void Finish(double x_pad, double y_pad) {
    if (x_max_ - x_min_ < 1e-12) {
      x_min_ -= x_pad > 0 ? 0.5 : 0.0;
      x_max_ = x_min_ + 1.0;
    }
    if (y_max_ - y_min_ < 1e-12) {
      y_min_ -= 0.5;
      y_max_ += 0.5;
    }
    const double px = x_pad * (x_max_ - x_min_), py = y_pad * (y_max_ - y_min_);
    x_min_ -= px;
    x_max_ += px;
    y_min_ -= py;
    y_max_ += py;
  }

  int Px(double x) const {
    return left_ + static_cast<int>((x - x_min_) / (x_max_ - x_min_) * Pw());
  }
  int Py(double y) const { return PyT(Ty(y)); }
  cv::Point P(double x, double y) const { return {Px(x), Py(y)}; }
  int left() const { return left_; }
  int top() const { return top_; }
  int Pw() const { return width_ - left_ - right_; }
  int Ph() const { return height_ - top_ - bottom_; }

  // White image with grid, ticks, frame, labels and title.
  cv::Mat Draw(const std::string& title, const std::string& x_label,
               const std::string& y_label) const {
    cv::Mat img(height_, width_, CV_8UC3, cv::Scalar(255, 255, 255));
    const int pw = Pw(), ph = Ph();
    const cv::Scalar grid(225, 225, 225), text(60, 60, 60);
    const double xs = NiceStep(x_max_ - x_min_, 8);
    for (double x = std::ceil(x_min_ / xs) * xs; x <= x_max_ + 1e-9 * xs; x += xs) {
      cv::line(img, {Px(x), top_}, {Px(x), top_ + ph}, grid, 1);
      cv::putText(img, Format(x), {Px(x) - 15, top_ + ph + 18}, kFont, 0.4, text, 1, cv::LINE_AA);
    }
    std::vector<double> y_ticks;  // in plotted units (log10 on a log axis)
    if (log_y_) {
      // Decades; with less than two decades in view also 2 and 5 times them.
      const bool fine = y_max_ - y_min_ < 2.0;
      for (double k = std::floor(y_min_); k <= std::ceil(y_max_); k += 1.0) {
        for (const double m : {1.0, 2.0, 5.0}) {
          if (m != 1.0 && !fine) continue;
          const double t = k + std::log10(m);
          if (t >= y_min_ && t <= y_max_) y_ticks.push_back(t);
        }
      }
      if (y_ticks.size() < 2) {
        // Less than a factor of 2 in view: evenly spaced values, placed on the log axis.
        y_ticks.clear();
        const double lo = std::pow(10.0, y_min_), hi = std::pow(10.0, y_max_);
        const double step = NiceStep(hi - lo, 5);
        for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * step; v += step) {
          if (v > 0) y_ticks.push_back(std::log10(v));
        }
      }
    } else {
      const double ys = NiceStep(y_max_ - y_min_, 6);
      for (double t = std::ceil(y_min_ / ys) * ys; t <= y_max_ + 1e-9 * ys; t += ys) {
        y_ticks.push_back(t);
      }
    }
    for (const double t : y_ticks) {
      cv::line(img, {left_, PyT(t)}, {left_ + pw, PyT(t)}, grid, 1);
      const std::string label = log_y_ ? Format(std::pow(10.0, t)) : Format(t);
      cv::putText(img, label, {5, PyT(t) + 4}, kFont, 0.4, text, 1, cv::LINE_AA);
    }
    cv::rectangle(img, {left_, top_}, {left_ + pw, top_ + ph}, cv::Scalar(0, 0, 0), 1);
    cv::putText(img, x_label, {left_ + pw / 2 - 30, top_ + ph + 40}, kFont, 0.5, text, 1,
                cv::LINE_AA);
    cv::putText(img, y_label + (log_y_ ? " (log)" : ""), {5, top_ - 6}, kFont, 0.45, text, 1,
                cv::LINE_AA);
    if (!title.empty()) {
      cv::putText(img, title, {left_, 25}, kFont, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    }
    return img;
  }

 private:
  double Ty(double y) const { return log_y_ ? std::log10(y) : y; }
  int PyT(double t) const {
    return top_ + static_cast<int>((1.0 - (t - y_min_) / (y_max_ - y_min_)) * Ph());
  }

  int width_, height_;
  bool log_y_;
  int left_ = 80, right_ = 20, top_, bottom_;
  double x_min_ = std::numeric_limits<double>::infinity(), x_max_ = -x_min_;
  double y_min_ = x_min_, y_max_ = -x_min_;
};

// Throws ConfigError "<what> <field> = <value> violates <rule>" for bad plot sizes.
void CheckPlotSize(const std::string& what, int width, int height) {
  auto fail = [&](const std::string& field, int value, const char* rule) {
    std::ostringstream msg;
    msg << what << " " << field << " = " << value << " violates " << rule;
    throw ConfigError(msg.str());
  };
  if (width < 300) fail("width", width, ">= 300");
  if (height < 200) fail("height", height, ">= 200");
}

}  // namespace

void CurvePlotOptions::Check() const {
  CheckPlotSize("curve plot", width, height);
  if (smooth_window < 1) {
    throw ConfigError("curve plot smooth_window = " + std::to_string(smooth_window) +
                      " violates >= 1");
  }
}

void ScatterPlotOptions::Check() const { CheckPlotSize("scatter plot", width, height); }

std::vector<double> MovingAverage(const std::vector<double>& values, int window) {
  DFO_CHECK(window >= 1) << window;
  const int n = static_cast<int>(values.size());
  std::vector<double> out(values.size());
  const int half = window / 2;
  for (int i = 0; i < n; ++i) {
    double sum = 0.0;
    int count = 0;
    for (int j = std::max(0, i - half); j <= std::min(n - 1, i + half); ++j) {
      if (std::isfinite(values[j])) {
        sum += values[j];
        ++count;
      }
    }
    out[i] = count > 0 ? sum / count : std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

void WriteCurvePlot(const std::string& path, const std::vector<CurveSeries>& series,
                    const CurvePlotOptions& options) {
  options.Check();
  PlotAxes axes(options.width, options.height, options.log_y, !options.title.empty());
  for (const CurveSeries& s : series) {
    if (s.x.size() != s.y.size()) {
      std::ostringstream msg;
      msg << "curve plot " << path << ": series '" << s.name << "' has " << s.x.size()
          << " x values and " << s.y.size() << " y values; expected equal counts";
      throw InputError(msg.str());
    }
    for (size_t i = 0; i < s.x.size(); ++i) axes.Include(s.x[i], s.y[i]);
  }
  if (axes.Empty()) throw InputError("curve plot " + path + ": no drawable point in any series");
  axes.Finish(0.0, 0.04);
  cv::Mat img = axes.Draw(options.title, options.x_label, options.y_label);
  const cv::Scalar text(60, 60, 60);
  for (size_t k = 0; k < series.size(); ++k) {
    const cv::Scalar colour = kColours[k % 10];
    auto draw = [&](const std::vector<double>& y, const cv::Scalar& c, int thickness) {
      cv::Point last(-1, -1);
      for (size_t i = 0; i < y.size(); ++i) {
        if (!axes.Drawable(series[k].x[i], y[i])) {
          last = cv::Point(-1, -1);
          continue;
        }
        const cv::Point p = axes.P(series[k].x[i], y[i]);
        if (last.x >= 0) cv::line(img, last, p, c, thickness, cv::LINE_AA);
        last = p;
      }
    };
    if (options.smooth_window > 1) {
      const cv::Scalar faint = 0.3 * colour + 0.7 * cv::Scalar(255, 255, 255);
      draw(series[k].y, faint, 1);
      draw(MovingAverage(series[k].y, options.smooth_window), colour, 2);
    } else {
      draw(series[k].y, colour, 2);
    }
    // Legend entry.
    const int right = axes.left() + axes.Pw();
    const int ly = axes.top() + 18 + 20 * static_cast<int>(k);
    cv::line(img, {right - 230, ly - 4}, {right - 205, ly - 4}, colour, 3);
    cv::putText(img, series[k].name, {right - 198, ly}, kFont, 0.45, text, 1, cv::LINE_AA);
  }
  WriteImageFile(img, path, "curve plot");
}

void WriteScatterPlot(const std::string& path, const std::vector<ScatterSeries>& series,
                      const ScatterPlotOptions& options) {
  options.Check();
  const int note_height = 17;
  PlotAxes axes(
      options.width, options.height, options.log_y, !options.title.empty(),
      options.notes.empty() ? 0 : note_height * static_cast<int>(options.notes.size()) + 8);
  if (axes.Ph() < 100) {
    throw ConfigError("scatter plot height = " + std::to_string(options.height) + " leaves " +
                      std::to_string(axes.Ph()) + " pixels for the plot under " +
                      std::to_string(options.notes.size()) + " notes; needs >= 100");
  }
  for (const ScatterSeries& s : series) {
    if (s.x.size() != s.y.size() || (!s.labels.empty() && s.labels.size() != s.x.size())) {
      std::ostringstream msg;
      msg << "scatter plot " << path << ": series '" << s.name << "' has " << s.x.size()
          << " x values, " << s.y.size() << " y values and " << s.labels.size()
          << " labels; expected as many y values (and labels, when any) as x values";
      throw InputError(msg.str());
    }
    for (const size_t i : s.front) {
      if (i >= s.x.size()) {
        throw InputError("scatter plot " + path + ": series '" + s.name + "' front index " +
                         std::to_string(i) + " is out of range (" + std::to_string(s.x.size()) +
                         " points)");
      }
    }
    for (size_t i = 0; i < s.x.size(); ++i) axes.Include(s.x[i], s.y[i]);
  }
  if (axes.Empty()) throw InputError("scatter plot " + path + ": no drawable point in any series");
  axes.Finish(0.06, 0.08);
  cv::Mat img = axes.Draw(options.title, options.x_label, options.y_label);
  const cv::Scalar text(60, 60, 60);
  const int right = axes.left() + axes.Pw();
  int legend_y = axes.top() + 18;
  for (size_t k = 0; k < series.size(); ++k) {
    const ScatterSeries& s = series[k];
    const cv::Scalar colour = kColours[k % 10];
    // The front first, so that the points are drawn over its line.
    cv::Point last(-1, -1);
    for (const size_t i : s.front) {
      if (!axes.Drawable(s.x[i], s.y[i])) continue;
      const cv::Point p = axes.P(s.x[i], s.y[i]);
      if (last.x >= 0) cv::line(img, last, p, colour, 2, cv::LINE_AA);
      cv::circle(img, p, 10, colour, 2, cv::LINE_AA);
      last = p;
    }
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!axes.Drawable(s.x[i], s.y[i])) continue;
      const cv::Point p = axes.P(s.x[i], s.y[i]);
      cv::circle(img, p, 5, colour, cv::FILLED, cv::LINE_AA);
      if (!s.labels.empty()) {
        cv::putText(img, s.labels[i], p + cv::Point(8, -8), kFont, 0.4, text, 1, cv::LINE_AA);
      }
    }
    cv::circle(img, {right - 215, legend_y - 4}, 5, colour, cv::FILLED, cv::LINE_AA);
    cv::putText(img, s.name, {right - 198, legend_y}, kFont, 0.45, text, 1, cv::LINE_AA);
    legend_y += 20;
  }
  int note_y = axes.top() + axes.Ph() + 50 + note_height;
  for (const std::string& note : options.notes) {
    cv::putText(img, note, {axes.left(), note_y}, kFont, 0.45, text, 1, cv::LINE_AA);
    note_y += note_height;
  }
  WriteImageFile(img, path, "scatter plot");
}

}  // namespace dfo::io
