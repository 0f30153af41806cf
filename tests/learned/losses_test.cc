// Training losses on known inputs: zero appearance loss for identical images, the robust clamp's
// kink, the smoothness term of a known disparity ramp, KL sparsity at and away from rho, the
// reconstruction loss, the inverse warp with identity and a pure translation, and the geometry
// consistency of a plane seen from two depths.
#include "dfo_frontend/learned/internal/losses.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dfo_core/error.h"

namespace dfo::learned {
namespace {

torch::Tensor RandomImage(int64_t n, int64_t c, int64_t h, int64_t w, uint64_t seed) {
  torch::manual_seed(seed);
  return torch::rand({n, c, h, w});
}

TEST(LossesTest, IdenticalImagesGiveZeroAppearanceLoss) {
  const torch::Tensor image = RandomImage(2, 3, 16, 24, 1);
  const LossOptions options;
  EXPECT_NEAR(AppearanceLoss(image, image.clone(), torch::Tensor(), options).item<double>(), 0.0,
              1e-6);
  EXPECT_NEAR(DssimMap(image, image).abs().max().item<double>(), 0.0, 1e-6);
}

TEST(LossesTest, DifferentImagesGivePositiveLossAndValidMaskSelectsPixels) {
  const torch::Tensor a = RandomImage(1, 3, 16, 24, 2);
  const torch::Tensor b = RandomImage(1, 3, 16, 24, 3);
  const LossOptions options;
  const double full = AppearanceLoss(a, b, torch::Tensor(), options).item<double>();
  EXPECT_GT(full, 0.05);
  // A mask with no valid pixel gives 0 (not NaN).
  const torch::Tensor none = torch::zeros({1, 1, 16, 24});
  EXPECT_EQ(AppearanceLoss(a, b, none, options).item<double>(), 0.0);
  // A mask selecting the left half equals the mean of the map over that half.
  torch::Tensor left = torch::zeros({1, 1, 16, 24});
  left.slice(3, 0, 12).fill_(1.0);
  const torch::Tensor map = AppearanceMap(a, b, options);
  EXPECT_NEAR(AppearanceLoss(a, b, left, options).item<double>(),
              map.slice(3, 0, 12).mean().item<double>(), 1e-6);
}

TEST(LossesTest, RobustClampIsIdentityBelowEpsAndTenthSlopeAbove) {
  const torch::Tensor x = torch::tensor({0.0, 0.1, 0.15, 0.25, 1.0}, torch::kFloat64);
  const torch::Tensor y = RobustClamp(x, 0.15);
  EXPECT_DOUBLE_EQ(y[0].item<double>(), 0.0);
  EXPECT_DOUBLE_EQ(y[1].item<double>(), 0.1);
  EXPECT_NEAR(y[2].item<double>(), 0.15, 1e-12);  // continuous at eps
  EXPECT_NEAR(y[3].item<double>(), 0.1 * 0.25 + 0.9 * 0.15, 1e-12);
  EXPECT_NEAR(y[4].item<double>(), 0.1 + 0.135, 1e-12);
}

TEST(LossesTest, AppearanceOfAConstantOffsetIsTheClampedL1Part) {
  // Two constant images differing by 0.5: SSIM of constant windows is the luminance term
  // (2 m1 m2 + C1) / (m1^2 + m2^2 + C1); L1 = 0.5 is clamped to 0.1 * 0.5 + 0.9 * 0.3 = 0.32.
  const torch::Tensor a = torch::full({1, 3, 8, 8}, 0.2);
  const torch::Tensor b = torch::full({1, 3, 8, 8}, 0.7);
  const double c1 = 1e-4;
  const double ssim = (2 * 0.2 * 0.7 + c1) / (0.04 + 0.49 + c1);
  double dssim = (1 - ssim) / 2;
  dssim = dssim < 0.15 ? dssim : 0.1 * dssim + 0.9 * 0.15;
  const double expected = 0.85 * dssim + 0.15 * 0.32;
  EXPECT_NEAR(AppearanceLoss(a, b, torch::Tensor(), LossOptions()).item<double>(), expected, 1e-5);
}

TEST(LossesTest, KnownDisparityRampGivesExpectedSmoothness) {
  // Disparity d(x) = 1 + 0.1 x over a constant image: normalised by its mean m, |d/dx| = 0.1 / m
  // everywhere, |d/dy| = 0, and exp(-|grad I|) = 1.
  const int64_t w = 21, h = 5;
  const torch::Tensor disp =
      (1.0 + 0.1 * torch::arange(w, torch::kFloat32)).view({1, 1, 1, w}).expand({1, 1, h, w});
  const torch::Tensor image = torch::full({1, 3, h, w}, 0.5);
  const double mean = 1.0 + 0.1 * (w - 1) / 2.0;
  EXPECT_NEAR(SmoothnessLoss(disp.contiguous(), image).item<double>(), 0.1 / mean, 1e-6);
  // A vertical image edge of height 1 between every column weights each x-step by exp(-1).
  const torch::Tensor stripes =
      (torch::arange(w, torch::kFloat32).remainder(2)).view({1, 1, 1, w}).expand({1, 3, h, w});
  EXPECT_NEAR(SmoothnessLoss(disp.contiguous(), stripes.contiguous()).item<double>(),
              0.1 / mean * std::exp(-1.0), 1e-6);
  // A constant disparity is perfectly smooth.
  EXPECT_NEAR(SmoothnessLoss(torch::full({1, 1, h, w}, 3.0), image).item<double>(), 0.0, 1e-7);
}

TEST(LossesTest, SparsityKlIsZeroAtTargetDensityAndPositiveElsewhere) {
  const double rho = 0.1;
  torch::Tensor mask = torch::zeros({2, 1, 10, 10});
  // Exactly 10% ones.
  mask.view({-1}).slice(0, 0, 20).fill_(1.0);
  EXPECT_NEAR(SparsityLoss(mask, rho).item<double>(), 0.0, 1e-6);
  const torch::Tensor soft = torch::full({1, 1, 4, 4}, rho);
  EXPECT_NEAR(SparsityLoss(soft, rho).item<double>(), 0.0, 1e-6);
  const double m = 0.5;
  const double expected = rho * std::log(rho / m) + (1 - rho) * std::log((1 - rho) / (1 - m));
  EXPECT_NEAR(SparsityLoss(torch::full({1, 1, 4, 4}, m), rho).item<double>(), expected, 1e-5);
  EXPECT_GT(expected, 0.0);
}

TEST(LossesTest, ReconstructionLossIsMeanSquaredError) {
  const torch::Tensor a = torch::zeros({1, 3, 4, 4});
  const torch::Tensor b = torch::full({1, 3, 4, 4}, 0.5);
  EXPECT_NEAR(ReconstructionLoss(a, b).item<double>(), 0.25, 1e-7);
  EXPECT_THROW(ReconstructionLoss(a, torch::zeros({1, 3, 4, 5})), InternalError);
}

TEST(LossesTest, InverseWarpIdentityReturnsTheSourceAndTranslationShiftsIt) {
  const int64_t h = 12, w = 20;
  const torch::Tensor source = RandomImage(1, 3, h, w, 4);
  const torch::Tensor depth = torch::full({1, 1, h, w}, 10.0);
  const torch::Tensor k = torch::tensor({{50.0, 50.0, 9.5, 5.5}});
  torch::Tensor valid;
  const torch::Tensor same =
      InverseWarp(source, depth, torch::eye(3).unsqueeze(0), torch::zeros({1, 3}), k, &valid);
  EXPECT_NEAR((same - source).abs().max().item<double>(), 0.0, 1e-5);
  EXPECT_EQ(valid.sum().item<double>(), static_cast<double>(h * w));
  // Moving the points by +0.4 m in x at 10 m depth shifts them by fx * 0.4 / 10 = 2 pixels:
  // reconstruction(x) = source(x + 2); the last 2 columns fall outside.
  const torch::Tensor shifted = InverseWarp(source, depth, torch::eye(3).unsqueeze(0),
                                            torch::tensor({{0.4, 0.0, 0.0}}), k, &valid);
  EXPECT_NEAR((shifted.slice(3, 0, w - 2) - source.slice(3, 2, w)).abs().max().item<double>(), 0.0,
              1e-4);
  EXPECT_EQ(valid.sum().item<double>(), static_cast<double>(h * (w - 2)));
}

TEST(LossesTest, DepthConsistencyIsZeroForAConsistentSceneAndMeasuresAScaleError) {
  // A fronto-parallel plane at 10 m seen from a source 1 m further back: the target's points lie
  // at 11 m in the source, so a source depth map of 11 m is consistent (loss 0) and one of
  // 13.2 m (1.2x) gives |11 - 13.2| / (11 + 13.2) on every pixel.
  const int64_t h = 12, w = 20;
  const torch::Tensor k = torch::tensor({{50.0, 50.0, 9.5, 5.5}});
  const torch::Tensor r = torch::eye(3).unsqueeze(0);
  const torch::Tensor t = torch::tensor({{0.0, 0.0, 1.0}});
  const torch::Tensor target = torch::full({1, 1, h, w}, 10.0);
  const torch::Tensor ok = torch::ones({1});
  EXPECT_NEAR(
      DepthConsistencyLoss(target, torch::full({1, 1, h, w}, 11.0), r, t, k, ok).item<double>(),
      0.0, 1e-6);
  EXPECT_NEAR(
      DepthConsistencyLoss(target, torch::full({1, 1, h, w}, 13.2), r, t, k, ok).item<double>(),
      2.2 / 24.2, 1e-5);
  // A left-out sample (failed alignment) contributes nothing; none left gives 0.
  EXPECT_EQ(
      DepthConsistencyLoss(target, torch::full({1, 1, h, w}, 13.2), r, t, k, torch::zeros({1}))
          .item<double>(),
      0.0);
  // The gradient pulls the two depths together: the source's depth down, the target's up.
  const torch::Tensor target_var = target.clone().requires_grad_(true);
  const torch::Tensor source_var = torch::full({1, 1, h, w}, 13.2).requires_grad_(true);
  DepthConsistencyLoss(target_var, source_var, r, t, k, ok).backward();
  EXPECT_GT(source_var.grad().sum().item<double>(), 0.0);
  EXPECT_LT(target_var.grad().sum().item<double>(), 0.0);
}

TEST(LossesTest, OptionsCheckNamesTheField) {
  LossOptions options;
  options.sparsity_target = 1.5;
  try {
    options.Check();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("train.sparsity_target = 1.5"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dfo::learned
