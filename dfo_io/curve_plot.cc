#include "dfo_io/curve_plot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "dfo_core/error.h"

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

}  // namespace

void CurvePlotOptions::Check() const {
  auto fail = [](const std::string& field, int value, const char* rule) {
    std::ostringstream msg;
    msg << "curve plot " << field << " = " << value << " violates " << rule;
    throw ConfigError(msg.str());
  };
  if (width < 300) fail("width", width, ">= 300");
  if (height < 200) fail("height", height, ">= 200");
  if (smooth_window < 1) fail("smooth_window", smooth_window, ">= 1");
}

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
  auto drawable = [&](double x, double y) {
    return std::isfinite(x) && std::isfinite(y) && (!options.log_y || y > 0.0);
  };
  auto ty = [&](double y) { return options.log_y ? std::log10(y) : y; };
  double x_min = std::numeric_limits<double>::infinity(), x_max = -x_min;
  double y_min = x_min, y_max = -x_min;
  for (const CurveSeries& s : series) {
    if (s.x.size() != s.y.size()) {
      std::ostringstream msg;
      msg << "curve plot " << path << ": series '" << s.name << "' has " << s.x.size()
          << " x values and " << s.y.size() << " y values; expected equal counts";
      throw InputError(msg.str());
    }
    for (size_t i = 0; i < s.x.size(); ++i) {
      if (!drawable(s.x[i], s.y[i])) continue;
      x_min = std::min(x_min, s.x[i]);
      x_max = std::max(x_max, s.x[i]);
      y_min = std::min(y_min, ty(s.y[i]));
      y_max = std::max(y_max, ty(s.y[i]));
    }
  }
  if (!std::isfinite(x_min)) {
    throw InputError("curve plot " + path + ": no drawable point in any series");
  }
  if (x_max - x_min < 1e-12) x_max = x_min + 1.0;
  if (y_max - y_min < 1e-12) {
    y_min -= 0.5;
    y_max += 0.5;
  }
  const double pad = 0.04 * (y_max - y_min);
  y_min -= pad;
  y_max += pad;

  cv::Mat img(options.height, options.width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int left = 80, right = 20, top = options.title.empty() ? 20 : 45, bottom = 50;
  const int pw = options.width - left - right, ph = options.height - top - bottom;
  auto px = [&](double x) { return left + static_cast<int>((x - x_min) / (x_max - x_min) * pw); };
  auto py = [&](double y) {
    return top + static_cast<int>((1.0 - (ty(y) - y_min) / (y_max - y_min)) * ph);
  };
  auto py_t = [&](double t) {
    return top + static_cast<int>((1.0 - (t - y_min) / (y_max - y_min)) * ph);
  };
  const cv::Scalar grid(225, 225, 225), text(60, 60, 60);
  // Grid and ticks.
  const double xs = NiceStep(x_max - x_min, 8);
  for (double x = std::ceil(x_min / xs) * xs; x <= x_max + 1e-9 * xs; x += xs) {
    cv::line(img, {px(x), top}, {px(x), top + ph}, grid, 1);
    cv::putText(img, Format(x), {px(x) - 15, top + ph + 18}, kFont, 0.4, text, 1, cv::LINE_AA);
  }
  std::vector<double> y_ticks;  // in plotted units (log10 on a log axis)
  if (options.log_y) {
    // Decades; with less than two decades in view also 2 and 5 times them.
    const bool fine = y_max - y_min < 2.0;
    for (double k = std::floor(y_min); k <= std::ceil(y_max); k += 1.0) {
      for (const double m : {1.0, 2.0, 5.0}) {
        if (m != 1.0 && !fine) continue;
        const double t = k + std::log10(m);
        if (t >= y_min && t <= y_max) y_ticks.push_back(t);
      }
    }
  } else {
    const double ys = NiceStep(y_max - y_min, 6);
    for (double t = std::ceil(y_min / ys) * ys; t <= y_max + 1e-9 * ys; t += ys) {
      y_ticks.push_back(t);
    }
  }
  for (const double t : y_ticks) {
    cv::line(img, {left, py_t(t)}, {left + pw, py_t(t)}, grid, 1);
    const std::string label = options.log_y ? Format(std::pow(10.0, t)) : Format(t);
    cv::putText(img, label, {5, py_t(t) + 4}, kFont, 0.4, text, 1, cv::LINE_AA);
  }
  cv::rectangle(img, {left, top}, {left + pw, top + ph}, cv::Scalar(0, 0, 0), 1);
  cv::putText(img, options.x_label, {left + pw / 2 - 30, options.height - 10}, kFont, 0.5, text, 1,
              cv::LINE_AA);
  cv::putText(img, options.y_label + (options.log_y ? " (log)" : ""), {5, top - 6}, kFont, 0.45,
              text, 1, cv::LINE_AA);
  if (!options.title.empty()) {
    cv::putText(img, options.title, {left, 25}, kFont, 0.6, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
  // Curves (clipped to the plot area).
  cv::Mat plot = img(cv::Rect(0, 0, options.width, options.height));
  for (size_t k = 0; k < series.size(); ++k) {
    const cv::Scalar colour = kColours[k % 10];
    auto draw = [&](const std::vector<double>& y, const cv::Scalar& c, int thickness) {
      cv::Point last(-1, -1);
      for (size_t i = 0; i < y.size(); ++i) {
        if (!drawable(series[k].x[i], y[i])) {
          last = cv::Point(-1, -1);
          continue;
        }
        const cv::Point p(px(series[k].x[i]), py(y[i]));
        if (last.x >= 0) cv::line(plot, last, p, c, thickness, cv::LINE_AA);
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
    const int ly = top + 18 + 20 * static_cast<int>(k);
    cv::line(img, {left + pw - 230, ly - 4}, {left + pw - 205, ly - 4}, colour, 3);
    cv::putText(img, series[k].name, {left + pw - 198, ly}, kFont, 0.45, text, 1, cv::LINE_AA);
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  bool ok = false;
  try {
    ok = cv::imwrite(path, img);
  } catch (const cv::Exception& e) {
    throw InputError("curve plot " + path + ": cannot be written (" + e.what() + ")");
  }
  if (!ok) throw InputError("curve plot " + path + ": cannot be written");
}

}  // namespace dfo::io
