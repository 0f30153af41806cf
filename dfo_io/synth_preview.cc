#include "dfo_io/synth_preview.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_io/depth_colour.h"
#include "dfo_io/image_io.h"

namespace dfo::io {

namespace {

const cv::Scalar kBackground(32, 30, 28);  // BGR
const cv::Scalar kText(235, 235, 235);
const cv::Scalar kDimText(170, 170, 170);
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

cv::Mat ToBgr(const ImageU8& rgb) {
  cv::Mat m(rgb.height(), rgb.width(), CV_8UC3);
  for (int y = 0; y < rgb.height(); ++y) std::memcpy(m.ptr(y), rgb.Row(y), rgb.width() * 3);
  cv::cvtColor(m, m, cv::COLOR_RGB2BGR);
  return m;
}

// Position of depth d on the colour scale, 0 (near) .. 1 (far), logarithmic.
double DepthToUnit(double d, const SynthPreviewOptions& o) {
  const double t = std::log(d / o.depth_near_m) / std::log(o.depth_far_m / o.depth_near_m);
  return std::clamp(t, 0.0, 1.0);
}

cv::Mat ColourDepthBgr(const ImageF& depth, const SynthPreviewOptions& o) {
  const ImageU8 rgb = ColourDepth(depth, o.depth_near_m, o.depth_far_m);
  return ToBgr(rgb);
}

cv::Scalar ScaleColourBgr(double t) {
  uint8_t rgb[3];
  DepthScaleColour(t, rgb);
  return cv::Scalar(rgb[2], rgb[1], rgb[0]);
}

void PutText(cv::Mat& img, const std::string& text, cv::Point at, double scale,
             const cv::Scalar& colour, int thickness = 1) {
  cv::putText(img, text, at, kFont, scale, cv::Scalar(0, 0, 0), thickness + 2, cv::LINE_AA);
  cv::putText(img, text, at, kFont, scale, colour, thickness, cv::LINE_AA);
}

std::string Fixed(double v, int decimals) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(decimals);
  out << v;
  return out.str();
}

}  // namespace

void SynthPreviewOptions::Check() const {
  if (num_frames < 1 || num_frames > 12) {
    throw ConfigError("SynthPreviewOptions.num_frames = " + std::to_string(num_frames) +
                      " violates in [1, 12]");
  }
  if (!(depth_near_m > 0.0 && depth_far_m > depth_near_m)) {
    throw ConfigError("SynthPreviewOptions.depth_near_m / depth_far_m = " + Fixed(depth_near_m, 3) +
                      " / " + Fixed(depth_far_m, 3) + " violates 0 < near < far");
  }
  if (num_threads < 1) {
    throw ConfigError("SynthPreviewOptions.num_threads = " + std::to_string(num_threads) +
                      " violates >= 1");
  }
}

ImageU8 RenderSyntheticPreview(const SyntheticSequence& sequence, const SynthPreviewOptions& o) {
  o.Check();
  const int n = sequence.num_frames();
  const int shown = std::min(o.num_frames, n);
  std::vector<int> indices;
  for (int k = 0; k < shown; ++k) {
    indices.push_back(shown == 1 ? 0 : static_cast<int>(std::lround(k * (n - 1.0) / (shown - 1))));
  }
  const int w = sequence.camera().width, h = sequence.camera().height;
  const int margin = 12, gap = 6, header = 44, label_h = 0;
  const int bar_h = 70;
  const int left_w = 2 * w + gap;
  const int left_h = shown * (h + gap + label_h) - gap + bar_h;
  const int map_size = std::max(left_h, 360);
  const int width = margin + left_w + 2 * margin + map_size + margin;
  const int height = header + map_size + margin;
  cv::Mat canvas(height, width, CV_8UC3, kBackground);

  // Title.
  const SyntheticOptions& so = sequence.options();
  {
    std::ostringstream title;
    title << "dfo_synth  seed " << so.seed << "  |  " << n << " frames of " << w << "x" << h
          << ", hfov " << Fixed(so.horizontal_fov_deg, 0) << " deg  |  path "
          << Fixed(sequence.GroundTruth().PathLength(), 0) << " m";
    PutText(canvas, title.str(), cv::Point(margin, 28), 0.65, kText, 1);
  }

  // Frames and depth maps.
  for (int k = 0; k < shown; ++k) {
    const SyntheticFrame frame = sequence.RenderFrame(indices[k], o.num_threads);
    const int y0 = header + k * (h + gap + label_h);
    ToBgr(frame.rgb).copyTo(canvas(cv::Rect(margin, y0, w, h)));
    ColourDepthBgr(frame.depth, o).copyTo(canvas(cv::Rect(margin + w + gap, y0, w, h)));
    const std::string tag = "#" + std::to_string(k + 1) + "  frame " + std::to_string(indices[k]);
    PutText(canvas, tag, cv::Point(margin + 6, y0 + 18), 0.5, kText, 1);
    PutText(canvas, "depth", cv::Point(margin + w + gap + 6, y0 + 18), 0.5, kText, 1);
  }

  // Colour bar under the depth column, ticks in metres.
  {
    const int x0 = margin + w + gap, y0 = header + shown * (h + gap) + 8, bw = w, bh = 14;
    for (int x = 0; x < bw; ++x) {
      const int k = static_cast<int>(std::lround(255.0 * x / (bw - 1)));
      cv::line(canvas, {x0 + x, y0}, {x0 + x, y0 + bh}, ScaleColourBgr(k / 255.0));
    }
    cv::rectangle(canvas, cv::Rect(x0 - 1, y0 - 1, bw + 2, bh + 2), kDimText, 1);
    for (double d : {2.0, 5.0, 10.0, 20.0, 50.0, 100.0, 150.0, 200.0}) {
      if (d < o.depth_near_m || d > o.depth_far_m) continue;
      const int x = x0 + static_cast<int>(std::lround(DepthToUnit(d, o) * (bw - 1)));
      cv::line(canvas, {x, y0 + bh}, {x, y0 + bh + 5}, kText);
      const std::string label = Fixed(d, 0);
      int base = 0;
      const cv::Size size = cv::getTextSize(label, kFont, 0.42, 1, &base);
      PutText(canvas, label, cv::Point(x - size.width / 2, y0 + bh + 20), 0.42, kText);
    }
    PutText(canvas, "z-depth [m], log scale; black = sky / no depth", cv::Point(x0, y0 + bh + 42),
            0.45, kDimText);
  }

  // Top view of the world frame's x-z plane (x right, z forward = up in the picture).
  {
    const int mx0 = margin + left_w + 2 * margin, my0 = header;
    cv::Mat map = canvas(cv::Rect(mx0, my0, map_size, map_size));
    map.setTo(cv::Scalar(58, 66, 52));
    const Trajectory truth = sequence.GroundTruth();
    const SE3d world_from_map = sequence.map_from_world().Inverse();
    auto to_world_xz = [&world_from_map](double x, double z) {
      const Eigen::Vector3d p = world_from_map * Eigen::Vector3d(x, 0.0, z);
      return Eigen::Vector2d(p.x(), p.z());
    };
    double xmin = 1e300, xmax = -1e300, zmin = 1e300, zmax = -1e300;
    for (const auto& p : truth) {
      xmin = std::min(xmin, p.world_from_cam.translation().x());
      xmax = std::max(xmax, p.world_from_cam.translation().x());
      zmin = std::min(zmin, p.world_from_cam.translation().z());
      zmax = std::max(zmax, p.world_from_cam.translation().z());
    }
    const double pad = 35.0;
    const double span = std::max({xmax - xmin, zmax - zmin, 40.0}) + 2 * pad;
    const double cx = 0.5 * (xmin + xmax), cz = 0.5 * (zmin + zmax);
    const double scale = map_size / span;
    auto px = [&](const Eigen::Vector2d& xz) {
      return cv::Point2d(0.5 * map_size + (xz.x() - cx) * scale,
                         0.5 * map_size - (xz.y() - cz) * scale);
    };
    const int shift = 4;  // sub-pixel drawing
    auto fixed = [&](const cv::Point2d& p) {
      return cv::Point(static_cast<int>(std::lround(p.x * (1 << shift))),
                       static_cast<int>(std::lround(p.y * (1 << shift))));
    };
    // Street: sidewalks, then the road, drawn as thick polylines of the road centre.
    const auto& samples = sequence.world().path.samples();
    std::vector<cv::Point> centre;
    for (size_t i = 0; i < samples.size(); i += 5) {
      const auto& s = samples[i];
      const double off = -synthetic::kLaneOffsetM;
      centre.push_back(fixed(px(to_world_xz(s.x_m + off * std::cos(s.heading_rad),
                                            s.z_m - off * std::sin(s.heading_rad)))));
    }
    const auto thick = [&](double metres) { return std::max(1, static_cast<int>(metres * scale)); };
    cv::polylines(map, centre, false, cv::Scalar(150, 155, 160),
                  thick(2 * synthetic::kSidewalkOuterM), cv::LINE_AA, shift);
    cv::polylines(map, centre, false, cv::Scalar(80, 80, 82), thick(2 * synthetic::kKerbInnerM),
                  cv::LINE_AA, shift);
    // Boxes.
    for (const auto& box : sequence.world().boxes) {
      std::vector<cv::Point> poly;
      for (const auto& c : box.FootprintCorners())
        poly.push_back(fixed(px(to_world_xz(c.x(), c.y()))));
      const Eigen::Vector3d col = box.colour * 255.0;
      const cv::Scalar bgr(col.z(), col.y(), col.x());
      if (box.kind == synthetic::BoxKind::kBuilding) {
        cv::fillConvexPoly(map, poly, bgr * 0.8, cv::LINE_AA, shift);
        cv::polylines(map, poly, true, cv::Scalar(20, 20, 20), 1, cv::LINE_AA, shift);
      } else if (box.kind == synthetic::BoxKind::kCar) {
        cv::fillConvexPoly(map, poly, bgr, cv::LINE_AA, shift);
      }
    }
    // Path of the camera, start and end markers, shown frames.
    std::vector<cv::Point> path;
    for (const auto& p : truth) {
      path.push_back(
          fixed(px({p.world_from_cam.translation().x(), p.world_from_cam.translation().z()})));
    }
    cv::polylines(map, path, false, cv::Scalar(255, 200, 40), 2, cv::LINE_AA, shift);
    const cv::Point2d start = px({0.0, 0.0});
    cv::circle(map, fixed(start), 7 << shift, cv::Scalar(60, 220, 60), cv::FILLED, cv::LINE_AA,
               shift);
    PutText(map, "start", cv::Point(static_cast<int>(start.x) + 10, static_cast<int>(start.y) + 5),
            0.5, cv::Scalar(120, 255, 120));
    const Eigen::Vector3d last = truth.poses().back().world_from_cam.translation();
    const cv::Point2d end = px({last.x(), last.z()});
    cv::rectangle(map, cv::Rect(static_cast<int>(end.x) - 5, static_cast<int>(end.y) - 5, 11, 11),
                  cv::Scalar(60, 60, 230), cv::FILLED);
    for (int k = 0; k < shown; ++k) {
      const SE3d& pose = truth[indices[k]].world_from_cam;
      const Eigen::Vector3d c = pose.translation();
      const Eigen::Vector3d ahead = pose * Eigen::Vector3d(0, 0, 12.0);
      const cv::Point2d a = px({c.x(), c.z()}), b = px({ahead.x(), ahead.z()});
      cv::arrowedLine(map, fixed(a), fixed(b), cv::Scalar(255, 255, 255), 2, cv::LINE_AA, shift,
                      0.3);
      PutText(map, "#" + std::to_string(k + 1),
              cv::Point(static_cast<int>(a.x) - 22, static_cast<int>(a.y) - 6), 0.5, kText);
    }
    // Scale bar and legend.
    const double bar_m = span > 400 ? 100.0 : 50.0;
    const int bl = static_cast<int>(bar_m * scale);
    const int lx = 8, ly = map_size - 92;
    cv::rectangle(map, cv::Rect(lx, ly, std::max(250, bl + 70), 84), cv::Scalar(30, 30, 30),
                  cv::FILLED);
    PutText(map, "top view (world x right, z up)", cv::Point(lx + 6, ly + 18), 0.42, kDimText);
    // Legend symbols drawn as on the map.
    int x = lx + 8;
    const int sy = ly + 40;
    cv::line(map, {x, sy - 4}, {x + 18, sy - 4}, cv::Scalar(255, 200, 40), 2, cv::LINE_AA);
    PutText(map, "path", cv::Point(x + 22, sy), 0.42, kText);
    x += 64;
    cv::circle(map, {x + 5, sy - 4}, 5, cv::Scalar(60, 220, 60), cv::FILLED, cv::LINE_AA);
    PutText(map, "start", cv::Point(x + 14, sy), 0.42, kText);
    x += 62;
    cv::rectangle(map, cv::Rect(x, sy - 9, 10, 10), cv::Scalar(60, 60, 230), cv::FILLED);
    PutText(map, "end", cv::Point(x + 14, sy), 0.42, kText);
    x += 48;
    cv::arrowedLine(map, {x, sy - 4}, {x + 16, sy - 4}, cv::Scalar(255, 255, 255), 2, cv::LINE_AA,
                    0, 0.4);
    PutText(map, "#k", cv::Point(x + 20, sy), 0.42, kText);
    cv::line(map, {lx + 8, ly + 66}, {lx + 8 + bl, ly + 66}, kText, 2);
    PutText(map, Fixed(bar_m, 0) + " m", cv::Point(lx + 14 + bl, ly + 71), 0.45, kText);
  }

  cv::cvtColor(canvas, canvas, cv::COLOR_BGR2RGB);
  ImageU8 out(canvas.cols, canvas.rows, 3);
  for (int y = 0; y < canvas.rows; ++y) std::memcpy(out.Row(y), canvas.ptr(y), canvas.cols * 3);
  return out;
}

void WriteSyntheticPreview(const std::string& path, const SyntheticSequence& sequence,
                           const SynthPreviewOptions& options) {
  WriteImage(path, RenderSyntheticPreview(sequence, options));
}

}  // namespace dfo::io
