#include "dfo_io/depth_colour.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "dfo_core/error.h"

namespace dfo::io {
namespace {

// OpenCV's COLORMAP_TURBO on 1 - t, as RGB: index = round(255 * t).
const cv::Mat& TurboLut() {
  static const cv::Mat lut = [] {
    cv::Mat ramp(1, 256, CV_8UC1);
    for (int i = 0; i < 256; ++i) ramp.at<uint8_t>(0, i) = static_cast<uint8_t>(255 - i);
    cv::Mat bgr;
    cv::applyColorMap(ramp, bgr, cv::COLORMAP_TURBO);
    return bgr;
  }();
  return lut;
}

}  // namespace

void DepthScaleColour(double t, uint8_t rgb[3]) {
  const int k = static_cast<int>(std::lround(255.0 * std::clamp(t, 0.0, 1.0)));
  const cv::Vec3b bgr = TurboLut().at<cv::Vec3b>(0, k);
  rgb[0] = bgr[2];
  rgb[1] = bgr[1];
  rgb[2] = bgr[0];
}

ImageU8 ColourDepth(const ImageF& depth, double near_m, double far_m) {
  DFO_CHECK(near_m > 0.0 && far_m > near_m) << near_m << " " << far_m;
  ImageU8 out(depth.width(), depth.height(), 3, 0);
  const double span = std::log(far_m / near_m);
  for (int y = 0; y < depth.height(); ++y) {
    for (int x = 0; x < depth.width(); ++x) {
      const float d = depth(x, y);
      if (!(d > 0.f) || !std::isfinite(d)) continue;
      DepthScaleColour(std::log(d / near_m) / span, &out(x, y, 0));
    }
  }
  return out;
}

}  // namespace dfo::io
