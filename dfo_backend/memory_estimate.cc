#include "dfo_backend/memory_estimate.h"

#include <cmath>
#include <cstdio>

#include "dfo_backend/window_optimizer.h"

namespace dfo {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;
constexpr double kFixedMib = 210.0;  // libraries, LibTorch, a model, threads (dfo_run: 205-220)
constexpr double kMargin = 1.2;
// Bytes a processed pixel (memory_estimate.h says where each comes from).
constexpr double kFrameBytes = 57.0;
constexpr double kFrameBytesPerChannel = 44.0;
constexpr double kStereoBytesPerView = 8.0;
constexpr double kNetworkBytes = 220.0;

}  // namespace

std::string MemoryEstimate::Describe() const {
  std::string out = std::to_string(static_cast<long long>(std::ceil(total_mib))) +
                    " MiB: " + std::to_string(static_cast<long long>(std::lround(fixed_mib))) +
                    " fixed";
  const auto add = [&](double mib, const char* what) {
    if (mib <= 0.0) return;
    out += " + " + std::to_string(static_cast<long long>(std::lround(mib))) + " " + what;
  };
  add(frames_mib, "frames");
  add(window_mib, "window");
  add(stereo_mib, "keyframe stereo");
  add(network_mib, "network");
  return out;
}

MemoryEstimate EstimatePeakMemory(const MemoryEstimateInput& input,
                                  const OdometryOptions& odometry) {
  const double pixels = static_cast<double>(input.width) * static_cast<double>(input.height);
  const double channels = std::max(1, input.feature_channels);
  MemoryEstimate m;
  m.fixed_mib = kFixedMib;
  m.frames_mib = kMargin * pixels * (kFrameBytes + kFrameBytesPerChannel * channels) / kMiB;
  if (odometry.has_window()) {
    const WindowOptions& w = odometry.window;
    const double level_pixels = pixels / std::pow(4.0, w.pyramid_level);
    const double zooms = w.zoom_blur_sigma_px > 0.0
                             ? static_cast<double>(WindowZoomLadder(w.max_patch_stretch).size())
                             : 0.0;
    double keyframe_bytes = level_pixels * 4.0 * (channels * (1.0 + zooms) + 1.0);
    if (w.coarse_iterations > 0) keyframe_bytes += level_pixels / 4.0 * 4.0 * channels;
    m.window_mib = kMargin * (w.max_keyframes + 1) * keyframe_bytes / kMiB;
    if (odometry.stereo.views > 0) {
      // The plane sweep's cost volume (a float per pixel and depth sample) and the views' maps.
      m.stereo_mib =
          kMargin *
          (4.0 * odometry.stereo.depth_samples + kStereoBytesPerView * odometry.stereo.views) *
          pixels / kMiB;
    }
  }
  m.network_mib = kMargin * kNetworkBytes * static_cast<double>(input.network_pixels) / kMiB;
  m.total_mib = m.fixed_mib + m.frames_mib + m.window_mib + m.stereo_mib + m.network_mib;
  return m;
}

}  // namespace dfo
