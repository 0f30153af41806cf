// The pose manifold and the feature-metric cost: analytic Jacobians against numeric ones
// (ceres::GradientChecker, through the manifold) and against an autodiff twin of the residual.
#include "dfo_backend/feature_metric_cost.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/crs_matrix.h>
#include <ceres/gradient_checker.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <random>

#include "dfo_backend/pose_manifold.h"
#include "dfo_core/lie.h"
#include "tests/backend/synthetic_keyframes.h"

namespace dfo {
namespace {

// Smooth, non-periodic C-channel feature map (sums of sinusoids with per-channel frequencies).
FeatureLevel SmoothLevel(int width, int height, int channels) {
  const PinholeCamera camera(60.0, 60.0, (width - 1) / 2.0, (height - 1) / 2.0, width, height);
  FeatureLevel level(width, height, channels, camera);
  for (int c = 0; c < channels; ++c) {
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        level.Channel(c)[y * width + x] =
            static_cast<float>(std::sin(0.31 * x * (1 + 0.2 * c) + 0.17 * y) +
                               0.5 * std::cos(0.23 * y * (1 + c) - 0.11 * x + c));
      }
    }
  }
  return level;
}

SE3d RandomPose(std::mt19937* rng, double rot, double trans) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  for (int i = 0; i < 3; ++i) xi(i) = trans * n(*rng);
  for (int i = 3; i < 6; ++i) xi(i) = rot * n(*rng);
  return SE3d::Exp(xi);
}

// Autodiff twin of FeatureMetricCost: the same residual written directly (X_h = ray / rho,
// X_t = T_t^-1 T_h X_h), differentiated by Ceres's Jets.
struct FeatureMetricTwin {
  const FeatureLevel* target;
  PinholeCamera host_camera;
  Eigen::Vector2d uv;
  int patch_size;
  std::vector<double> host_patch;
  std::vector<double> depth_shape;  // empty: fronto-parallel

  template <typename T>
  static double Scalar(const T& v) {
    if constexpr (std::is_same_v<T, double>) {
      return v;
    } else {
      return v.a;
    }
  }

  template <typename T>
  bool operator()(const T* host, const T* tgt, const T* rho, T* residuals) const {
    Eigen::Quaternion<T> qh(host[3], host[0], host[1], host[2]);
    Eigen::Quaternion<T> qt(tgt[3], tgt[0], tgt[1], tgt[2]);
    qh.normalize();
    qt.normalize();
    const Eigen::Matrix<T, 3, 1> th(host[4], host[5], host[6]), tt(tgt[4], tgt[5], tgt[6]);
    const int r = patch_size / 2, kk = patch_size * patch_size;
    const int w = target->width, h = target->height;
    const PinholeCamera& cam = target->camera;
    for (int dy = -r; dy <= r; ++dy) {
      for (int dx = -r; dx <= r; ++dx) {
        const int k = (dy + r) * patch_size + (dx + r);
        const Eigen::Vector3d ray = host_camera.Ray(Eigen::Vector2d(uv.x() + dx, uv.y() + dy));
        // Pixel k at depth shape[k] / rho (the surface of the host's depth map).
        const double d = depth_shape.empty() ? 1.0 : depth_shape[k];
        const Eigen::Matrix<T, 3, 1> x_h = (d * ray).cast<T>() / rho[0];
        const Eigen::Matrix<T, 3, 1> x_t = qt.conjugate() * (qh * x_h + th - tt);
        const T px = T(cam.fx) * x_t.x() / x_t.z() + T(cam.cx);
        const T py = T(cam.fy) * x_t.y() / x_t.z() + T(cam.cy);
        const bool in_front = Scalar(x_t.z()) > 0;
        // Clamped to the border outside the image (constant, so derivative 0 along that axis).
        T cx = px, cy = py;
        if (!(Scalar(px) >= 0 && Scalar(px) <= w - 1.0)) cx = T(Scalar(px) < 0 ? 0.0 : w - 1.0);
        if (!(Scalar(py) >= 0 && Scalar(py) <= h - 1.0)) cy = T(Scalar(py) < 0 ? 0.0 : h - 1.0);
        const double sx = Scalar(cx), sy = Scalar(cy);
        for (int c = 0; c < target->channels; ++c) {
          if (!in_front) {
            residuals[c * kk + k] = T(host_patch[c * kk + k]);
            continue;
          }
          const int x0 = std::min(static_cast<int>(std::floor(sx)), w - 2);
          const int y0 = std::min(static_cast<int>(std::floor(sy)), h - 2);
          const T ax = cx - T(x0), ay = cy - T(y0);
          const double v00 = target->At(c, x0, y0), v10 = target->At(c, x0 + 1, y0);
          const double v01 = target->At(c, x0, y0 + 1), v11 = target->At(c, x0 + 1, y0 + 1);
          const T value =
              (T(1) - ay) * ((T(1) - ax) * v00 + ax * v10) + ay * ((T(1) - ax) * v01 + ax * v11);
          residuals[c * kk + k] = T(host_patch[c * kk + k]) - value;
        }
      }
    }
    return true;
  }
};

// The host turned 90 degrees about its y axis: no patch pixel is in view, all clamped in x.
void TurnedAway(const double* host_pose, double* target_pose) {
  const SE3d turned = PoseFromParameters(host_pose) *
                      SE3d(SO3d::Exp(Eigen::Vector3d(0, M_PI / 2, 0)), Eigen::Vector3d::Zero());
  PoseToParameters(turned, target_pose);
}

struct CostFixture {
  FeatureLevel host = SmoothLevel(64, 48, 4);
  FeatureLevel target = SmoothLevel(64, 48, 4);
  double host_pose[7], target_pose[7];
  double rho = 0.2;  // 5 m
  Eigen::Vector2d uv{30, 22};
  std::shared_ptr<const std::vector<double>> patch;

  explicit CostFixture(int seed) {
    std::mt19937 rng(seed);
    const SE3d world_from_host = RandomPose(&rng, 0.3, 1.0);
    // Target near the host, so the point stays in view.
    const SE3d world_from_target = world_from_host * RandomPose(&rng, 0.03, 0.2);
    PoseToParameters(world_from_host, host_pose);
    PoseToParameters(world_from_target, target_pose);
    patch = std::make_shared<const std::vector<double>>(
        SampleHostPatch(host, static_cast<int>(uv.x()), static_cast<int>(uv.y()), 3));
  }
};

TEST(PoseManifoldTest, MinusJacobianIsLeftInverseOfPlusJacobian) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    double x[7];
    PoseToParameters(RandomPose(&rng, 1.0, 3.0), x);
    const Matrix6d product = PoseMinusJacobian(x) * PosePlusJacobian(x);
    EXPECT_LT((product - Matrix6d::Identity()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(PoseManifoldTest, PlusMinusRoundTripAndLeftPerturbation) {
  std::mt19937 rng(4);
  SE3Manifold manifold;
  double x[7], y[7];
  const SE3d pose = RandomPose(&rng, 1.0, 3.0);
  PoseToParameters(pose, x);
  Vector6d delta;
  delta << 0.1, -0.2, 0.3, 0.05, -0.02, 0.04;
  ASSERT_TRUE(manifold.Plus(x, delta.data(), y));
  const SE3d expected = SE3d::Exp(delta) * pose;
  EXPECT_LT(
      (PoseFromParameters(y).Matrix3x4Form() - expected.Matrix3x4Form()).cwiseAbs().maxCoeff(),
      1e-12);
  Vector6d back;
  ASSERT_TRUE(manifold.Minus(y, x, back.data()));
  EXPECT_LT((back - delta).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(PoseManifoldTest, PlusJacobianMatchesFiniteDifferences) {
  std::mt19937 rng(5);
  SE3Manifold manifold;
  double x[7];
  PoseToParameters(RandomPose(&rng, 1.0, 3.0), x);
  const Matrix7x6d analytic = PosePlusJacobian(x);
  const double h = 1e-7;
  for (int j = 0; j < 6; ++j) {
    double dp[6] = {0, 0, 0, 0, 0, 0}, dm[6] = {0, 0, 0, 0, 0, 0}, yp[7], ym[7];
    dp[j] = h;
    dm[j] = -h;
    manifold.Plus(x, dp, yp);
    manifold.Plus(x, dm, ym);
    for (int i = 0; i < 7; ++i) EXPECT_NEAR((yp[i] - ym[i]) / (2 * h), analytic(i, j), 1e-7);
  }
}

// The warp's stretch: 1 for the same view and for a roll about the optical axis; the inverse
// depth ratio when the target moves along the ray of a point at the principal point (the patch
// looks twice as large from half the distance), and its inverse moving away; the finite-difference
// derivative of the warp elsewhere; 0 behind the camera.
TEST(FeatureMetricCostTest, WarpStretchIsTheScaleOfTheWarp) {
  const FeatureLevel level = SmoothLevel(64, 48, 2);
  const PinholeCamera& cam = level.camera;
  const Eigen::Vector2d centre(cam.cx, cam.cy);
  auto patch = std::make_shared<const std::vector<double>>(
      SampleHostPatch(level, static_cast<int>(centre.x()), static_cast<int>(centre.y()), 3));
  FeatureMetricCost at_centre(
      &level, cam, Eigen::Vector2d(std::floor(centre.x()), std::floor(centre.y())), 3, patch);
  double host[7], target[7];
  PoseToParameters(SE3d(), host);
  const double rho = 0.1;  // 10 m
  auto stretch = [&](const SE3d& world_from_target, const FeatureMetricCost& cost) {
    PoseToParameters(world_from_target, target);
    return cost.WarpStretch(host, target, rho);
  };
  Eigen::Vector2d s = stretch(SE3d(), at_centre);
  EXPECT_NEAR(s(0), 1.0, 1e-12);
  EXPECT_NEAR(s(1), 1.0, 1e-12);
  s = stretch(SE3d(SO3d::Exp(Eigen::Vector3d(0, 0, 0.4)), Eigen::Vector3d::Zero()), at_centre);
  EXPECT_NEAR(s(0), 1.0, 1e-12);
  EXPECT_NEAR(s(1), 1.0, 1e-12);
  // floor() moved the pixel off the principal point by < 1 px: the ray is still within 0.3 deg
  // of the axis, so the stretch is the depth ratio to 1e-4.
  s = stretch(SE3d(SO3d(), Eigen::Vector3d(0, 0, 5.0)), at_centre);
  EXPECT_NEAR(s(0), 2.0, 1e-3);
  EXPECT_NEAR(s(1), 2.0, 1e-3);
  s = stretch(SE3d(SO3d(), Eigen::Vector3d(0, 0, -10.0)), at_centre);
  EXPECT_NEAR(s(0), 0.5, 1e-3);
  EXPECT_NEAR(s(1), 0.5, 1e-3);
  s = stretch(SE3d(SO3d(), Eigen::Vector3d(0, 0, 12.0)), at_centre);
  EXPECT_EQ(s(0), 0.0);
  EXPECT_EQ(s(1), 0.0);

  // Off-centre with a general motion: the singular values of the central-difference derivative
  // of the warped patch centre.
  const Eigen::Vector2d uv(9.0, 37.0);
  FeatureMetricCost off(&level, cam, uv, 3, patch);
  const SE3d world_from_target(SO3d::Exp(Eigen::Vector3d(0.05, -0.2, 0.1)),
                               Eigen::Vector3d(0.8, -0.3, 3.0));
  s = stretch(world_from_target, off);
  auto warp = [&](const Eigen::Vector2d& u) {
    const Eigen::Vector3d x_host = cam.Ray(u) / rho;
    return cam.Project(world_from_target.Inverse() * x_host);
  };
  const double h = 1e-4;
  Eigen::Matrix2d a;
  a.col(0) = (warp(uv + Eigen::Vector2d(h, 0)) - warp(uv - Eigen::Vector2d(h, 0))) / (2 * h);
  a.col(1) = (warp(uv + Eigen::Vector2d(0, h)) - warp(uv - Eigen::Vector2d(0, h))) / (2 * h);
  const Eigen::Vector2d expected = Eigen::JacobiSVD<Eigen::Matrix2d>(a).singularValues();
  EXPECT_NEAR(s(0), expected(0), 1e-6);
  EXPECT_NEAR(s(1), expected(1), 1e-6);
  EXPECT_GT(s(0) / s(1), 1.05);  // an anisotropic case
}

TEST(FeatureMetricCostTest, GradientCheckerPassesThroughTheManifold) {
  for (int seed = 0; seed < 5; ++seed) {
    CostFixture fx(seed);
    FeatureMetricCost cost(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
    ASSERT_EQ(cost.num_residuals(), 4 * 9);
    ASSERT_EQ(cost.NumVisible(fx.host_pose, fx.target_pose, fx.rho), 9) << "seed " << seed;
    SE3Manifold manifold;
    const std::vector<const ceres::Manifold*> manifolds = {&manifold, &manifold, nullptr};
    // GradientChecker differentiates with Ridders' method from a 1% step by default; the
    // bilinear interpolant is only piecewise smooth (cells of 1 px), so start from a tiny step.
    ceres::NumericDiffOptions numeric;
    numeric.ridders_relative_initial_step_size = 1e-6;
    ceres::GradientChecker checker(&cost, &manifolds, numeric);
    const double* params[] = {fx.host_pose, fx.target_pose, &fx.rho};
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(params, 1e-6, &results)) << "seed " << seed << "\n"
                                                       << results.error_log;
  }
}

TEST(FeatureMetricCostTest, AnalyticEqualsAutodiffTwin) {
  for (int seed = 10; seed < 15; ++seed) {
    CostFixture fx(seed);
    FeatureMetricCost cost(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
    auto* twin = new FeatureMetricTwin{&fx.target, fx.host.camera, fx.uv, 3, *fx.patch, {}};
    ceres::AutoDiffCostFunction<FeatureMetricTwin, ceres::DYNAMIC, 7, 7, 1> autodiff(twin, 36);
    const int n = 36;
    const double* params[] = {fx.host_pose, fx.target_pose, &fx.rho};
    Eigen::VectorXd r_analytic(n), r_auto(n);
    RowMajorMatrixXd jh(n, 6), jt(n, 6);
    Eigen::VectorXd jr(n);
    ASSERT_TRUE(cost.EvaluateTangent(fx.host_pose, fx.target_pose, fx.rho, r_analytic.data(),
                                     jh.data(), jt.data(), jr.data()));
    RowMajorMatrixXd ah(n, 7), at(n, 7);
    Eigen::VectorXd ar(n);
    double* jac[] = {ah.data(), at.data(), ar.data()};
    ASSERT_TRUE(autodiff.Evaluate(params, r_auto.data(), jac));
    EXPECT_LT((r_analytic - r_auto).cwiseAbs().maxCoeff(), 1e-9);
    const RowMajorMatrixXd th = ah * PosePlusJacobian(fx.host_pose);
    const RowMajorMatrixXd tt = at * PosePlusJacobian(fx.target_pose);
    const double scale = jh.cwiseAbs().maxCoeff();
    EXPECT_GT(scale, 1e-3);
    EXPECT_LT((th - jh).cwiseAbs().maxCoeff(), 1e-8 * scale) << "seed " << seed;
    EXPECT_LT((tt - jt).cwiseAbs().maxCoeff(), 1e-8 * scale) << "seed " << seed;
    EXPECT_LT((ar - jr).cwiseAbs().maxCoeff(), 1e-8 * std::max(1.0, jr.cwiseAbs().maxCoeff()));
    // The gauge: a common left perturbation of both poses changes nothing.
    EXPECT_LT((jh + jt).cwiseAbs().maxCoeff(), 1e-12 * scale);
  }
}

// With a depth shape (a slanted patch: depths 0.8-1.25x the centre's) the analytic residuals and
// Jacobians still equal the twin's and pass the gradient checker.
TEST(FeatureMetricCostTest, DepthShapedPatchEqualsTwinAndPassesGradientChecker) {
  const auto shape = std::make_shared<const std::vector<double>>(
      std::vector<double>{0.8, 0.85, 0.9, 0.95, 1.0, 1.05, 1.1, 1.2, 1.25});
  for (int seed = 30; seed < 33; ++seed) {
    CostFixture fx(seed);
    FeatureMetricCost cost(&fx.target, fx.host.camera, fx.uv, 3, fx.patch, shape);
    FeatureMetricCost flat(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
    auto* twin = new FeatureMetricTwin{&fx.target, fx.host.camera, fx.uv, 3, *fx.patch, *shape};
    ceres::AutoDiffCostFunction<FeatureMetricTwin, ceres::DYNAMIC, 7, 7, 1> autodiff(twin, 36);
    const int n = 36;
    const double* params[] = {fx.host_pose, fx.target_pose, &fx.rho};
    Eigen::VectorXd r_analytic(n), r_flat(n), r_auto(n);
    RowMajorMatrixXd jh(n, 6), jt(n, 6);
    Eigen::VectorXd jr(n);
    ASSERT_TRUE(cost.EvaluateTangent(fx.host_pose, fx.target_pose, fx.rho, r_analytic.data(),
                                     jh.data(), jt.data(), jr.data()));
    ASSERT_TRUE(flat.EvaluateTangent(fx.host_pose, fx.target_pose, fx.rho, r_flat.data(), nullptr,
                                     nullptr, nullptr));
    RowMajorMatrixXd ah(n, 7), at(n, 7);
    Eigen::VectorXd ar(n);
    double* jac[] = {ah.data(), at.data(), ar.data()};
    ASSERT_TRUE(autodiff.Evaluate(params, r_auto.data(), jac));
    EXPECT_LT((r_analytic - r_auto).cwiseAbs().maxCoeff(), 1e-9);
    // The shape matters: the patch's corners move.
    EXPECT_GT((r_analytic - r_flat).cwiseAbs().maxCoeff(), 1e-3) << "seed " << seed;
    const double scale = jh.cwiseAbs().maxCoeff();
    EXPECT_LT((ah * PosePlusJacobian(fx.host_pose) - jh).cwiseAbs().maxCoeff(), 1e-8 * scale);
    EXPECT_LT((at * PosePlusJacobian(fx.target_pose) - jt).cwiseAbs().maxCoeff(), 1e-8 * scale);
    EXPECT_LT((ar - jr).cwiseAbs().maxCoeff(), 1e-8 * std::max(1.0, jr.cwiseAbs().maxCoeff()));
    SE3Manifold manifold;
    const std::vector<const ceres::Manifold*> manifolds = {&manifold, &manifold, nullptr};
    ceres::NumericDiffOptions numeric;
    numeric.ridders_relative_initial_step_size = 1e-6;
    ceres::GradientChecker checker(&cost, &manifolds, numeric);
    ceres::GradientChecker::ProbeResults results;
    EXPECT_TRUE(checker.Probe(params, 1e-6, &results)) << "seed " << seed << "\n"
                                                       << results.error_log;
  }
}

// Frames 0 (host) and 6 (target) of the synthetic street (seed 1, forward motion) with their true
// poses and depths, one pyramid level.
struct StreetPair {
  KeyframeData host, target;
  double host_pose[7], target_pose[7];
  StreetPair() {
    SyntheticOptions options;
    options.num_frames = 10;
    options.seed = 1;
    const SyntheticSequence sequence(options);
    host = test::MakeSyntheticKeyframe(sequence, 0, 1);
    target = test::MakeSyntheticKeyframe(sequence, 6, 1);
    PoseToParameters(host.world_from_cam, host_pose);
    PoseToParameters(target.world_from_cam, target_pose);
  }
  // |r|^2 of `cost` (host into target) at inverse depth rho; NaN when the evaluation fails.
  double SquaredResidual(const FeatureMetricCost& cost, double rho) const {
    std::vector<double> r(cost.num_residuals());
    if (!cost.EvaluateTangent(host_pose, target_pose, rho, r.data(), nullptr, nullptr, nullptr)) {
      return std::numeric_limits<double>::quiet_NaN();
    }
    double sq = 0.0;
    for (double v : r) sq += v * v;
    return sq;
  }
};

// On the synthetic street with its true depths and poses, patches on slanted surfaces (3 x 3
// depth spread above 3 %: the road, walls seen at an angle) match their target better when
// warped as the depth map's surface than as a fronto-parallel plane at the centre's depth.
TEST(FeatureMetricCostTest, DepthShapedPatchesMatchSlantedSurfacesBetter) {
  const StreetPair pair;
  const FeatureLevel& host_level = pair.host.features.levels[0];
  const ImageF& depth = pair.host.depth.levels[0];
  double flat_sum = 0.0, shaped_sum = 0.0;
  int n = 0;
  for (int y = 1; y + 1 < depth.height(); y += 2) {
    for (int x = 1; x + 1 < depth.width(); x += 2) {
      float lo = depth(x, y), hi = depth(x, y);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          lo = std::min(lo, depth(x + dx, y + dy));
          hi = std::max(hi, depth(x + dx, y + dy));
        }
      }
      if (!(lo > 0.0f) || !(hi / lo > 1.03f) || hi / lo > 1.3f) continue;
      auto patch =
          std::make_shared<const std::vector<double>>(SampleHostPatch(host_level, x, y, 3));
      auto shape = std::make_shared<std::vector<double>>(9);
      for (int k = 0; k < 9; ++k) (*shape)[k] = depth(x + k % 3 - 1, y + k / 3 - 1) / depth(x, y);
      const Eigen::Vector2d uv(x, y);
      FeatureMetricCost flat(&pair.target.features.levels[0], host_level.camera, uv, 3, patch);
      FeatureMetricCost shaped(&pair.target.features.levels[0], host_level.camera, uv, 3, patch,
                               shape);
      const double rho = 1.0 / depth(x, y);
      if (flat.NumVisible(pair.host_pose, pair.target_pose, rho) < 9) continue;
      flat_sum += pair.SquaredResidual(flat, rho);
      shaped_sum += pair.SquaredResidual(shaped, rho);
      ++n;
    }
  }
  std::printf(
      "[ figures  ] %d slanted patches, frame 0 into 6 at the truth: mean squared residual %.4f "
      "fronto-parallel, %.4f depth-shaped\n",
      n, flat_sum / std::max(n, 1), shaped_sum / std::max(n, 1));
  EXPECT_GT(n, 100);
  EXPECT_LT(shaped_sum, 0.92 * flat_sum);  // measured: 0.86
}

// A view that sees a surface s times larger sees its gradients in pixels 1 / s as steep. On the
// synthetic street with its true depths and poses (forward motion: frame 0 into frame 6), patches
// the target sees zoomed by 1.1 or more match it better with the host patch's gradient channels
// scaled by 1 / s (ZoomScaledPatch, window.zoom_scaled_gradients); the intensity channel is left
// as it is, and features without derivative orders (learned ones) are not touched.
TEST(FeatureMetricCostTest, ZoomScaledGradientsMatchZoomedViewsBetter) {
  const StreetPair pair;
  const FeatureLevel& host_level = pair.host.features.levels[0];
  ASSERT_EQ(host_level.derivative_order, (std::vector<int>{0, 1, 1}));
  const ImageF& depth = pair.host.depth.levels[0];
  double plain_sum = 0.0, scaled_sum = 0.0, zoom_sum = 0.0;
  int n = 0;
  for (int y = 1; y + 1 < depth.height(); y += 2) {
    for (int x = 1; x + 1 < depth.width(); x += 2) {
      if (!(depth(x, y) > 0.0f)) continue;
      const double rho = 1.0 / depth(x, y);
      const Eigen::Vector2d uv(x, y);
      auto patch =
          std::make_shared<const std::vector<double>>(SampleHostPatch(host_level, x, y, 3));
      FeatureMetricCost plain(&pair.target.features.levels[0], host_level.camera, uv, 3, patch);
      if (plain.NumVisible(pair.host_pose, pair.target_pose, rho) < 9) continue;
      const Eigen::Vector2d stretch = plain.WarpStretch(pair.host_pose, pair.target_pose, rho);
      const double zoom = std::sqrt(stretch(0) * stretch(1));
      if (!(zoom >= 1.1) || zoom > 1.5) continue;
      auto scaled_patch = ZoomScaledPatch(*patch, host_level.derivative_order, 3, zoom);
      ASSERT_NE(scaled_patch, nullptr);
      for (int k = 0; k < 9; ++k) {
        EXPECT_EQ((*scaled_patch)[k], (*patch)[k]);  // intensity unchanged
        EXPECT_NEAR((*scaled_patch)[9 + k], (*patch)[9 + k] / zoom, 1e-12);
      }
      FeatureMetricCost scaled(&pair.target.features.levels[0], host_level.camera, uv, 3,
                               scaled_patch);
      plain_sum += pair.SquaredResidual(plain, rho);
      scaled_sum += pair.SquaredResidual(scaled, rho);
      zoom_sum += zoom;
      ++n;
    }
  }
  std::printf(
      "[ figures  ] %d patches seen zoomed (mean %.2f), frame 0 into 6 at the truth: mean squared "
      "residual %.4f with the host's gradients as they are, %.4f scaled by 1 / zoom\n",
      n, zoom_sum / std::max(n, 1), plain_sum / std::max(n, 1), scaled_sum / std::max(n, 1));
  EXPECT_GT(n, 100);
  EXPECT_LT(scaled_sum, 0.92 * plain_sum);  // measured: 0.86
  // Learned features carry no derivative orders: nothing to scale.
  EXPECT_EQ(ZoomScaledPatch(std::vector<double>(27, 1.0), {}, 3, 1.3), nullptr);
  EXPECT_EQ(ZoomScaledPatch(std::vector<double>(27, 1.0), {0, 0, 0}, 3, 1.3), nullptr);
}

TEST(FeatureMetricCostTest, IdenticalViewsGiveZeroResidual) {
  CostFixture fx(20);
  FeatureMetricCost cost(&fx.host, fx.host.camera, fx.uv, 3, fx.patch);
  std::vector<double> r(cost.num_residuals());
  ASSERT_TRUE(cost.EvaluateTangent(fx.host_pose, fx.host_pose, fx.rho, r.data(), nullptr, nullptr,
                                   nullptr));
  for (double v : r) EXPECT_NEAR(v, 0.0, 1e-6);
}

TEST(FeatureMetricCostTest, OutOfViewPixelsAreClampedNotFreeAndNaNFails) {
  CostFixture fx(21);
  // Target turned 90 degrees: nothing of the patch is visible.
  double target[7];
  TurnedAway(fx.host_pose, target);
  FeatureMetricCost cost(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
  EXPECT_EQ(cost.NumVisible(fx.host_pose, target, fx.rho), 0);
  const int n = cost.num_residuals();
  std::vector<double> r(n), jh(n * 6), jt(n * 6), jr(n);
  ASSERT_TRUE(cost.EvaluateTangent(fx.host_pose, target, fx.rho, r.data(), jh.data(), jt.data(),
                                   jr.data()));
  // Not a zero residual (that would reward leaving the view), and no pose derivative along the
  // clamped axis: the 90 degree turn leaves every pixel clamped in x.
  double sq = 0.0;
  for (double v : r) sq += v * v;
  EXPECT_GT(sq, 0.1);
  for (int row = 0; row < n; ++row) {
    // Only d/dy terms can remain; compare with the autodiff twin for the exact values.
    EXPECT_TRUE(std::isfinite(jh[6 * row]));
  }
  auto* twin = new FeatureMetricTwin{&fx.target, fx.host.camera, fx.uv, 3, *fx.patch, {}};
  ceres::AutoDiffCostFunction<FeatureMetricTwin, ceres::DYNAMIC, 7, 7, 1> autodiff(twin, n);
  std::vector<double> r_auto(n), ah(n * 7), at(n * 7), ar(n);
  double* jac[] = {ah.data(), at.data(), ar.data()};
  const double* params[] = {fx.host_pose, target, &fx.rho};
  ASSERT_TRUE(autodiff.Evaluate(params, r_auto.data(), jac));
  for (int i = 0; i < n; ++i) EXPECT_NEAR(r[i], r_auto[i], 1e-9);
  FeatureLevel nan_level = fx.target;
  std::fill(nan_level.data.begin(), nan_level.data.end(), std::nanf(""));
  FeatureMetricCost nan_cost(&nan_level, fx.host.camera, fx.uv, 3, fx.patch);
  EXPECT_FALSE(nan_cost.EvaluateTangent(fx.host_pose, fx.target_pose, fx.rho, r.data(), nullptr,
                                        nullptr, nullptr));
}

// Ambient residuals and Jacobian [J_host J_target J_rho] (N x 15) of a cost at the fixture's
// parameters (any ceres::CostFunction with the blocks 7, 7, 1).
struct Linearization {
  Eigen::VectorXd r;
  RowMajorMatrixXd j;
};

Linearization Linearize(const ceres::CostFunction& cost, const double* host, const double* target,
                        const double* rho) {
  const int n = cost.num_residuals();
  Linearization lin;
  lin.r.resize(n);
  RowMajorMatrixXd jh(n, 7), jt(n, 7);
  Eigen::VectorXd jr(n);
  double* jac[] = {jh.data(), jt.data(), jr.data()};
  const double* params[] = {host, target, rho};
  EXPECT_TRUE(cost.Evaluate(params, lin.r.data(), jac));
  lin.j.resize(n, 15);
  lin.j << jh, jt, jr;
  return lin;
}

// The compression must leave |r|^2, J^T r and J^T J (all the trust-region solver sees) unchanged.
void ExpectSameNormalEquations(const FeatureMetricCost& full, const double* host,
                               const double* target, double rho, const std::string& what) {
  CompressedFeatureMetricCost compressed(&full);
  ASSERT_EQ(compressed.num_residuals(), CompressedFeatureMetricCost::kNumResiduals);
  const Linearization a = Linearize(full, host, target, &rho);
  const Linearization b = Linearize(compressed, host, target, &rho);
  const double cost_scale = std::max(a.r.squaredNorm(), 1e-30);
  EXPECT_NEAR(b.r.squaredNorm(), a.r.squaredNorm(), 1e-12 * cost_scale) << what;
  const Eigen::MatrixXd jtj_a = a.j.transpose() * a.j, jtj_b = b.j.transpose() * b.j;
  const double h_scale = std::max(jtj_a.cwiseAbs().maxCoeff(), 1e-30);
  EXPECT_LT((jtj_b - jtj_a).cwiseAbs().maxCoeff(), 1e-10 * h_scale) << what;
  const Eigen::VectorXd g_a = a.j.transpose() * a.r, g_b = b.j.transpose() * b.r;
  const double g_scale = std::sqrt(h_scale * cost_scale);
  EXPECT_LT((g_b - g_a).cwiseAbs().maxCoeff(), 1e-10 * g_scale) << what;
  // A residual-only evaluation gives the same norm.
  Eigen::VectorXd r_only(CompressedFeatureMetricCost::kNumResiduals);
  const double* params[] = {host, target, &rho};
  ASSERT_TRUE(compressed.Evaluate(params, r_only.data(), nullptr));
  EXPECT_NEAR(r_only.squaredNorm(), a.r.squaredNorm(), 1e-12 * cost_scale) << what;
}

TEST(CompressedFeatureMetricCostTest, SameCostGradientAndGaussNewtonMatrix) {
  for (int seed = 30; seed < 35; ++seed) {
    CostFixture fx(seed);
    FeatureMetricCost cost(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
    ExpectSameNormalEquations(cost, fx.host_pose, fx.target_pose, fx.rho,
                              "seed " + std::to_string(seed));
  }
  // Clamped pixels (target turned away: only d/dy rows remain, rank-deficient) and a flat target
  // (no gradient at all: [A c] = 0, everything in the remainder row).
  CostFixture fx(36);
  double target[7];
  TurnedAway(fx.host_pose, target);
  FeatureMetricCost cost(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
  ExpectSameNormalEquations(cost, fx.host_pose, target, fx.rho, "turned away");
  FeatureLevel flat = fx.target;
  std::fill(flat.data.begin(), flat.data.end(), 0.25f);
  FeatureMetricCost flat_cost(&flat, fx.host.camera, fx.uv, 3, fx.patch);
  ExpectSameNormalEquations(flat_cost, fx.host_pose, fx.target_pose, fx.rho, "flat target");
  // Zero inverse depth (a point at infinity: the depth column is then independent).
  ExpectSameNormalEquations(cost, fx.host_pose, fx.target_pose, 0.0, "rho = 0");
}

// Through Ceres with a robust loss (its Corrector rescales residuals and Jacobians): the gradient
// and the Gauss-Newton matrix of a one-block problem are the same with either cost.
TEST(CompressedFeatureMetricCostTest, SameGradientAndJacobianGramThroughHuberLoss) {
  CostFixture fx(40);
  FeatureMetricCost full(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
  CompressedFeatureMetricCost compressed(&full);
  // A scale below the block's RMS residual so that the loss is in its linear part.
  double r_full[36];
  const double* params[] = {fx.host_pose, fx.target_pose, &fx.rho};
  ASSERT_TRUE(full.Evaluate(params, r_full, nullptr));
  double sq = 0.0;
  for (double v : r_full) sq += v * v;
  ASSERT_GT(sq, 0.0);
  auto evaluate = [&](ceres::CostFunction* cost, double* out_cost, Eigen::VectorXd* gradient,
                      Eigen::MatrixXd* gauss_newton) {
    double host[7], target[7], rho = fx.rho;
    std::copy(fx.host_pose, fx.host_pose + 7, host);
    std::copy(fx.target_pose, fx.target_pose + 7, target);
    ceres::Problem::Options options;
    options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(options);
    SE3Manifold manifold;
    problem.AddParameterBlock(host, 7, &manifold);
    problem.AddParameterBlock(target, 7, &manifold);
    problem.AddResidualBlock(cost, new ceres::HuberLoss(0.3 * std::sqrt(sq)), host, target, &rho);
    std::vector<double> g;
    ceres::CRSMatrix crs;
    ASSERT_TRUE(problem.Evaluate(ceres::Problem::EvaluateOptions(), out_cost, nullptr, &g, &crs));
    *gradient = Eigen::Map<Eigen::VectorXd>(g.data(), static_cast<int>(g.size()));
    Eigen::MatrixXd j = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
    for (int row = 0; row < crs.num_rows; ++row) {
      for (int i = crs.rows[row]; i < crs.rows[row + 1]; ++i) j(row, crs.cols[i]) = crs.values[i];
    }
    *gauss_newton = j.transpose() * j;
  };
  double cost_a = 0.0, cost_b = 0.0;
  Eigen::VectorXd g_a, g_b;
  Eigen::MatrixXd h_a, h_b;
  evaluate(&full, &cost_a, &g_a, &h_a);
  evaluate(&compressed, &cost_b, &g_b, &h_b);
  EXPECT_NEAR(cost_b, cost_a, 1e-12 * cost_a);
  ASSERT_EQ(g_a.size(), 13);  // tangent gradient: 6 + 6 + 1
  EXPECT_LT((g_b - g_a).cwiseAbs().maxCoeff(), 1e-9 * g_a.cwiseAbs().maxCoeff());
  EXPECT_LT((h_b - h_a).cwiseAbs().maxCoeff(), 1e-9 * h_a.cwiseAbs().maxCoeff());
}

// The kept evaluation: at bitwise the same parameters it is reused (same outputs as a fresh cost,
// and |r|^2 for the outlier gate); at any other parameters the cost is evaluated anew.
TEST(CompressedFeatureMetricCostTest, KeptEvaluationServesOnlyTheSameParameters) {
  CostFixture fx(41);
  FeatureMetricCost full(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
  CompressedFeatureMetricCost kept(&full);
  const int n = CompressedFeatureMetricCost::kNumResiduals;
  auto evaluate = [n](const CompressedFeatureMetricCost& cost, const double* host,
                      const double* target, double rho) {
    std::vector<double> out(static_cast<size_t>(n) * 16);  // residuals, 7 + 7 + 1 columns
    double* jac[] = {out.data() + n, out.data() + 8 * n, out.data() + 15 * n};
    const double* params[] = {host, target, &rho};
    EXPECT_TRUE(cost.Evaluate(params, out.data(), jac));
    return out;
  };
  double sq = -1.0;
  EXPECT_FALSE(kept.CachedSquaredNorm(fx.host_pose, fx.target_pose, fx.rho, &sq));
  // A residual-only evaluation keeps nothing.
  std::vector<double> r_only(n);
  const double* params[] = {fx.host_pose, fx.target_pose, &fx.rho};
  ASSERT_TRUE(kept.Evaluate(params, r_only.data(), nullptr));
  EXPECT_FALSE(kept.CachedSquaredNorm(fx.host_pose, fx.target_pose, fx.rho, &sq));

  const std::vector<double> first = evaluate(kept, fx.host_pose, fx.target_pose, fx.rho);
  std::vector<double> r_full(full.num_residuals());
  ASSERT_TRUE(full.Evaluate(params, r_full.data(), nullptr));
  double full_sq = 0.0;
  for (double v : r_full) full_sq += v * v;
  ASSERT_TRUE(kept.CachedSquaredNorm(fx.host_pose, fx.target_pose, fx.rho, &sq));
  EXPECT_EQ(sq, full_sq);
  EXPECT_EQ(evaluate(kept, fx.host_pose, fx.target_pose, fx.rho), first);

  // Moved parameters: not served from the kept evaluation, and equal to a fresh cost's.
  double moved[7];
  std::copy(fx.target_pose, fx.target_pose + 7, moved);
  moved[4] += 0.01;
  EXPECT_FALSE(kept.CachedSquaredNorm(fx.host_pose, moved, fx.rho, &sq));
  const std::vector<double> second = evaluate(kept, fx.host_pose, moved, fx.rho);
  CompressedFeatureMetricCost fresh(&full);
  EXPECT_EQ(second, evaluate(fresh, fx.host_pose, moved, fx.rho));
  EXPECT_NE(second, first);
  EXPECT_FALSE(kept.CachedSquaredNorm(fx.host_pose, fx.target_pose, fx.rho, &sq));
  EXPECT_FALSE(kept.CachedSquaredNorm(fx.host_pose, moved, fx.rho + 1e-12, &sq));
}

// Prefetch evaluates as Evaluate would: afterwards Evaluate (with or without Jacobians) gives
// bitwise a fresh cost's outputs. A residual-only prefetch keeps only |r|^2, apart from the
// Jacobian evaluation that the outlier gate reads.
TEST(CompressedFeatureMetricCostTest, PrefetchGivesTheSameEvaluations) {
  CostFixture fx(43);
  FeatureMetricCost full(&fx.target, fx.host.camera, fx.uv, 3, fx.patch);
  const int n = CompressedFeatureMetricCost::kNumResiduals;
  const auto evaluate = [n](const CompressedFeatureMetricCost& cost, const double* host,
                            const double* target, double rho, bool jacobians) {
    std::vector<double> out(static_cast<size_t>(n) * 16, 0.0);
    double* jac[] = {out.data() + n, out.data() + 8 * n, out.data() + 15 * n};
    const double* params[] = {host, target, &rho};
    EXPECT_TRUE(cost.Evaluate(params, out.data(), jacobians ? jac : nullptr));
    return out;
  };
  double moved[7];
  std::copy(fx.target_pose, fx.target_pose + 7, moved);
  moved[5] += 0.02;

  CompressedFeatureMetricCost prefetched(&full);
  double sq = -1.0;
  prefetched.Prefetch(fx.host_pose, moved, fx.rho, /*with_jacobians=*/false);
  EXPECT_FALSE(prefetched.CachedSquaredNorm(fx.host_pose, moved, fx.rho, &sq));
  EXPECT_EQ(evaluate(prefetched, fx.host_pose, moved, fx.rho, false),
            evaluate(CompressedFeatureMetricCost(&full), fx.host_pose, moved, fx.rho, false));

  prefetched.Prefetch(fx.host_pose, fx.target_pose, fx.rho, /*with_jacobians=*/true);
  ASSERT_TRUE(prefetched.CachedSquaredNorm(fx.host_pose, fx.target_pose, fx.rho, &sq));
  // A residual-only prefetch elsewhere leaves the kept Jacobian evaluation alone.
  prefetched.Prefetch(fx.host_pose, moved, fx.rho, /*with_jacobians=*/false);
  EXPECT_TRUE(prefetched.CachedSquaredNorm(fx.host_pose, fx.target_pose, fx.rho, &sq));
  for (const bool jacobians : {false, true}) {
    for (const double* target : std::vector<const double*>{fx.target_pose, moved}) {
      EXPECT_EQ(
          evaluate(prefetched, fx.host_pose, target, fx.rho, jacobians),
          evaluate(CompressedFeatureMetricCost(&full), fx.host_pose, target, fx.rho, jacobians))
          << "jacobians " << jacobians;
    }
  }
}

}  // namespace
}  // namespace dfo
