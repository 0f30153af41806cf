#include "dfo_core/depth_metrics.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dfo_core/error.h"

namespace dfo {
namespace {

TEST(DepthMetrics, PerfectPredictionScoresZeroAndOne) {
  ImageF gt(8, 4, 1, 12.5f);
  const DepthErrors e = ComputeDepthErrors(gt, gt);
  EXPECT_EQ(e.num_pixels, 32u);
  EXPECT_EQ(e.num_images, 1u);
  EXPECT_DOUBLE_EQ(e.abs_rel, 0.0);
  EXPECT_DOUBLE_EQ(e.rmse, 0.0);
  EXPECT_DOUBLE_EQ(e.rmse_log, 0.0);
  EXPECT_DOUBLE_EQ(e.a1, 1.0);
  EXPECT_DOUBLE_EQ(e.a3, 1.0);
}

TEST(DepthMetrics, KnownValuesOnAConstructedMap) {
  // 10 valid pixels of gt 10 m: half predicted 12 m, half 10 m; plus invalid gt pixels
  // (0, beyond max_depth, NaN) that must not count whatever is predicted there.
  ImageF gt(14, 1, 1, 10.0f), pred(14, 1, 1, 10.0f);
  for (int x = 0; x < 5; ++x) pred(x, 0) = 12.0f;
  gt(10, 0) = 0.0f;
  gt(11, 0) = 95.0f;
  gt(12, 0) = std::nanf("");
  gt(13, 0) = 80.0f;  // == max_depth: excluded (mask is gt < max_depth, as Monodepth2)
  for (int x = 10; x < 14; ++x) pred(x, 0) = 1000.0f;
  const DepthErrors e = ComputeDepthErrors(gt, pred);
  EXPECT_EQ(e.num_pixels, 10u);
  EXPECT_NEAR(e.abs_rel, 0.5 * 0.2, 1e-12);
  EXPECT_NEAR(e.sq_rel, 0.5 * 4.0 / 10.0, 1e-12);
  EXPECT_NEAR(e.rmse, std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(e.rmse_log, std::sqrt(0.5) * std::log(1.2), 1e-12);
  EXPECT_DOUBLE_EQ(e.a1, 1.0);  // 1.2 < 1.25

  // Predictions 1.9x too far: fail a1 (1.9 > 1.25) and a2 (> 1.5625), pass a3 (< 1.953).
  ImageF far(14, 1, 1, 19.0f);
  const DepthErrors f = ComputeDepthErrors(gt, far);
  EXPECT_DOUBLE_EQ(f.a1, 0.0);
  EXPECT_DOUBLE_EQ(f.a2, 0.0);
  EXPECT_DOUBLE_EQ(f.a3, 1.0);
  EXPECT_NEAR(f.abs_rel, 0.9, 1e-12);
}

TEST(DepthMetrics, MedianScalingRemovesAGlobalScaleAndClampsPredictions) {
  ImageF gt(4, 4), pred(4, 4);
  for (int y = 0; y < 4; ++y) {
    for (int x = 0; x < 4; ++x) {
      gt(x, y) = 1.0f + x + 4 * y;
      pred(x, y) = 0.25f * gt(x, y);
    }
  }
  DepthMetricsOptions options;
  options.median_scaling = true;
  const DepthErrors e = ComputeDepthErrors(gt, pred, options);
  EXPECT_NEAR(e.median_scale, 4.0, 1e-6);
  EXPECT_NEAR(e.abs_rel, 0.0, 1e-6);
  EXPECT_NEAR(e.a1, 1.0, 1e-12);
  // The raw medians (16 values: the mean of the middle two, 8.5), with or without the scaling.
  EXPECT_NEAR(e.median_ground_truth, 8.5, 1e-6);
  EXPECT_NEAR(e.median_prediction, 8.5 / 4.0, 1e-6);
  EXPECT_NEAR(ComputeDepthErrors(gt, pred).median_prediction, 8.5 / 4.0, 1e-6);

  // Without scaling a zero prediction is clamped to min_depth, a huge one to max_depth.
  ImageF one(2, 1, 1, 10.0f), bad(2, 1);
  bad(0, 0) = 0.0f;
  bad(1, 0) = 1e6f;
  const DepthErrors c = ComputeDepthErrors(one, bad);
  EXPECT_NEAR(c.abs_rel, 0.5 * ((10.0 - 1e-3) / 10.0 + 70.0 / 10.0), 1e-9);
}

TEST(DepthMetrics, AverageIsOverImagesNotPixels) {
  ImageF gt_small(1, 1, 1, 10.0f), pred_small(1, 1, 1, 12.0f);  // abs_rel 0.2, one pixel
  ImageF gt_big(10, 10, 1, 10.0f);                              // abs_rel 0, 100 pixels
  ImageF empty_gt(3, 3, 1, 0.0f);                               // no valid pixel: skipped
  const std::vector<DepthErrors> per_image = {ComputeDepthErrors(gt_small, pred_small),
                                              ComputeDepthErrors(gt_big, gt_big),
                                              ComputeDepthErrors(empty_gt, empty_gt)};
  EXPECT_EQ(per_image[2].num_images, 0u);
  EXPECT_TRUE(std::isnan(per_image[2].abs_rel));
  const DepthErrors mean = AverageDepthErrors(per_image);
  EXPECT_EQ(mean.num_images, 2u);
  EXPECT_EQ(mean.num_pixels, 101u);
  EXPECT_NEAR(mean.abs_rel, 0.1, 1e-12);
  EXPECT_TRUE(std::isnan(per_image[2].median_ground_truth));
  EXPECT_TRUE(std::isnan(mean.median_prediction));  // medians are per image only
  EXPECT_TRUE(std::isnan(AverageDepthErrors({}).abs_rel));
}

TEST(DepthMetrics, MedianScaleCvIsTheSpreadOfThePerImageRatios) {
  // Three images whose predictions are 1/2, 1/4 and 1/6 of the truth: ratios 2, 4, 6, mean 4,
  // population standard deviation sqrt(8 / 3).
  ImageF gt(3, 1, 1, 12.0f);
  DepthMetricsOptions options;
  options.median_scaling = true;
  std::vector<DepthErrors> per_image;
  for (float ratio : {2.0f, 4.0f, 6.0f}) {
    per_image.push_back(ComputeDepthErrors(gt, ImageF(3, 1, 1, 12.0f / ratio), options));
  }
  const DepthErrors mean = AverageDepthErrors(per_image);
  EXPECT_NEAR(mean.median_scale, 4.0, 1e-6);
  EXPECT_NEAR(mean.median_scale_cv, std::sqrt(8.0 / 3.0) / 4.0, 1e-6);
  // One image has no spread.
  EXPECT_EQ(AverageDepthErrors({per_image[0]}).median_scale_cv, 0.0);
}

TEST(DepthMetrics, SizeMismatchAndBadOptionsThrow) {
  EXPECT_THROW(ComputeDepthErrors(ImageF(4, 4), ImageF(4, 5)), InputError);
  EXPECT_THROW(ComputeDepthErrors(ImageF(4, 4, 2), ImageF(4, 4, 2)), InputError);
  DepthMetricsOptions options;
  options.max_depth = 1e-4;
  EXPECT_THROW(ComputeDepthErrors(ImageF(1, 1), ImageF(1, 1), options), ConfigError);
  options = DepthMetricsOptions();
  options.min_depth = 0.0;
  EXPECT_THROW(ComputeDepthErrors(ImageF(1, 1), ImageF(1, 1), options), ConfigError);
}

}  // namespace
}  // namespace dfo
