// Tests of the feature and depth sources: z-scoring, pyramid sizes and cameras, validity-aware
// depth averaging.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "dfo_core/error.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"

namespace dfo {
namespace {

Frame MakeFrame(int w, int h) {
  Frame f;
  f.index = 7;
  f.camera = PinholeCamera(100, 100, (w - 1) / 2.0, (h - 1) / 2.0, w, h);
  f.image = ImageU8(w, h, 1);
  f.depth_m = ImageF(w, h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      f.image(x, y) = static_cast<uint8_t>(128 + 100 * std::sin(0.3 * x) * std::cos(0.2 * y));
      f.depth_m(x, y) = 2.0f + 0.01f * x;
    }
  }
  return f;
}

TEST(HandmadeFeatures, PyramidIsZScoredWithLevelCameras) {
  const Frame frame = MakeFrame(64, 32);
  for (const char* descriptor : {"intensity", "intensity_gradients", "rich"}) {
    HandmadeFeatureOptions options;
    options.descriptor = descriptor;
    HandmadeFeatureSource source(options);
    const FeaturePyramid p = source.Compute(frame, 3);
    ASSERT_EQ(p.num_levels(), 3);
    for (int l = 0; l < 3; ++l) {
      const FeatureLevel& f = p.levels[l];
      EXPECT_EQ(f.width, 64 >> l);
      EXPECT_EQ(f.height, 32 >> l);
      EXPECT_EQ(f.channels, source.num_channels());
      EXPECT_DOUBLE_EQ(f.camera.fx, frame.camera.PyramidLevel(l).fx);
      EXPECT_DOUBLE_EQ(f.camera.cx, frame.camera.PyramidLevel(l).cx);
      for (int c = 0; c < f.channels; ++c) {
        double sum = 0, sq = 0;
        const int n = f.width * f.height;
        for (int i = 0; i < n; ++i) sum += f.Channel(c)[i];
        for (int i = 0; i < n; ++i) sq += std::pow(f.Channel(c)[i] - sum / n, 2);
        EXPECT_NEAR(sum / n, 0.0, 1e-5) << descriptor << " level " << l << " channel " << c;
        EXPECT_NEAR(std::sqrt(sq / n), 1.0, 1e-4) << descriptor << " level " << l;
      }
    }
  }
}

TEST(HandmadeFeatures, RgbAndBadInput) {
  Frame frame = MakeFrame(32, 16);
  ImageU8 rgb(32, 16, 3, 50);
  frame.image = rgb;
  HandmadeFeatureSource source;
  EXPECT_NO_THROW(source.Compute(frame, 2));
  frame.image = ImageU8(32, 16, 2);
  EXPECT_THROW(source.Compute(frame, 2), InputError);
  frame = MakeFrame(32, 16);
  EXPECT_THROW(source.Compute(frame, 4), InputError);  // coarsest 4 x 2 < 4 x 4
  frame.camera.width = 30;
  EXPECT_THROW(source.Compute(frame, 1), InputError);
  HandmadeFeatureOptions bad;
  bad.descriptor = "sift";
  EXPECT_THROW(HandmadeFeatureSource{bad}, ConfigError);
  EXPECT_THROW(MakeFeatureSource("learned"), ConfigError);
}

TEST(DepthSources, ValidityAwareAveraging) {
  ImageF depth(4, 2, 1, 0.0f);
  depth(0, 0) = 2.0f;  // block 0: one valid value among three invalid
  depth(1, 1) = std::numeric_limits<float>::quiet_NaN();
  depth(2, 0) = 1.0f;  // block 1: four valid values
  depth(3, 0) = 2.0f;
  depth(2, 1) = 3.0f;
  depth(3, 1) = 4.0f;
  const ImageF half = DownsampleDepthHalf(depth);
  ASSERT_EQ(half.width(), 2);
  ASSERT_EQ(half.height(), 1);
  EXPECT_FLOAT_EQ(half(0, 0), 2.0f);  // never averaged with the invalid 0 / NaN
  EXPECT_FLOAT_EQ(half(1, 0), 2.5f);
  const ImageF none = DownsampleDepthHalf(ImageF(2, 2, 1, 0.0f));
  EXPECT_FLOAT_EQ(none(0, 0), 0.0f);
}

TEST(DepthSources, GroundTruthPyramid) {
  Frame frame = MakeFrame(64, 32);
  frame.depth_m(5, 5) = std::numeric_limits<float>::infinity();
  frame.depth_m(6, 5) = -1.0f;
  GroundTruthDepthSource source;
  const DepthPyramid p = source.Compute(frame, 3);
  ASSERT_EQ(p.num_levels(), 3);
  EXPECT_EQ(p.levels[2].width(), 16);
  EXPECT_FLOAT_EQ(p.levels[0](5, 5), 0.0f);  // non-finite and negative become invalid
  EXPECT_FLOAT_EQ(p.levels[0](6, 5), 0.0f);
  EXPECT_EQ(p.NumValid(0), 64 * 32 - 2);
  EXPECT_NEAR(p.MeanDepth(2), p.MeanDepth(0), 0.01);
  frame.depth_m = ImageF(10, 10, 1, 1.0f);
  EXPECT_THROW(source.Compute(frame, 3), InputError);
  frame.depth_m = ImageF();
  EXPECT_THROW(source.Compute(frame, 3), InputError);
  EXPECT_THROW(MakeDepthSource("network"), ConfigError);
}

}  // namespace
}  // namespace dfo
