#include "dfo_backend/tracking_depth.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "dfo_core/check_option.h"
#include "dfo_core/error.h"

namespace dfo {
namespace {

using internal::CheckOption;

// The pixel a camera-frame point falls on (rounded), or false when outside the image.
bool PixelOf(const Eigen::Vector3d& p, const PinholeCamera& camera, int* x, int* y) {
  if (!(p.z() > 0.0)) return false;
  const Eigen::Vector2d uv = camera.Project(p);
  if (!uv.allFinite()) return false;
  *x = static_cast<int>(std::lround(uv.x()));
  *y = static_cast<int>(std::lround(uv.y()));
  return *x >= 0 && *y >= 0 && *x < camera.width && *y < camera.height;
}

}  // namespace

void TrackingDepthOptions::Check() const {
  CheckOption(depth == "window" || depth == "source", "tracker.depth", depth,
              "one of window|source");
  CheckOption(fill == "scaled_source" || fill == "none", "tracker.depth_fill", fill,
              "one of scaled_source|none");
  CheckOption(min_window_points >= 1, "tracker.min_window_points", min_window_points, ">= 1");
  CheckOption(splat_radius_px >= 0 && splat_radius_px <= 8, "tracker.splat_radius_px",
              splat_radius_px, "in [0, 8]");
  CheckOption(initial_depth_scale == "window" || initial_depth_scale == "source",
              "window.initial_depth_scale", initial_depth_scale, "one of window|source");
  CheckOption(source_scale == "raw" || source_scale == "run_median" || source_scale == "window",
              "window.source_scale", source_scale, "one of raw|run_median|window");
}

double WindowToSourceScale(const std::vector<Eigen::Vector3d>& points, const ImageF& depth,
                           const PinholeCamera& camera, int min_pairs) {
  if (depth.width() != camera.width || depth.height() != camera.height) return 0.0;
  std::vector<double> ratios;
  ratios.reserve(points.size());
  for (const Eigen::Vector3d& p : points) {
    int x = 0, y = 0;
    if (!PixelOf(p, camera, &x, &y)) continue;
    const double d = depth(x, y);
    if (d > 0.0 && std::isfinite(d)) ratios.push_back(p.z() / d);
  }
  if (ratios.empty() || static_cast<int>(ratios.size()) < min_pairs) return 0.0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  const double scale = ratios[ratios.size() / 2];
  return std::isfinite(scale) && scale > 0.0 ? scale : 0.0;
}

TrackingDepth BuildTrackingDepth(const DepthPyramid& source,
                                 const std::vector<PinholeCamera>& cameras,
                                 const std::vector<Eigen::Vector3d>& points,
                                 const TrackingDepthOptions& options) {
  TrackingDepth out;
  if (source.num_levels() == 0 || static_cast<int>(cameras.size()) < source.num_levels()) {
    out.note = "no depth pyramid or cameras for the keyframe";
    return out;
  }
  const PinholeCamera& finest = cameras[0];
  for (const Eigen::Vector3d& p : points) {
    int x = 0, y = 0;
    out.num_points += PixelOf(p, finest, &x, &y) ? 1 : 0;
  }
  if (out.num_points < options.min_window_points) {
    out.note = std::to_string(out.num_points) + " window points in the keyframe, " +
               std::to_string(options.min_window_points) + " needed (tracker.min_window_points)";
    return out;
  }
  out.scale = WindowToSourceScale(points, source.levels[0], finest, options.min_window_points);
  if (options.fill == "scaled_source" && out.scale <= 0.0) {
    out.note = "too few window points on valid source depth to scale the fill";
    return out;
  }
  const int r = options.splat_radius_px;
  out.depth.levels.resize(source.levels.size());
  for (int l = 0; l < source.num_levels(); ++l) {
    const ImageF& src = source.levels[l];
    const PinholeCamera& camera = cameras[l];
    const int w = src.width(), h = src.height();
    // Inverse-depth sums and counts of the window points per pixel.
    std::vector<double> sum(static_cast<size_t>(w) * h, 0.0);
    std::vector<int> count(sum.size(), 0);
    for (const Eigen::Vector3d& p : points) {
      int x = 0, y = 0;
      if (!PixelOf(p, camera, &x, &y)) continue;
      const double inverse = 1.0 / p.z();
      for (int yy = std::max(0, y - r); yy <= std::min(h - 1, y + r); ++yy) {
        for (int xx = std::max(0, x - r); xx <= std::min(w - 1, x + r); ++xx) {
          sum[static_cast<size_t>(yy) * w + xx] += inverse;
          ++count[static_cast<size_t>(yy) * w + xx];
        }
      }
    }
    ImageF& level = out.depth.levels[l];
    level = ImageF(w, h, 1, 0.0f);
    if (l == 0) out.covered.assign(sum.size(), 0);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        const size_t i = static_cast<size_t>(y) * w + x;
        if (count[i] > 0) {
          level(x, y) = static_cast<float>(count[i] / sum[i]);
          if (l == 0) out.covered[i] = 1;
        } else if (options.fill == "scaled_source") {
          const float d = src(x, y);
          level(x, y) = d > 0.0f && std::isfinite(d) ? static_cast<float>(d * out.scale) : 0.0f;
        }
      }
    }
  }
  out.from_window = true;
  return out;
}

}  // namespace dfo
