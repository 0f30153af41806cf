#include "dfo_backend/memory_estimate.h"

#include <gtest/gtest.h>

namespace dfo {
namespace {

MemoryEstimateInput Input(int width, int height, int channels = 3) {
  MemoryEstimateInput in;
  in.width = width;
  in.height = height;
  in.feature_channels = channels;
  return in;
}

// The parts grow with what they hold: pixels, channels, keyframes, zoom copies, stereo samples, a
// network's pixels; a run without a window has no window part.
TEST(MemoryEstimate, EachPartGrowsWithWhatItHolds) {
  OdometryOptions o;
  const MemoryEstimate small = EstimatePeakMemory(Input(416, 128), o);
  const MemoryEstimate big = EstimatePeakMemory(Input(832, 256), o);
  EXPECT_NEAR(big.frames_mib, 4.0 * small.frames_mib, 1e-9);
  EXPECT_NEAR(big.window_mib, 4.0 * small.window_mib, 1e-9);
  EXPECT_DOUBLE_EQ(big.fixed_mib, small.fixed_mib);
  EXPECT_NEAR(
      small.total_mib,
      small.fixed_mib + small.frames_mib + small.window_mib + small.stereo_mib + small.network_mib,
      1e-9);
  EXPECT_GT(EstimatePeakMemory(Input(832, 256, 5), o).total_mib, big.total_mib);

  OdometryOptions more = o;
  more.window.max_keyframes = 2 * o.window.max_keyframes + 1;  // twice the keyframes (+ 1 held)
  EXPECT_NEAR(EstimatePeakMemory(Input(832, 256), more).window_mib, 2.0 * big.window_mib, 1e-9);
  OdometryOptions zoom = o;
  zoom.window.zoom_blur_sigma_px = 0.5;  // 1.1 ... 1.5 with the default stretch: 5 copies
  ASSERT_EQ(WindowZoomLadder(zoom.window.max_patch_stretch).size(), 5u);
  EXPECT_NEAR(EstimatePeakMemory(Input(832, 256), zoom).window_mib,
              big.window_mib * (3.0 * 6 + 1) / (3.0 + 1), 1e-9);
  OdometryOptions coarser = o;
  coarser.window.pyramid_level = 1;
  EXPECT_NEAR(EstimatePeakMemory(Input(832, 256), coarser).window_mib, big.window_mib / 4.0, 1e-9);
  OdometryOptions stereo = o;
  stereo.stereo.views = 3;
  const double three_views = EstimatePeakMemory(Input(832, 256), stereo).stereo_mib;
  EXPECT_GT(three_views, 0.0);
  stereo.stereo.depth_samples *= 4;  // the cost volume grows with the depth samples
  EXPECT_GT(EstimatePeakMemory(Input(832, 256), stereo).stereo_mib, 3.0 * three_views);
  EXPECT_EQ(big.stereo_mib, 0.0);

  OdometryOptions frontend = o;
  frontend.mode = OdometryMode::kFrontend;
  frontend.stereo.views = 3;
  const MemoryEstimate alone = EstimatePeakMemory(Input(832, 256), frontend);
  EXPECT_EQ(alone.window_mib, 0.0);
  EXPECT_EQ(alone.stereo_mib, 0.0);

  MemoryEstimateInput network = Input(832, 256);
  network.network_pixels = 832 * 256;
  EXPECT_GT(EstimatePeakMemory(network, o).network_mib, 0.0);
  EXPECT_EQ(big.network_mib, 0.0);
}

// 8192 x 8192 frames (the largest dataset.image_width/height accepts) with the defaults: tens of
// GiB, far beyond what dfo_run accepts by default; the description names the parts.
TEST(MemoryEstimate, TheLargestAcceptedSizeIsEstimatedFarAboveTheDefaultLimit) {
  const MemoryEstimate m = EstimatePeakMemory(Input(8192, 8192), OdometryOptions());
  EXPECT_GT(m.total_mib, 16000.0);
  const std::string text = m.Describe();
  for (const char* part : {"MiB", "fixed", "frames", "window"}) {
    EXPECT_NE(text.find(part), std::string::npos) << text;
  }
  EXPECT_EQ(text.find("network"), std::string::npos) << text;
}

}  // namespace
}  // namespace dfo
