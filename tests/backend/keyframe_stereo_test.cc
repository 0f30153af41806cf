#include "dfo_backend/keyframe_stereo.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/image_pyramid.h"
#include "dfo_core/synthetic/synthetic_sequence.h"

namespace dfo {
namespace {

// Keyframe 40 of a synthetic street, the three frames before it at their true poses, and a
// source depth that is off as a network's is on real video: half the scale, and the range
// compressed about the median (d -> m (d / m)^0.6 / 2).
struct StereoCase {
  PinholeCamera camera;
  ImageF reference;
  std::vector<ImageF> images;
  std::vector<StereoView> views;
  ImageF true_depth;
  DepthPyramid source;
};

StereoCase MakeCase(int num_views) {
  SyntheticOptions options;
  options.seed = 3;
  options.num_frames = 41;
  const SyntheticSequence sequence(options);
  StereoCase c;
  c.camera = sequence.camera();
  const SyntheticFrame keyframe = sequence.RenderFrame(40);
  c.reference = keyframe.gray.Cast<float>();
  c.true_depth = keyframe.depth;
  c.images.reserve(num_views);
  for (int k = 1; k <= num_views; ++k) {
    c.images.push_back(sequence.RenderFrame(40 - k).gray.Cast<float>());
    c.views.push_back(
        {&c.images.back(), sequence.WorldFromCam(40 - k).Inverse() * keyframe.world_from_cam});
  }
  std::vector<float> valid;
  for (float d : c.true_depth.vector()) {
    if (d > 0.0f) valid.push_back(d);
  }
  std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
  const double median = valid[valid.size() / 2];
  ImageF source = c.true_depth;
  for (float& d : source.vector()) {
    if (d > 0.0f) d = static_cast<float>(median * std::pow(d / median, 0.6) / 2.0);
  }
  c.source.levels.push_back(source);
  for (int l = 1; l < 4; ++l)
    c.source.levels.push_back(DownsampleDepthHalf(c.source.levels.back()));
  return c;
}

// Median over the pixels with a true depth (and, when `only` is given, where it is 1) of
// |log(scale * depth / truth)|.
double MedianLogError(const ImageF& depth, const ImageF& truth, double scale,
                      const std::vector<char>* only = nullptr) {
  std::vector<double> errors;
  for (size_t i = 0; i < depth.size(); ++i) {
    const double d = depth.vector()[i], t = truth.vector()[i];
    if (d > 0.0 && t > 0.0 && (only == nullptr || (*only)[i])) {
      errors.push_back(std::abs(std::log(scale * d / t)));
    }
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

// The stereo depth replaces the source's where it is confident, in the source's scale (divided
// by the window scale), and the coarser levels follow the finest.
TEST(KeyframeStereoTest, ReplacesTheSourceDepthByStereoInTheSourcesScale) {
  StereoCase c = MakeCase(3);
  const double window_scale = 2.0;  // the window's poses are metric, the source half the scale
  const ImageF original = c.source.levels[0];
  KeyframeStereoOptions options;
  options.views = 3;
  const KeyframeStereoResult r =
      ApplyKeyframeStereo(c.reference, c.camera, c.views, window_scale, options, &c.source);
  EXPECT_EQ(r.num_views, 3);
  EXPECT_GT(r.fraction, 0.2);
  std::vector<char> replaced(original.size(), 0);
  int num_replaced = 0;
  for (size_t i = 0; i < original.size(); ++i) {
    replaced[i] = original.vector()[i] != c.source.levels[0].vector()[i];
    num_replaced += replaced[i];
  }
  EXPECT_EQ(r.num_replaced, num_replaced);
  // Where the stereo took over, the depth is the truth's (at the window's scale); over the whole
  // image the error falls.
  const double before = MedianLogError(original, c.true_depth, window_scale, &replaced);
  const double after = MedianLogError(c.source.levels[0], c.true_depth, window_scale, &replaced);
  EXPECT_LT(after, 0.05) << "before " << before;
  EXPECT_LT(MedianLogError(c.source.levels[0], c.true_depth, window_scale),
            0.8 * MedianLogError(original, c.true_depth, window_scale));
  EXPECT_EQ(c.source.levels[1].vector(), DownsampleDepthHalf(c.source.levels[0]).vector());
}

TEST(KeyframeStereoTest, FewerThanTwoViewsChangeNothing) {
  StereoCase c = MakeCase(1);
  const std::vector<float> original = c.source.levels[0].vector();
  KeyframeStereoOptions options;
  options.views = 1;
  const KeyframeStereoResult r =
      ApplyKeyframeStereo(c.reference, c.camera, c.views, 2.0, options, &c.source);
  EXPECT_EQ(r.num_views, 1);
  EXPECT_EQ(r.num_replaced, 0);
  EXPECT_EQ(c.source.levels[0].vector(), original);
}

// stereo.max_source_ratio keeps the source where the stereo disagrees with it by more.
TEST(KeyframeStereoTest, SourceRatioLimitKeepsFarOffStereoOut) {
  StereoCase free_case = MakeCase(3), limited_case = MakeCase(3);
  KeyframeStereoOptions options;
  options.views = 3;
  const KeyframeStereoResult free_result = ApplyKeyframeStereo(
      free_case.reference, free_case.camera, free_case.views, 2.0, options, &free_case.source);
  options.max_source_ratio = 1.1;
  const KeyframeStereoResult limited =
      ApplyKeyframeStereo(limited_case.reference, limited_case.camera, limited_case.views, 2.0,
                          options, &limited_case.source);
  EXPECT_GT(limited.num_replaced, 0);
  EXPECT_LT(limited.num_replaced, free_result.num_replaced / 2);
}

TEST(KeyframeStereoTest, CheckNamesTheKey) {
  const auto message = [](const KeyframeStereoOptions& o) {
    try {
      o.Check();
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  KeyframeStereoOptions o;
  EXPECT_EQ(message(o), "");
  o.views = 13;
  EXPECT_NE(message(o).find("stereo.views = 13"), std::string::npos);
  o = KeyframeStereoOptions();
  o.max_source_ratio = 0.5;
  EXPECT_NE(message(o).find("stereo.max_source_ratio"), std::string::npos);
  o = KeyframeStereoOptions();
  o.depth_samples = 4;
  EXPECT_NE(message(o).find("stereo.depth_samples"), std::string::npos);
}

}  // namespace
}  // namespace dfo
