#include "dfo_backend/keyframe_stereo.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "dfo_core/check_option.h"
#include "dfo_core/error.h"
#include "dfo_core/image_pyramid.h"
#include "dfo_core/timing.h"

namespace dfo {

using internal::CheckOption;

void KeyframeStereoOptions::Check() const {
  CheckOption(views >= 0 && views <= 12, "stereo.views", views, "in [0, 12]");
  CheckOption(depth_samples >= 8 && depth_samples <= 1024, "stereo.depth_samples", depth_samples,
              "in [8, 1024]");
  CheckOption(window_radius >= 1 && window_radius <= 8, "stereo.window_radius", window_radius,
              "in [1, 8]");
  CheckOption(std::isfinite(min_epipolar_px) && min_epipolar_px >= 0.0, "stereo.min_epipolar_px",
              min_epipolar_px, ">= 0");
  CheckOption(std::isfinite(max_cost) && max_cost > 0.0 && max_cost <= 2.0, "stereo.max_cost",
              max_cost, "in (0, 2]");
  CheckOption(std::isfinite(uniqueness) && uniqueness >= 1.0, "stereo.uniqueness", uniqueness,
              ">= 1");
  CheckOption(
      std::isfinite(max_source_ratio) && (max_source_ratio == 0.0 || max_source_ratio > 1.0),
      "stereo.max_source_ratio", max_source_ratio, "0 (off) or > 1");
  CheckOption(num_threads >= 1 && num_threads <= 256, "run.threads", num_threads, "in [1, 256]");
}

namespace {

// ApplyKeyframeStereo without its timing.
KeyframeStereoResult ApplyStereo(const ImageF& reference, const PinholeCamera& camera,
                                 const std::vector<StereoView>& views, double window_scale,
                                 const KeyframeStereoOptions& options, DepthPyramid* depth) {
  KeyframeStereoResult result;
  result.num_views = static_cast<int>(views.size());
  if (depth == nullptr || depth->num_levels() == 0 || views.size() < 2 || !(window_scale > 0.0) ||
      !std::isfinite(window_scale)) {
    return result;
  }
  ImageF& finest = depth->levels[0];
  std::vector<float> valid;
  valid.reserve(finest.size());
  for (float d : finest.vector()) {
    if (d > 0.0f) valid.push_back(d);
  }
  if (valid.empty()) return result;
  std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
  const double median = valid[valid.size() / 2] * window_scale;

  PlaneSweepOptions sweep;
  sweep.min_depth_m = median / 8.0;
  sweep.max_depth_m = median * 12.0;
  sweep.num_depths = options.depth_samples;
  sweep.window_radius = options.window_radius;
  sweep.min_epipolar_px = options.min_epipolar_px;
  sweep.max_cost = options.max_cost;
  sweep.uniqueness = options.uniqueness;
  sweep.min_views = 2;
  sweep.num_threads = options.num_threads;
  const PlaneSweepResult stereo = PlaneSweepDepth(reference, camera, views, sweep);
  result.confident = stereo.confident_fraction;
  if (stereo.depth.width() != finest.width() || stereo.depth.height() != finest.height()) {
    return result;
  }
  for (size_t i = 0; i < finest.size(); ++i) {
    const double d = stereo.depth.vector()[i];
    if (!(d > 0.0)) continue;
    const double source = finest.vector()[i];
    if (options.max_source_ratio > 0.0 && source > 0.0) {
      const double ratio = d / (source * window_scale);
      if (ratio > options.max_source_ratio || ratio < 1.0 / options.max_source_ratio) continue;
    }
    finest.vector()[i] = static_cast<float>(d / window_scale);
    ++result.num_replaced;
  }
  result.fraction =
      finest.size() > 0 ? static_cast<double>(result.num_replaced) / finest.size() : 0.0;
  if (result.num_replaced > 0) {
    for (int l = 1; l < depth->num_levels(); ++l) {
      depth->levels[l] = DownsampleDepthHalf(depth->levels[l - 1]);
    }
  }
  return result;
}

}  // namespace

KeyframeStereoResult ApplyKeyframeStereo(const ImageF& reference, const PinholeCamera& camera,
                                         const std::vector<StereoView>& views, double window_scale,
                                         const KeyframeStereoOptions& options,
                                         DepthPyramid* depth) {
  const auto start = std::chrono::steady_clock::now();
  KeyframeStereoResult result = ApplyStereo(reference, camera, views, window_scale, options, depth);
  result.milliseconds = MsSince(start);
  return result;
}

}  // namespace dfo
