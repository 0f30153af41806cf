#include "dfo_io/plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dfo_core/error.h"
#include "dfo_io/image_file_writer.h"

namespace dfo::io {
namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kBlack(0, 0, 0);
const cv::Scalar kGrid(225, 225, 225);
const cv::Scalar kAxisText(60, 60, 60);
const cv::Scalar kGroundTruth(70, 70, 70);
const cv::Scalar kStart(40, 160, 40);          // BGR green
const cv::Scalar kPlainEstimate(200, 90, 30);  // BGR blue, when no errors are given
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

// A "nice" tick step (1, 2 or 5 x 10^k) giving about `target` intervals over `range`.
double NiceStep(double range, int target) {
  const double raw = range / target;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  const double r = raw / magnitude;
  const double nice = r < 1.5 ? 1.0 : r < 3.5 ? 2.0 : r < 7.5 ? 5.0 : 10.0;
  return nice * magnitude;
}

std::string FormatTick(double value, double step) {
  const int decimals = std::max(0, static_cast<int>(-std::floor(std::log10(step) + 1e-9)));
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, std::abs(value) < step * 1e-6 ? 0.0 : value);
  return buf;
}

std::string FormatValue(double value) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3g", value);
  return buf;
}

void Text(cv::Mat& img, const std::string& s, cv::Point org, double scale, const cv::Scalar& c,
          int thickness = 1) {
  cv::putText(img, s, org, kFont, scale, c, thickness, cv::LINE_AA);
}

cv::Size TextSize(const std::string& s, double scale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(s, kFont, scale, thickness, &baseline);
}

// Turbo colour map as a 256-entry BGR lookup table.
std::array<cv::Vec3b, 256> ColourTable() {
  cv::Mat ramp(256, 1, CV_8UC1);
  for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(i) = static_cast<uint8_t>(i);
  cv::Mat colours;
  cv::applyColorMap(ramp, colours, cv::COLORMAP_TURBO);
  std::array<cv::Vec3b, 256> table;
  for (int i = 0; i < 256; ++i) table[i] = colours.at<cv::Vec3b>(i);
  return table;
}

// The canvas of a top-view plot: header lines, equal-scale plot area around every point of
// `paths`, grid, ticks and axis names; `to_pixel` maps a position to (sub-pixel) image
// coordinates. `right_margin` leaves room for a colour bar.
struct Canvas {
  cv::Mat img;
  cv::Rect area;
  int h_axis = 0, v_axis = 2;
  double scale = 1.0, centre_h = 0.0, centre_v = 0.0, area_cx = 0.0, area_cy = 0.0;
  cv::Point2d to_pixel(const Eigen::Vector3d& p) const {
    return cv::Point2d(area_cx + (p[h_axis] - centre_h) * scale,
                       area_cy - (p[v_axis] - centre_v) * scale);  // up is +v
  }
};

constexpr int kShift = 4;  // sub-pixel drawing precision (1/16 px)
cv::Point Fixed(const cv::Point2d& p) {
  return cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))),
                   static_cast<int>(std::lround(p.y * (1 << kShift))));
}

Canvas DrawCanvas(const std::vector<const std::vector<Eigen::Vector3d>*>& paths,
                  const TrajectoryPlotOptions& options, int right_margin) {
  Canvas c;
  // Extents per axis over both paths.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto* points : paths) {
    for (const auto& p : *points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  }
  const Eigen::Vector3d extent = hi - lo;
  // x-z (KITTI ground plane) unless the path climbs more than it spans in x or z.
  int& h_axis = c.h_axis;
  int& v_axis = c.v_axis;
  if (extent.y() > std::min(extent.x(), extent.z())) {
    int smallest = 0;
    for (int a = 1; a < 3; ++a) {
      if (extent[a] < extent[smallest]) smallest = a;
    }
    h_axis = smallest == 0 ? 1 : 0;
    v_axis = smallest == 2 ? 1 : 2;
  }
  const char* kAxisNames[3] = {"x", "y", "z"};

  c.img = cv::Mat(options.height, options.width, CV_8UC3, kWhite);
  cv::Mat& img = c.img;
  // Header: title and figure lines.
  int y_text = 32;
  Text(img, options.title, cv::Point(20, y_text), 0.8, kBlack, 2);
  for (const std::string& line : options.text_lines) {
    y_text += 26;
    Text(img, line, cv::Point(20, y_text), 0.55, kAxisText);
  }
  const int area_top = y_text + 44;
  c.area =
      cv::Rect(90, area_top, options.width - 90 - right_margin, options.height - area_top - 60);
  const cv::Rect& area = c.area;

  // Equal scale on both axes, data centred in the plot area with a 5% margin.
  double range_h = std::max(extent[h_axis], 1e-6) * 1.1;
  double range_v = std::max(extent[v_axis], 1e-6) * 1.1;
  if (extent[h_axis] < 1e-6 && extent[v_axis] < 1e-6) range_h = range_v = 1.0;
  c.scale = std::min(area.width / range_h, area.height / range_v);
  c.centre_h = 0.5 * (lo[h_axis] + hi[h_axis]);
  c.centre_v = 0.5 * (lo[v_axis] + hi[v_axis]);
  c.area_cx = area.x + 0.5 * area.width;
  c.area_cy = area.y + 0.5 * area.height;
  const double scale = c.scale, centre_h = c.centre_h, centre_v = c.centre_v;
  const double area_cx = c.area_cx, area_cy = c.area_cy;

  // Grid, tick labels in metres, axis names.
  const double visible_h = area.width / scale, visible_v = area.height / scale;
  const double step = NiceStep(std::max(visible_h, visible_v), 8);
  const double h_min = centre_h - 0.5 * visible_h, v_min = centre_v - 0.5 * visible_v;
  for (double t = std::ceil(h_min / step) * step; t <= h_min + visible_h; t += step) {
    const int x = static_cast<int>(std::lround(area_cx + (t - centre_h) * scale));
    cv::line(img, cv::Point(x, area.y), cv::Point(x, area.br().y), kGrid, 1);
    const std::string label = FormatTick(t, step);
    const cv::Size size = TextSize(label, 0.45);
    Text(img, label, cv::Point(x - size.width / 2, area.br().y + 20), 0.45, kAxisText);
  }
  for (double t = std::ceil(v_min / step) * step; t <= v_min + visible_v; t += step) {
    const int y = static_cast<int>(std::lround(area_cy - (t - centre_v) * scale));
    cv::line(img, cv::Point(area.x, y), cv::Point(area.br().x, y), kGrid, 1);
    const std::string label = FormatTick(t, step);
    const cv::Size size = TextSize(label, 0.45);
    Text(img, label, cv::Point(area.x - size.width - 8, y + size.height / 2), 0.45, kAxisText);
  }
  cv::rectangle(img, area, kAxisText, 1);
  const std::string h_label = std::string(kAxisNames[h_axis]) + " [m]";
  const std::string v_label = std::string(kAxisNames[v_axis]) + " [m]";
  Text(img, h_label,
       cv::Point(area.x + area.width / 2 - TextSize(h_label, 0.6).width / 2, area.br().y + 48), 0.6,
       kBlack);
  Text(img, v_label, cv::Point(12, area.y - 8), 0.6, kBlack);

  return c;
}

}  // namespace

void TrajectoryPlotOptions::Check() const {
  if (width < 400) throw ConfigError("plot.width = " + std::to_string(width) + " violates >= 400");
  if (height < 300) {
    throw ConfigError("plot.height = " + std::to_string(height) + " violates >= 300");
  }
}

void WriteTrajectoryPlot(const std::string& path, const Trajectory& ground_truth,
                         const Trajectory& estimate, const std::vector<double>& errors,
                         const TrajectoryPlotOptions& options) {
  options.Check();
  if (!errors.empty() && errors.size() != estimate.size()) {
    throw InputError("trajectory plot " + path + ": " + std::to_string(errors.size()) +
                     " errors for " + std::to_string(estimate.size()) +
                     " estimated poses, expected one per pose");
  }
  const std::vector<Eigen::Vector3d> gt = ground_truth.Positions();
  const std::vector<Eigen::Vector3d> est = estimate.Positions();
  if (gt.empty() && est.empty()) {
    throw InputError("trajectory plot " + path + ": both trajectories are empty");
  }

  const bool coloured = !errors.empty();
  Canvas canvas = DrawCanvas({&gt, &est}, options, coloured ? 170 : 40);
  cv::Mat& img = canvas.img;
  const cv::Rect& area = canvas.area;
  const auto to_pixel = [&](const Eigen::Vector3d& p) { return canvas.to_pixel(p); };
  const auto fixed = [](const cv::Point2d& p) { return Fixed(p); };

  // Error colour range.
  double e_min = 0.0, e_max = 1.0;
  if (coloured) {
    e_min = *std::min_element(errors.begin(), errors.end());
    e_max = *std::max_element(errors.begin(), errors.end());
    if (!(e_max > e_min)) e_max = e_min + 1e-9;
  }
  const std::array<cv::Vec3b, 256> table = ColourTable();
  const auto colour_of = [&](double e) {
    const int i =
        std::clamp(static_cast<int>(std::lround(255.0 * (e - e_min) / (e_max - e_min))), 0, 255);
    const cv::Vec3b c = table[i];
    return cv::Scalar(c[0], c[1], c[2]);
  };

  // Paths: ground truth first, the estimate on top.
  for (size_t i = 1; i < gt.size(); ++i) {
    cv::line(img, fixed(to_pixel(gt[i - 1])), fixed(to_pixel(gt[i])), kGroundTruth, 2, cv::LINE_AA,
             kShift);
  }
  for (size_t i = 1; i < est.size(); ++i) {
    const cv::Scalar c = coloured ? colour_of(0.5 * (errors[i - 1] + errors[i])) : kPlainEstimate;
    cv::line(img, fixed(to_pixel(est[i - 1])), fixed(to_pixel(est[i])), c, 2, cv::LINE_AA, kShift);
  }
  // Start marker at the first ground-truth (else estimated) position.
  const cv::Point2d start = to_pixel(!gt.empty() ? gt.front() : est.front());
  cv::circle(img, fixed(start), 7 << kShift, kStart, cv::FILLED, cv::LINE_AA, kShift);
  cv::circle(img, fixed(start), 7 << kShift, kBlack, 1, cv::LINE_AA, kShift);
  // Label with a white halo so it stays readable over the paths.
  const cv::Point start_label(static_cast<int>(start.x) + 10, static_cast<int>(start.y) - 8);
  Text(img, "start", start_label, 0.5, kWhite, 4);
  Text(img, "start", start_label, 0.5, kStart, 1);

  // Legend, top-left inside the plot area.
  const cv::Rect legend(area.x + 10, area.y + 10, 230, 56);
  cv::rectangle(img, legend, kWhite, cv::FILLED);
  cv::rectangle(img, legend, kGrid, 1);
  cv::line(img, cv::Point(legend.x + 10, legend.y + 18), cv::Point(legend.x + 50, legend.y + 18),
           kGroundTruth, 2, cv::LINE_AA);
  Text(img, "ground truth", cv::Point(legend.x + 60, legend.y + 23), 0.5, kBlack);
  for (int k = 0; k < 40; ++k) {
    const cv::Scalar c = coloured ? colour_of(e_min + (e_max - e_min) * k / 39.0) : kPlainEstimate;
    cv::line(img, cv::Point(legend.x + 10 + k, legend.y + 40),
             cv::Point(legend.x + 11 + k, legend.y + 40), c, 2);
  }
  Text(img, "estimate (aligned)", cv::Point(legend.x + 60, legend.y + 45), 0.5, kBlack);

  // Colour bar on the right.
  if (coloured) {
    const cv::Rect bar(area.br().x + 30, area.y + 20, 22, area.height - 40);
    for (int y = 0; y < bar.height; ++y) {
      const double e = e_max - (e_max - e_min) * y / std::max(1, bar.height - 1);
      cv::line(img, cv::Point(bar.x, bar.y + y), cv::Point(bar.br().x - 1, bar.y + y), colour_of(e),
               1);
    }
    cv::rectangle(img, bar, kAxisText, 1);
    Text(img, options.error_label, cv::Point(bar.x - 10, bar.y - 16), 0.5, kBlack);
    for (int k = 0; k <= 4; ++k) {
      const double e = e_max - (e_max - e_min) * k / 4.0;
      const int y = bar.y + static_cast<int>(std::lround((bar.height - 1) * k / 4.0));
      cv::line(img, cv::Point(bar.br().x, y), cv::Point(bar.br().x + 5, y), kAxisText, 1);
      Text(img, FormatValue(e), cv::Point(bar.br().x + 8, y + 5), 0.45, kAxisText);
    }
  }

  WriteImageFile(img, path, "plot");
}

void WriteTrajectoriesPlot(const std::string& path, const Trajectory& ground_truth,
                           const std::vector<LabelledTrajectory>& estimates,
                           const TrajectoryPlotOptions& options) {
  options.Check();
  // BGR: blue, orange, green, purple, brown, pink (matplotlib's first colours).
  const cv::Scalar kColours[6] = {{180, 119, 31},  {14, 127, 255}, {44, 160, 44},
                                  {189, 103, 148}, {75, 86, 140},  {194, 119, 227}};
  if (estimates.size() > 6) {
    throw InputError("trajectory plot " + path + ": " + std::to_string(estimates.size()) +
                     " estimates, at most 6 are drawn");
  }
  std::vector<std::vector<Eigen::Vector3d>> points;
  points.push_back(ground_truth.Positions());
  for (const LabelledTrajectory& e : estimates) points.push_back(e.trajectory.Positions());
  std::vector<const std::vector<Eigen::Vector3d>*> paths;
  bool any = false;
  for (const auto& p : points) {
    paths.push_back(&p);
    any = any || !p.empty();
  }
  if (!any) throw InputError("trajectory plot " + path + ": every trajectory is empty");
  Canvas canvas = DrawCanvas(paths, options, 40);
  cv::Mat& img = canvas.img;
  const auto draw = [&](const std::vector<Eigen::Vector3d>& p, const cv::Scalar& colour) {
    for (size_t i = 1; i < p.size(); ++i) {
      cv::line(img, Fixed(canvas.to_pixel(p[i - 1])), Fixed(canvas.to_pixel(p[i])), colour, 2,
               cv::LINE_AA, kShift);
    }
  };
  draw(points[0], kGroundTruth);
  for (size_t k = 1; k < points.size(); ++k) draw(points[k], kColours[k - 1]);
  const std::vector<Eigen::Vector3d>* first = &points[0];
  for (const auto& p : points) {
    if (first->empty()) first = &p;
  }
  const cv::Point2d start = canvas.to_pixel(first->front());
  cv::circle(img, Fixed(start), 7 << kShift, kStart, cv::FILLED, cv::LINE_AA, kShift);
  cv::circle(img, Fixed(start), 7 << kShift, kBlack, 1, cv::LINE_AA, kShift);
  const cv::Point start_label(static_cast<int>(start.x) + 10, static_cast<int>(start.y) - 8);
  Text(img, "start", start_label, 0.5, kWhite, 4);
  Text(img, "start", start_label, 0.5, kStart, 1);

  // Legend, top-left inside the plot area: one line per trajectory.
  int legend_width = 0;
  for (const LabelledTrajectory& e : estimates) {
    legend_width = std::max(legend_width, TextSize(e.label, 0.5).width);
  }
  legend_width = std::max(legend_width, TextSize("ground truth", 0.5).width) + 80;
  // No ground-truth line when there is none (a run without ground truth).
  const size_t first_entry = ground_truth.size() == 0 ? 1 : 0;
  const cv::Rect legend(canvas.area.x + 10, canvas.area.y + 10, legend_width,
                        14 + 22 * static_cast<int>(points.size() - first_entry));
  cv::rectangle(img, legend, kWhite, cv::FILLED);
  cv::rectangle(img, legend, kGrid, 1);
  for (size_t k = first_entry; k < points.size(); ++k) {
    const int y = legend.y + 18 + 22 * static_cast<int>(k - first_entry);
    const cv::Scalar colour = k == 0 ? kGroundTruth : kColours[k - 1];
    cv::line(img, cv::Point(legend.x + 10, y), cv::Point(legend.x + 50, y), colour, 2, cv::LINE_AA);
    Text(img, k == 0 ? std::string("ground truth") : estimates[k - 1].label,
         cv::Point(legend.x + 60, y + 5), 0.5, kBlack);
  }

  WriteImageFile(img, path, "plot");
}

}  // namespace dfo::io
