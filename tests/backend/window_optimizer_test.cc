// WindowOptimizer on the synthetic sequence: perturbed poses and depths return to ground truth,
// the window stays bounded over a long run, marginalisation on/off, a failing solve keeps the
// state, NaN depth is harmless, bad input and options are rejected with their names.
#include "dfo_backend/window_optimizer.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <set>

#include "dfo_backend/marginalization.h"
#include "tests/backend/synthetic_keyframes.h"

namespace dfo {
namespace {

const SyntheticSequence& Sequence() {
  static const SyntheticSequence* sequence = [] {
    SyntheticOptions options;
    options.num_frames = 80;
    options.seed = 1;
    return new SyntheticSequence(options);
  }();
  return *sequence;
}

SE3d Perturb(const SE3d& pose, double trans_m, double rot_rad, std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Vector6d xi;
  for (int i = 0; i < 3; ++i) xi(i) = trans_m * n(*rng);
  for (int i = 3; i < 6; ++i) xi(i) = rot_rad * n(*rng);
  return pose * SE3d::Exp(xi);
}

struct PoseErrors {
  double max_trans_m = 0.0;
  double max_rot_deg = 0.0;
};

// Errors after the one gauge freedom a fixed first keyframe leaves in monocular BA, the scale:
// camera centres are scaled about the first keyframe's (at ground truth) by the least-squares
// factor, returned in *scale.
PoseErrors Errors(const std::vector<std::pair<int, SE3d>>& poses, double* scale = nullptr,
                  const SyntheticSequence& sequence = Sequence()) {
  const Eigen::Vector3d origin = poses.front().second.translation();
  double num = 0.0, den = 0.0;
  for (const auto& [index, pose] : poses) {
    const Eigen::Vector3d est = pose.translation() - origin;
    const Eigen::Vector3d gt = sequence.WorldFromCam(index).translation() - origin;
    num += gt.dot(est);
    den += est.squaredNorm();
  }
  const double s = den > 0.0 ? num / den : 1.0;
  if (scale) *scale = s;
  PoseErrors e;
  for (const auto& [index, pose] : poses) {
    SE3d scaled = pose;
    scaled.translation() = origin + s * (pose.translation() - origin);
    const SE3d err = sequence.WorldFromCam(index).Inverse() * scaled;
    e.max_trans_m = std::max(e.max_trans_m, err.translation().norm());
    e.max_rot_deg = std::max(e.max_rot_deg, err.so3().Angle() * 180.0 / M_PI);
  }
  return e;
}

WindowOptions TestOptions() {
  WindowOptions options;
  options.num_threads = 1;  // deterministic
  options.max_iterations = 30;
  options.max_solver_time_s = 60.0;
  // Windows started far from the truth (the basin test below) need a longer warm-up than the
  // few coarse iterations per keyframe a run needs.
  options.coarse_iterations = 10;
  // The depth search trusts the keyframes' poses as handed in (in a run: tracked, about 1 cm
  // off); with every pose perturbed by decimetres, as the basin tests below do, it moves points
  // to wrong depths (measured: 0.22 m after instead of < 0.03 m). These tests are about the
  // solve; DepthSearchCorrectsAWrongSourceDepthByParallax tests the search.
  options.depth_search_range = 1.0;
  // Most keyframes here carry 5 % per-pixel depth noise, which the depth-edge rule reads as
  // edges nearly everywhere (DepthEdgeRuleKeepsPointsOffDepthEdges): with it the basin test's
  // window, left with few points, moved from 0.025 m off to 0.16 m off. The rule is for smooth
  // (network) or exact depth maps.
  options.max_depth_edge_slope = 0.0;
  return options;
}

// TestOptions for a window of 5 keyframes with a depth prior.
WindowOptions DepthPriorWindowOptions(int points_per_keyframe, int max_iterations,
                                      double depth_prior_weight) {
  WindowOptions options = TestOptions();
  options.max_keyframes = 5;
  options.points_per_keyframe = points_per_keyframe;
  options.max_iterations = max_iterations;
  options.depth_prior_weight = depth_prior_weight;
  return options;
}

// The gauge of a marginalisation prior at its linearisation point, in its tangent coordinates
// (left perturbations of world_from_cam): a common [upsilon; omega] for all poses (6 columns)
// and the scale, upsilon_i = t_i (7th), as the window projects them out.
Eigen::MatrixXd GaugeNullspace(const LinearPriorCost& prior) {
  const LinearPrior& lp = prior.prior();
  Eigen::MatrixXd nullspace = Eigen::MatrixXd::Zero(lp.jacobian.cols(), 7);
  for (size_t b = 0; b < lp.variables.size(); ++b) {
    const std::vector<double>& x0 = prior.x0()[b];
    nullspace.block<6, 6>(lp.offsets[b], 0).setIdentity();
    nullspace.block<3, 1>(lp.offsets[b], 6) = Eigen::Vector3d(x0[4], x0[5], x0[6]);
  }
  return nullspace;
}

// Four keyframes (frames 0-9) with 5% log-normal depth noise and every pose but the gauge
// keyframe's perturbed by `scale` x (5 cm, 0.01 rad) per axis; returns the errors before and after
// (after the scale, a gauge freedom without a depth prior) and the scale after.
struct BasinResult {
  PoseErrors before, after;
  double scale_after = 0.0;
};
BasinResult RunBasin(const WindowOptions& options, double scale) {
  WindowOptimizer window(options);
  std::mt19937 rng(1);
  std::vector<std::pair<int, SE3d>> perturbed;
  WindowResult result;
  for (int index = 0; index <= 9; index += 3) {
    KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), index, 2, 0.05);
    if (index > 0) {
      kf.world_from_cam = Perturb(kf.world_from_cam, scale * 0.05, scale * 0.01, &rng);
    }
    perturbed.emplace_back(index, kf.world_from_cam);
    result = window.AddKeyframe(std::move(kf));
    if (index > 0) {
      EXPECT_TRUE(result.optimized) << result.message;
      EXPECT_LE(result.final_cost, result.initial_cost);
    }
  }
  EXPECT_EQ(result.keyframe_poses.size(), 4u);
  BasinResult out;
  double scale_before = 0.0;
  out.before = Errors(perturbed, &scale_before);
  out.after = Errors(result.keyframe_poses, &out.scale_after);
  return out;
}

// Bounds: ground-truth-initialised windows of this sequence (5% depth noise) end within ~1 cm
// and ~0.04 deg (the feature-metric optimum is not exactly the rendering's pose: interpolation
// at edges, silhouettes); the scale is a gauge freedom without a depth prior, so the part of
// the perturbation along it stays (measured: up to ~1%) and is aligned away.
void ExpectReturned(const BasinResult& r) {
  EXPECT_LT(r.after.max_rot_deg, 0.1) << "before " << r.before.max_rot_deg;
  EXPECT_LT(r.after.max_trans_m, 0.03) << "before " << r.before.max_trans_m;
  EXPECT_LT(r.after.max_trans_m, 0.5 * r.before.max_trans_m);
  EXPECT_NEAR(r.scale_after, 1.0, 0.03);
}

// Without the scale gate (max_patch_stretch open) the window returns from ~1.5 deg and 10 cm.
TEST(WindowOptimizerTest, PerturbedPosesAndDepthsReturnToGroundTruth) {
  WindowOptions options = TestOptions();
  options.max_patch_stretch = 1e9;
  const BasinResult r = RunBasin(options, 1.0);
  EXPECT_GT(r.before.max_rot_deg, 0.5);
  ExpectReturned(r);
}

// A step says how many iterations its solves took and whether they converged: from perturbed
// poses one iteration is cut off by window.max_iterations, 50 end by Ceres's tolerances.
// The step that adds frame 3, perturbed by 5 cm and 0.01 rad, to a window holding frame 0.
WindowResult SolvePerturbedPair(const WindowOptions& options) {
  WindowOptimizer window(options);
  std::mt19937 rng(1);
  WindowResult result;
  for (int index = 0; index <= 3; index += 3) {
    KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), index, 2, 0.05);
    if (index > 0) kf.world_from_cam = Perturb(kf.world_from_cam, 0.05, 0.01, &rng);
    result = window.AddKeyframe(std::move(kf));
  }
  return result;
}

TEST(WindowOptimizerTest, StepsReportIterationsAndConvergence) {
  for (const int max_iterations : {1, 50}) {
    WindowOptions options = TestOptions();
    options.max_iterations = max_iterations;
    const WindowResult result = SolvePerturbedPair(options);
    ASSERT_TRUE(result.optimized) << result.message;
    if (max_iterations == 1) {
      EXPECT_FALSE(result.converged);
      EXPECT_GE(result.num_iterations, 1);
      EXPECT_LE(result.num_iterations, 2);  // the second solve after the gate: 1 more at most
    } else {
      EXPECT_TRUE(result.converged) << result.num_iterations << " iterations";
      EXPECT_GT(result.num_iterations, 1);
      EXPECT_LT(result.num_iterations, 2 * max_iterations);
    }
  }
}

// A solve the wall-time limit ends is told apart from one that reached its iteration cap: its
// result depends on the machine (frames.csv keyframe_solve "time_limit").
TEST(WindowOptimizerTest, StepsSayWhenTheTimeLimitEndedTheSolve) {
  for (const bool tiny_limit : {false, true}) {
    WindowOptions options = TestOptions();
    options.max_iterations = tiny_limit ? 1000 : 1;
    options.max_solver_time_s = tiny_limit ? 1e-9 : 1000.0;
    const WindowResult result = SolvePerturbedPair(options);
    ASSERT_TRUE(result.optimized) << result.message;
    EXPECT_FALSE(result.converged);
    EXPECT_EQ(result.time_limited, tiny_limit) << result.num_iterations << " iterations";
    if (tiny_limit) {
      EXPECT_LT(result.num_iterations, 1000);
    }
  }
}

// window.stop_step_px ends a solve once its steps move the keyframes by less than the threshold
// in the image: from the same perturbed poses it reports convergence after fewer iterations than
// a solve left to Ceres's tolerances (which here runs into the 50-iteration cap, creeping along
// a flat valley), and its poses are as close to the truth (measured: 21 against 75 iterations,
// 0.231 against 0.237 m).
TEST(WindowOptimizerTest, SmallStepRuleEndsSolvesWhereTheToleranceWould) {
  std::vector<WindowResult> results;
  for (const double stop_step_px : {0.0, 0.05}) {
    WindowOptions options = TestOptions();
    options.max_iterations = 50;
    options.stop_step_px = stop_step_px;
    WindowOptimizer window(options);
    std::mt19937 rng(1);
    for (int index = 0; index <= 6; index += 3) {
      KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), index, 2, 0.05);
      if (index > 0) kf.world_from_cam = Perturb(kf.world_from_cam, 0.05, 0.01, &rng);
      results.push_back(window.AddKeyframe(std::move(kf)));
    }
    ASSERT_TRUE(results.back().optimized) << results.back().message;
  }
  const WindowResult& tolerance = results[2];
  const WindowResult& small_step = results[5];
  ASSERT_EQ(small_step.keyframe_poses.size(), tolerance.keyframe_poses.size());
  const PoseErrors e_tolerance = Errors(tolerance.keyframe_poses);
  const PoseErrors e_small_step = Errors(small_step.keyframe_poses);
  std::cout << "iterations " << small_step.num_iterations << " against " << tolerance.num_iterations
            << "; error " << e_small_step.max_trans_m << " m " << e_small_step.max_rot_deg
            << " deg against " << e_tolerance.max_trans_m << " m " << e_tolerance.max_rot_deg
            << " deg\n";
  EXPECT_TRUE(small_step.converged);
  EXPECT_LT(small_step.num_iterations, tolerance.num_iterations);
  EXPECT_GT(small_step.last_step_px, 0.0);
  EXPECT_LT(small_step.last_step_px, 0.05);
  EXPECT_LT(e_small_step.max_trans_m, 1.1 * e_tolerance.max_trans_m);
  EXPECT_LT(e_small_step.max_rot_deg, 1.1 * e_tolerance.max_rot_deg);
}

// The default scale gate (max_patch_stretch 1.5) leaves out the near points' long links, the
// strongest parallax, so its basin is narrower: measured, it returns from 0.75 x the
// perturbation above and not from 1 x (0.92 deg, 0.27 m after). Half of it must work.
TEST(WindowOptimizerTest, PerturbedPosesReturnWithTheDefaultScaleGate) {
  const WindowOptions options = TestOptions();
  ASSERT_EQ(options.max_patch_stretch, WindowOptions().max_patch_stretch);
  const BasinResult r = RunBasin(options, 0.5);
  EXPECT_GT(r.before.max_rot_deg, 0.3);
  ExpectReturned(r);
}

// A full window started at ground truth must stay there while it slides through a turn between
// facades with repetitive window grids (frames 90-180 of seed 1, keyframes 2.7-3.6 m apart, every
// keyframe handed in at its true pose, exact depth): the solves may only move it by the feature-
// metric optimum's own offset, never drift or collapse. Measured (after the scale, a free gauge
// without a depth prior): BA at level 0 with a 10-iteration coarse warm-up of the newest keyframe
// (TestOptions) ends within 0.25 m / 0.46 deg, scale off by 1%; without the warm-up 0.11 m /
// 0.43 deg but the scale off by 9%; BA at level 1 drifted to 10.6 m / 2.3 deg (scale off by 30%),
// and a warm-up that moved the whole window at level 1 to 13.9 m.
TEST(WindowOptimizerTest, GroundTruthWindowStaysThroughATurn) {
  SyntheticOptions sequence_options;
  sequence_options.num_frames = 181;
  sequence_options.seed = 1;
  const SyntheticSequence sequence(sequence_options);
  WindowOptions options = TestOptions();
  options.max_iterations = 10;
  WindowOptimizer window(options);
  double worst_trans = 0.0, worst_rot = 0.0, worst_scale = 0.0;
  for (int index = 90; index <= 180; index += 3) {
    const WindowResult result =
        window.AddKeyframe(test::MakeSyntheticKeyframe(sequence, index, options.pyramid_level + 2));
    if (result.keyframe_poses.size() < 2) continue;
    ASSERT_TRUE(result.optimized) << "keyframe " << index << ": " << result.message;
    double scale = 1.0;
    const PoseErrors e = Errors(result.keyframe_poses, &scale, sequence);
    worst_trans = std::max(worst_trans, e.max_trans_m);
    worst_rot = std::max(worst_rot, e.max_rot_deg);
    worst_scale = std::max(worst_scale, std::abs(scale - 1.0));
  }
  EXPECT_LT(worst_trans, 0.4);
  EXPECT_LT(worst_rot, 0.8);
  EXPECT_LT(worst_scale, 0.15);
  std::printf("worst window: %.4f m, %.4f deg, scale off by %.4f\n", worst_trans, worst_rot,
              worst_scale);
}

TEST(WindowOptimizerTest, WindowStaysBoundedOverALongRunAndMarginalizes) {
  WindowOptions options = TestOptions();
  options.max_keyframes = 5;
  options.points_per_keyframe = 80;
  options.max_iterations = 4;
  WindowOptimizer window(options);
  int max_points = 0, max_blocks = 0, marginalized = 0;
  std::vector<int> points_late, blocks_late;
  const int num_keyframes = 24;
  for (int k = 0; k < num_keyframes; ++k) {
    const WindowResult result =
        window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 3 * k, 2));
    EXPECT_LE(window.num_keyframes(), options.max_keyframes);
    EXPECT_EQ(static_cast<int>(result.keyframe_poses.size()), window.num_keyframes());
    EXPECT_EQ(result.num_points, window.num_points());
    EXPECT_EQ(result.num_residual_blocks, window.num_residual_blocks());
    // Bounds by construction: points per keyframe, one block per (point, other keyframe).
    EXPECT_LE(window.num_points(), options.max_keyframes * options.points_per_keyframe);
    EXPECT_LE(window.num_residual_blocks(), window.num_points() * (options.max_keyframes - 1));
    if (result.marginalized_frame_index >= 0) {
      ++marginalized;
      // The leaving keyframe is never one of the newest two.
      EXPECT_LT(result.marginalized_frame_index, 3 * (k - 1));
      EXPECT_NE(window.prior(), nullptr) << result.message;
      EXPECT_TRUE(result.marginalized_into_prior);
    }
    max_points = std::max(max_points, result.num_points);
    max_blocks = std::max(max_blocks, result.num_residual_blocks);
    if (k >= num_keyframes / 2) {
      points_late.push_back(result.num_points);
      blocks_late.push_back(result.num_residual_blocks);
    }
  }
  EXPECT_EQ(marginalized, num_keyframes - options.max_keyframes);
  // No growth with sequence length: the second half stays within the bound reached once the
  // window was full.
  EXPECT_LE(*std::max_element(points_late.begin(), points_late.end()),
            options.max_keyframes * options.points_per_keyframe);
  EXPECT_GT(*std::min_element(points_late.begin(), points_late.end()), 0);
  // The prior lives on window keyframes only.
  ASSERT_NE(window.prior(), nullptr);
  const std::vector<int> prior_frames = window.PriorFrameIndices();
  EXPECT_FALSE(prior_frames.empty());
  for (int f : prior_frames) {
    bool in_window = false;
    for (const auto& kp : window.KeyframePoses()) in_window = in_window || kp.first == f;
    EXPECT_TRUE(in_window) << f;
  }
  EXPECT_GT(window.prior()->prior().rank(), 0);
  // The prior carries no information along the gauge of its linearisation point (a common left
  // motion of all its poses, and the scale): 7 directions projected out.
  const LinearPrior& lp = window.prior()->prior();
  const int n = static_cast<int>(lp.jacobian.cols());
  EXPECT_LE(lp.rank(), n - 7);
  const Eigen::MatrixXd nullspace = GaugeNullspace(*window.prior());
  EXPECT_LT((lp.jacobian * nullspace).norm(), 1e-8 * lp.jacobian.norm() * nullspace.norm());
}

// What a keyframe's points settled on (WindowResult::marginalized_points when it leaves): pixels
// at level 0 that land on the BA level's pixel grid, one observation at least, finite residuals,
// and depths closer to the truth than the 20 % per-pixel noise the keyframes' depth maps carry
// (the window at the true poses, BA on pyramid level 1; measured: median |log error| 0.024
// against 0.066 at the start).
TEST(WindowOptimizerTest, SettledPointsOfALeavingKeyframeAreCloserToTheTruthThanTheirStart) {
  WindowOptions options = TestOptions();
  options.pyramid_level = 1;
  options.coarse_iterations = 0;
  options.max_keyframes = 5;
  options.points_per_keyframe = 80;
  options.max_iterations = 10;
  WindowOptimizer window(options);
  std::vector<double> settled_error, start_error;
  int left = 0;
  for (int k = 0; k < 9; ++k) {
    const int index = 3 * k;
    const WindowResult result =
        window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), index, 2, 0.20));
    ASSERT_TRUE(k == 0 || result.optimized) << result.message;
    if (k == 4) {
      // Hosted points of a keyframe in the window: at BA level 1, pixel (x, y) is
      // (2 x + 0.5, 2 y + 0.5) at level 0.
      const std::vector<SettledPoint> hosted = window.HostedPoints(index);
      std::set<std::pair<int, int>> pixels;
      for (const WindowOptimizer::PointInfo& p : window.Points()) {
        if (p.host_frame == index) pixels.insert({p.x, p.y});
      }
      ASSERT_FALSE(hosted.empty());
      for (const SettledPoint& p : hosted) {
        const double x = (p.u + 0.5) / 2.0 - 0.5, y = (p.v + 0.5) / 2.0 - 0.5;
        EXPECT_EQ(pixels.count({static_cast<int>(x), static_cast<int>(y)}), 1u) << x << " " << y;
        EXPECT_EQ(x, std::floor(x));
      }
      EXPECT_TRUE(window.HostedPoints(1000).empty());
    }
    if (result.marginalized_frame_index < 0) continue;
    ++left;
    EXPECT_FALSE(result.marginalized_points.empty());
    const KeyframeData truth =
        test::MakeSyntheticKeyframe(Sequence(), result.marginalized_frame_index, 2, 0.0);
    const ImageF& depth = truth.depth.levels[1];
    for (const SettledPoint& p : result.marginalized_points) {
      EXPECT_GE(p.observations, 1);
      EXPECT_TRUE(std::isfinite(p.rms_residual) && p.rms_residual >= 0.0);
      const int x = static_cast<int>((p.u + 0.5) / 2.0 - 0.5);
      const int y = static_cast<int>((p.v + 0.5) / 2.0 - 0.5);
      const double d = depth(x, y);
      settled_error.push_back(std::abs(std::log(p.depth_m / d)));
      start_error.push_back(std::abs(std::log(p.start_depth_m / d)));
    }
  }
  EXPECT_EQ(left, 4);
  ASSERT_GT(settled_error.size(), 100u);
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double settled = median(settled_error), start = median(start_error);
  std::cout << "median |log depth error|: settled " << settled << ", start " << start << " ("
            << settled_error.size() << " points)\n";
  EXPECT_GT(start, 0.04);  // the noise is there
  EXPECT_LT(settled, 0.7 * start);
}

// With a depth prior the scale is observable: backend.prior_scale_memory 1 keeps the leaving
// points' information about it in the marginalisation prior, 0 removes it with the gauge; the
// six directions of a common motion are removed either way.
TEST(WindowOptimizerTest, PriorScaleMemoryKeepsTheScaleInformationOfADepthPrior) {
  double scale_information[2] = {0.0, 0.0};
  int rank[2] = {0, 0};
  for (int keep = 0; keep < 2; ++keep) {
    WindowOptions options = DepthPriorWindowOptions(60, 3, 1.0);
    options.prior_scale_memory = keep;
    // The scale information is about 1e-10 of the prior's largest eigenvalue here (numerical
    // noise: about 1e-16 of it); the default floor, 1e-8, would drop it.
    options.relative_eigenvalue_floor = 1e-13;
    WindowOptimizer window(options);
    for (int k = 0; k < 8; ++k) {
      window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 3 * k, 2));
    }
    ASSERT_NE(window.prior(), nullptr);
    const LinearPrior& lp = window.prior()->prior();
    const int n = static_cast<int>(lp.jacobian.cols());
    const Eigen::MatrixXd q = GaugeNullspace(*window.prior()).householderQr().householderQ() *
                              Eigen::MatrixXd::Identity(n, 7);
    EXPECT_LT((lp.jacobian * q.leftCols(6)).norm(), 1e-8 * lp.jacobian.norm()) << "keep " << keep;
    // Information along the scale direction relative to the prior's largest.
    const Eigen::MatrixXd h = lp.jacobian.transpose() * lp.jacobian;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(h);
    scale_information[keep] = q.col(6).dot(h * q.col(6)) / eig.eigenvalues().maxCoeff();
    rank[keep] = lp.rank();
  }
  std::printf("[ figures  ] scale information of the prior / its largest: memory 0 %.2e, 1 %.2e\n",
              scale_information[0], scale_information[1]);
  EXPECT_LT(std::abs(scale_information[0]), 1e-15);
  EXPECT_GT(scale_information[1], 1e-11);
  EXPECT_EQ(rank[1], rank[0] + 1);
}

// A monocular network gives each image its own scale. With the whole depth prior on each
// keyframe's scale (window.depth_prior_scale_fraction 1) the keyframes' steps follow their depth
// maps' scales; with a small fraction each keyframe's prior depths share a free scale, the prior
// keeps their shape, and the parallax between keyframes sets the scale.
TEST(WindowOptimizerTest, DepthPriorScaleFractionLetsTheGeometrySetEachKeyframesScale) {
  double spread[2] = {0.0, 0.0};
  const double fractions[2] = {1.0, 0.02};
  for (int run = 0; run < 2; ++run) {
    WindowOptions options = DepthPriorWindowOptions(80, 4, 2.0);
    options.coarse_iterations = 0;
    options.depth_prior_scale_fraction = fractions[run];
    // The keyframes' poses are the truth here, so the depth search can be trusted (TestOptions
    // turns it off for the perturbed windows of the basin tests).
    options.depth_search_range = 2.0;
    WindowOptimizer window(options);
    std::vector<std::pair<int, SE3d>> poses;  // each keyframe's pose when it was newest but one
    for (int k = 0; k < 9; ++k) {
      KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), 3 * k, 2);
      // Depth maps alternately 20 % too near and 25 % too far (the first keeps the truth).
      const float factor = k == 0 ? 1.0f : (k % 2 ? 0.8f : 1.25f);
      for (ImageF& level : kf.depth.levels) {
        for (float& d : level.vector()) d *= factor;
      }
      const WindowResult r = window.AddKeyframe(std::move(kf));
      ASSERT_TRUE(k == 0 || r.optimized) << r.message;
      if (k >= 2) poses.push_back(r.keyframe_poses[r.keyframe_poses.size() - 2]);
    }
    // Spread of the step lengths over the truth's.
    std::vector<double> ratios;
    for (size_t i = 1; i < poses.size(); ++i) {
      const double est = (poses[i].second.translation() - poses[i - 1].second.translation()).norm();
      const double gt = (Sequence().WorldFromCam(poses[i].first).translation() -
                         Sequence().WorldFromCam(poses[i - 1].first).translation())
                            .norm();
      ratios.push_back(est / gt);
    }
    double mean = 0.0, sq = 0.0;
    for (double r : ratios) mean += r / ratios.size();
    for (double r : ratios) sq += (r - mean) * (r - mean) / ratios.size();
    spread[run] = std::sqrt(sq) / mean;
  }
  std::printf(
      "[ figures  ] per-keyframe depth scales 0.8 / 1.25: step-length ratio cv %.3f with the "
      "prior's fraction on the scale 1, %.3f with 0.02\n",
      spread[0], spread[1]);
  EXPECT_GT(spread[0], 0.05);
  EXPECT_LT(spread[1], 0.5 * spread[0]);
}

// KeyframeData::prior_depth_scale centres the depth prior: keyframes whose depth maps are all half
// the truth, their points started at the map, with a strong prior. With the prior at the map the
// points stay near half their true depth; with it at twice the map the window's depths (and its
// scale) move to the truth.
TEST(WindowOptimizerTest, PriorDepthScaleCentresTheDepthPrior) {
  // Signed median log(depth / true depth) over the window's points.
  const auto bias = [](const WindowOptimizer& window) {
    std::vector<double> logs;
    for (const WindowOptimizer::PointInfo& p : window.Points()) {
      const SyntheticFrame truth = Sequence().RenderFrame(p.host_frame);
      if (!(truth.depth(p.x, p.y) > 0.0f)) continue;
      logs.push_back(std::log(1.0 / (p.inverse_depth * truth.depth(p.x, p.y))));
    }
    std::nth_element(logs.begin(), logs.begin() + logs.size() / 2, logs.end());
    return logs[logs.size() / 2];
  };
  double result[2];
  for (int run = 0; run < 2; ++run) {
    WindowOptions options = DepthPriorWindowOptions(60, 10, 50.0);
    options.coarse_iterations = 0;
    WindowOptimizer window(options);
    for (int frame : {0, 3, 6, 9}) {
      KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), frame, 2);
      for (ImageF& level : kf.depth.levels) {
        for (float& d : level.vector()) d *= 0.5f;
      }
      kf.prior_depth_scale = run == 0 ? 1.0 : 2.0;
      const WindowResult r = window.AddKeyframe(std::move(kf));
      ASSERT_TRUE(frame == 0 || r.optimized) << r.message;
    }
    result[run] = bias(window);
  }
  std::printf(
      "[ figures  ] depth maps at half the truth, points started there: median log(depth / "
      "truth) %.3f with the prior at the map, %.3f with it at twice the map\n",
      result[0], result[1]);
  EXPECT_LT(result[0], std::log(0.6));
  EXPECT_NEAR(result[1], 0.0, 0.1);
}

// Features with a blur fixed in pixels disagree where a patch is seen zoomed (forward motion),
// and the window's optimum moves away from the truth; comparing the zoomed side's features
// blurred by the zoom (window.zoom_blur_sigma_px) keeps a window started at the truth closer to
// it. The keyframes' features are blurred by 1 px here, as the hand-made ones are.
TEST(WindowOptimizerTest, ZoomMatchedBlurKeepsTheOptimumCloserToTheTruth) {
  double median_error[2] = {0.0, 0.0};
  for (int run = 0; run < 2; ++run) {
    WindowOptions options = TestOptions();
    options.coarse_iterations = 0;
    options.max_iterations = 5;
    options.zoom_blur_sigma_px = run ? 1.0 : 0.0;
    WindowOptimizer window(options);
    std::vector<double> errors;
    for (int k = 0; k < 12; ++k) {
      KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), 3 * k, 2);
      for (FeatureLevel& level : kf.features.levels) level = GaussianBlur(level, 1.0);
      const WindowResult r = window.AddKeyframe(std::move(kf));
      ASSERT_TRUE(k == 0 || r.optimized) << r.message;
      if (k >= 4) errors.push_back(Errors(r.keyframe_poses).max_trans_m);
    }
    std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
    median_error[run] = errors[errors.size() / 2];
  }
  std::printf(
      "[ figures  ] window started at the truth, 1 px feature blur: median largest keyframe "
      "error %.4f m without the zoom-matched blur, %.4f m with it\n",
      median_error[0], median_error[1]);
  EXPECT_LT(median_error[1], 0.85 * median_error[0]);  // measured: 0.75
}

TEST(WindowOptimizerTest, MarginalizationOffOnlyDrops) {
  WindowOptions options = TestOptions();
  options.max_keyframes = 5;
  options.points_per_keyframe = 60;
  options.max_iterations = 3;
  options.marginalization = false;
  WindowOptimizer window(options);
  int dropped = 0;
  for (int k = 0; k < 7; ++k) {
    const WindowResult r = window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 3 * k, 2));
    if (r.marginalized_frame_index >= 0) {
      EXPECT_FALSE(r.marginalized_into_prior);
      ++dropped;
    }
  }
  EXPECT_EQ(dropped, 2);
  EXPECT_EQ(window.num_keyframes(), 5);
  EXPECT_EQ(window.prior(), nullptr);
}

// The scale gate: a block exists only where the target sees its patch at a similar scale. With
// forward motion a tight gate leaves fewer blocks than an open one, and every block it keeps
// has a stretch inside the bound; the open gate keeps blocks outside it (so the test can fail).
TEST(WindowOptimizerTest, BlocksOnlyWhereThePatchKeepsItsScale) {
  auto blocks_after = [](double max_stretch) {
    WindowOptions options = TestOptions();
    options.coarse_iterations = 0;
    options.max_keyframes = 5;
    options.points_per_keyframe = 80;
    options.max_iterations = 2;
    options.max_patch_stretch = max_stretch;
    WindowOptimizer window(options);
    for (int k = 0; k < 5; ++k) {
      window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 3 * k, 2));
    }
    return window.num_residual_blocks();
  };
  const int open = blocks_after(1e9);
  const int tight = blocks_after(1.2);
  EXPECT_GT(tight, 0);
  EXPECT_LT(tight, open);
}

// A keyframe with NaN features (every block into it would be NaN and poison the window) is
// refused on insertion: the window keeps its keyframes and poses, the message names the frame,
// and the next good keyframe is optimised as usual.
TEST(WindowOptimizerTest, KeyframeWithNonFiniteFeaturesIsRejectedAndSaysWhy) {
  WindowOptimizer window(TestOptions());
  window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 0, 2));
  window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 3, 2));
  const auto before = window.KeyframePoses();
  const int points_before = window.num_points();
  KeyframeData bad = test::MakeSyntheticKeyframe(Sequence(), 6, 2);
  bad.features.levels[TestOptions().pyramid_level].data[7] =
      std::numeric_limits<float>::quiet_NaN();
  const WindowResult result = window.AddKeyframe(std::move(bad));
  EXPECT_FALSE(result.optimized);
  EXPECT_NE(result.message.find("keyframe 6 rejected"), std::string::npos) << result.message;
  EXPECT_NE(result.message.find("not finite"), std::string::npos) << result.message;
  EXPECT_EQ(window.num_keyframes(), 2);
  EXPECT_EQ(window.num_points(), points_before);
  ASSERT_EQ(result.keyframe_poses.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(result.keyframe_poses[i].first, before[i].first);
    EXPECT_EQ(result.keyframe_poses[i].second.Matrix3x4Form(), before[i].second.Matrix3x4Form());
  }
  // A non-finite pose is refused the same way.
  KeyframeData bad_pose = test::MakeSyntheticKeyframe(Sequence(), 6, 2);
  bad_pose.world_from_cam.translation().x() = std::numeric_limits<double>::infinity();
  const WindowResult pose_result = window.AddKeyframe(std::move(bad_pose));
  EXPECT_FALSE(pose_result.optimized);
  EXPECT_NE(pose_result.message.find("pose is not finite"), std::string::npos)
      << pose_result.message;
  EXPECT_EQ(window.num_keyframes(), 2);
  const WindowResult good = window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 6, 2));
  EXPECT_TRUE(good.optimized) << good.message;
  EXPECT_EQ(window.num_keyframes(), 3);
  for (const WindowOptimizer::PointInfo& p : window.Points()) {
    EXPECT_TRUE(std::isfinite(p.inverse_depth));
  }
}

TEST(WindowOptimizerTest, NaNAndZeroDepthHostNoPointsButDoNotFail) {
  WindowOptimizer window(TestOptions());
  window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 0, 2));
  const int points_before = window.num_points();
  KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), 3, 2);
  for (ImageF& level : kf.depth.levels) {
    for (size_t i = 0; i < level.size(); ++i) {
      level.vector()[i] = i % 2 ? std::numeric_limits<float>::quiet_NaN() : 0.0f;
    }
  }
  const WindowResult result = window.AddKeyframe(std::move(kf));
  EXPECT_TRUE(result.optimized) << result.message;
  for (const WindowOptimizer::PointInfo& p : window.Points()) {
    EXPECT_EQ(p.host_frame, 0);  // nothing hosted in the keyframe without depth
    EXPECT_TRUE(std::isfinite(p.inverse_depth));
  }
  EXPECT_LE(window.num_points(), points_before);
  EXPECT_GT(window.num_residual_blocks(), 0);
}

// window.max_depth_edge_slope: no point is selected where the keyframe's depth changes faster
// than the slope within its 3 x 3 neighbourhood; without the rule the same street scene gives such
// points (its selection favours strong feature gradients, which object outlines have).
TEST(WindowOptimizerTest, DepthEdgeRuleKeepsPointsOffDepthEdges) {
  auto edge_points = [](double slope, int* num_points) {
    WindowOptions options = TestOptions();
    options.max_depth_edge_slope = slope;
    WindowOptimizer window(options);
    KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), 0, 2);
    const ImageF depth = kf.depth.levels[options.pyramid_level];
    const double fx = kf.features.levels[options.pyramid_level].camera.fx;
    const float max_ratio = static_cast<float>(1.0 + 6.0 * 2.0 / fx);
    window.AddKeyframe(std::move(kf));
    int on_edge = 0;
    for (const WindowOptimizer::PointInfo& p : window.Points()) {
      float lo = std::numeric_limits<float>::infinity(), hi = 0.0f;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          lo = std::min(lo, depth(p.x + dx, p.y + dy));
          hi = std::max(hi, depth(p.x + dx, p.y + dy));
        }
      }
      if (!(hi <= max_ratio * lo)) ++on_edge;
    }
    *num_points = window.num_points();
    return on_edge;
  };
  int all = 0, kept = 0;
  EXPECT_GT(edge_points(0.0, &all), 0);
  EXPECT_EQ(edge_points(6.0, &kept), 0);
  EXPECT_GT(kept, all / 2);  // the rule removes edge pixels, not the keyframe's points

  // The result says how much it left out: a small part of an exact depth map, nearly all of one
  // with 5 % per-pixel noise (what dfo_run warns about).
  WindowOptions options = TestOptions();
  options.max_depth_edge_slope = 6.0;
  WindowOptimizer exact(options);
  const double exact_fraction =
      exact.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 0, 2)).depth_edge_fraction;
  EXPECT_GT(exact_fraction, 0.0);
  EXPECT_LT(exact_fraction, 0.5);
  WindowOptimizer noisy(options);
  EXPECT_GT(
      noisy.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 0, 2, 0.05)).depth_edge_fraction,
      0.9);
}

TEST(WindowOptimizerTest, SparseAndDenseSchurAgree) {
  std::vector<std::pair<int, SE3d>> poses[2];
  for (int s = 0; s < 2; ++s) {
    WindowOptions options = TestOptions();
    options.linear_solver = s == 0 ? "sparse_schur" : "dense_schur";
    options.points_per_keyframe = 100;
    options.max_iterations = 5;
    WindowOptimizer window(options);
    std::mt19937 rng(4);
    for (int index = 0; index <= 6; index += 3) {
      KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), index, 2);
      if (index > 0) kf.world_from_cam = Perturb(kf.world_from_cam, 0.03, 0.005, &rng);
      poses[s] = window.AddKeyframe(std::move(kf)).keyframe_poses;
    }
  }
  ASSERT_EQ(poses[0].size(), poses[1].size());
  for (size_t i = 0; i < poses[0].size(); ++i) {
    const SE3d diff = poses[0][i].second.Inverse() * poses[1][i].second;
    EXPECT_LT(diff.translation().norm(), 1e-4);
    EXPECT_LT(diff.so3().Angle(), 1e-5);
  }
}

// The blocks evaluated ahead of Ceres on several threads (WindowOptions::evaluation_threads) give
// bitwise the same window as Ceres evaluating them itself: each block is evaluated alone.
TEST(WindowOptimizerTest, EvaluationThreadsDoNotChangeTheResult) {
  std::vector<std::vector<std::pair<int, SE3d>>> poses;
  std::vector<std::vector<Eigen::Vector3d>> points;
  int blocks = 0;
  for (const int threads : {1, 2, 3}) {
    WindowOptions options = TestOptions();
    options.evaluation_threads = threads;
    options.points_per_keyframe = 300;  // enough blocks for 3 threads (256 per thread at least)
    options.max_iterations = 4;
    WindowOptimizer window(options);
    std::mt19937 rng(4);
    WindowResult result;
    for (int index = 0; index <= 6; index += 3) {
      KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), index, 2);
      if (index > 0) kf.world_from_cam = Perturb(kf.world_from_cam, 0.03, 0.005, &rng);
      result = window.AddKeyframe(std::move(kf));
      ASSERT_TRUE(result.optimized || index == 0) << result.message;
    }
    blocks = result.num_residual_blocks;
    poses.push_back(result.keyframe_poses);
    points.push_back(window.PointsInCamera(SE3d()));
  }
  EXPECT_GE(blocks, 3 * 256);
  for (size_t t = 1; t < poses.size(); ++t) {
    ASSERT_EQ(poses[t].size(), poses[0].size());
    for (size_t i = 0; i < poses[0].size(); ++i) {
      EXPECT_EQ(poses[t][i].second.Matrix(), poses[0][i].second.Matrix()) << "threads " << t + 1;
    }
    ASSERT_EQ(points[t].size(), points[0].size());
    for (size_t i = 0; i < points[0].size(); ++i) EXPECT_EQ(points[t][i], points[0][i]);
  }
}

// A solve that cannot run (here: a keyframe turned away from everything the window saw, so no
// residual block exists) reports why and leaves the poses as they were; the run goes on and the
// next keyframe that sees the window is optimised.
TEST(WindowOptimizerTest, FailedSolveKeepsTheStateAndSaysWhy) {
  WindowOptimizer window(TestOptions());
  window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 0, 3));
  KeyframeData away = test::MakeSyntheticKeyframe(Sequence(), 3, 3);
  const SE3d turned = away.world_from_cam *
                      SE3d(SO3d::Exp(Eigen::Vector3d(0.0, M_PI, 0.0)), Eigen::Vector3d::Zero());
  away.world_from_cam = turned;
  const WindowResult result = window.AddKeyframe(std::move(away));
  EXPECT_FALSE(result.optimized);
  EXPECT_NE(result.message.find("no residual blocks"), std::string::npos) << result.message;
  ASSERT_EQ(result.keyframe_poses.size(), 2u);
  EXPECT_EQ((result.keyframe_poses[0].second.Inverse() * Sequence().WorldFromCam(0)).Log().norm(),
            0.0);
  EXPECT_EQ((result.keyframe_poses[1].second.Inverse() * turned).Log().norm(), 0.0);
  const WindowResult next = window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 6, 3));
  EXPECT_TRUE(next.optimized) << next.message;
  EXPECT_GT(next.num_residual_blocks, 0);
}

TEST(WindowOptimizerTest, BadKeyframesAreRejectedWithTheFrameIndex) {
  WindowOptimizer window(TestOptions());
  KeyframeData one_level = test::MakeSyntheticKeyframe(Sequence(), 0, 1);
  one_level.frame_index = 17;
  try {
    window.AddKeyframe(std::move(one_level));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 17"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("window.pyramid_level"), std::string::npos) << e.what();
  }
  window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), 0, 2));
  KeyframeData channels = test::MakeSyntheticKeyframe(Sequence(), 3, 2);
  FeatureLevel& level = channels.features.levels[TestOptions().pyramid_level];
  level.channels = 1;
  level.data.resize(static_cast<size_t>(level.width) * level.height);
  EXPECT_THROW(window.AddKeyframe(std::move(channels)), InputError);
  KeyframeData depth_size = test::MakeSyntheticKeyframe(Sequence(), 3, 2);
  depth_size.depth.levels[TestOptions().pyramid_level] = ImageF(5, 5);
  EXPECT_THROW(window.AddKeyframe(std::move(depth_size)), InputError);
  KeyframeData prior_scale = test::MakeSyntheticKeyframe(Sequence(), 3, 2);
  prior_scale.prior_depth_scale = 0.0;
  EXPECT_THROW(window.AddKeyframe(std::move(prior_scale)), InputError);
  EXPECT_EQ(window.num_keyframes(), 1);
}

// The synthetic keyframe of `frame` with its depth maps multiplied by `factor` (a wrong source
// depth).
KeyframeData KeyframeWithDepthTimes(int frame, float factor) {
  KeyframeData kf = test::MakeSyntheticKeyframe(Sequence(), frame);
  for (ImageF& level : kf.depth.levels) {
    for (float& d : level.vector()) d *= factor;
  }
  return kf;
}

// Median |log(depth / true depth)| of the window's points hosted in `frame`; infinity when it
// hosts none with a true depth.
double MedianLogDepthError(const WindowOptimizer& window, int frame) {
  const SyntheticFrame truth = Sequence().RenderFrame(frame);
  std::vector<double> errors;
  for (const WindowOptimizer::PointInfo& p : window.Points()) {
    if (p.host_frame != frame || !(truth.depth(p.x, p.y) > 0.0f)) continue;
    errors.push_back(std::abs(std::log(1.0 / (p.inverse_depth * truth.depth(p.x, p.y)))));
  }
  if (errors.empty()) return std::numeric_limits<double>::infinity();
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

// The depth search (window.depth_search_range) corrects a new keyframe whose source depth is 1.6x
// too far, by parallax against the keyframes already in the window, before the solve: the new
// points end near their true depth, where without the search the one solve step leaves them far
// off (outside the feature-metric basin). With uniqueness 1.2; the default 2 (chosen on real
// video, docs/tracking_against_the_window.md) moves only the 60 clearest of the 148 points here.
TEST(WindowOptimizerTest, DepthSearchCorrectsAWrongSourceDepthByParallax) {
  double err[2] = {0.0, 0.0};
  int moved = 0;
  for (int search = 0; search < 2; ++search) {
    WindowOptions options;
    options.num_threads = 1;
    options.max_iterations = 1;
    options.max_solver_time_s = 60.0;
    options.depth_search_range = search ? 2.0 : 1.0;
    options.depth_search_uniqueness = 1.2;
    WindowOptimizer window(options);
    for (int frame : {0, 3, 6}) window.AddKeyframe(test::MakeSyntheticKeyframe(Sequence(), frame));
    const WindowResult r = window.AddKeyframe(KeyframeWithDepthTimes(9, 1.6f));
    ASSERT_TRUE(r.optimized) << r.message;
    err[search] = MedianLogDepthError(window, 9);
    if (search) {
      EXPECT_GT(r.num_depth_searched, 50);
      moved = r.num_depth_found;
    } else {
      EXPECT_EQ(r.num_depth_searched, 0);
    }
  }
  std::printf(
      "[ figures  ] depth 1.6x too far: median |log depth error| of the points seen from "
      "the new keyframe %.3f without the depth search, %.3f with it (%d points moved)\n",
      err[0], err[1], moved);
  EXPECT_LT(err[1], 0.5 * err[0]);
  EXPECT_LT(err[1], 0.1);
}

// With window.searched_points_only, selected points are candidates: none enters the window with the
// source's depth (here 1.6x too far in every keyframe); each enters once parallax against
// another keyframe has found its depth, and the candidates leave with their keyframe.
TEST(WindowOptimizerTest, SearchedPointsEnterOnlyWithTheDepthParallaxFound) {
  WindowOptions options = TestOptions();
  options.max_iterations = 1;
  options.depth_search_range = 2.0;
  options.depth_search_uniqueness = 1.2;
  options.searched_points_only = true;
  WindowOptimizer window(options);
  const auto too_far = [](int frame) { return KeyframeWithDepthTimes(frame, 1.6f); };
  const WindowResult first = window.AddKeyframe(too_far(0));
  EXPECT_EQ(window.num_points(), 0);
  EXPECT_GT(first.num_candidates, 100);
  const WindowResult second = window.AddKeyframe(too_far(3));
  ASSERT_TRUE(second.optimized) << second.message;
  EXPECT_GT(second.num_depth_found, 100);
  EXPECT_LE(window.num_points(), second.num_depth_found);  // the gate may leave some blockless
  const double error = std::max(MedianLogDepthError(window, 0), MedianLogDepthError(window, 3));
  std::printf(
      "[ figures  ] source depth 1.6x too far (|log| 0.470): %d of %d candidates entered after "
      "the second keyframe, median |log depth error| %.3f (the worse keyframe)\n",
      second.num_depth_found, second.num_depth_found + second.num_candidates, error);
  EXPECT_LT(error, 0.1);
  // Candidates are bounded by the keyframes in the window.
  for (int k = 2; k < 12; ++k) {
    const WindowResult r = window.AddKeyframe(too_far(3 * k));
    EXPECT_LE(r.num_candidates, window.num_keyframes() * options.points_per_keyframe);
  }
}

TEST(WindowOptionsTest, CheckNamesTheKey) {
  auto message = [](const WindowOptions& o) {
    try {
      o.Check();
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  WindowOptions o;
  EXPECT_EQ(message(o), "");
  o.max_keyframes = 4;
  EXPECT_EQ(message(o), "window.max_keyframes = 4 violates >= 5");
  o = WindowOptions();
  o.patch_size = 4;
  EXPECT_NE(message(o).find("window.patch_size = 4"), std::string::npos);
  o = WindowOptions();
  o.loss = "l2";
  EXPECT_NE(message(o).find("window.loss = l2"), std::string::npos);
  o = WindowOptions();
  o.linear_solver = "cholesky";
  EXPECT_NE(message(o).find("window.linear_solver"), std::string::npos);
  o = WindowOptions();
  o.prior_weight = 0.0;
  EXPECT_NE(message(o).find("backend.prior_weight = 0"), std::string::npos);
  o = WindowOptions();
  o.max_patch_stretch = 1.0;
  EXPECT_EQ(message(o), "window.max_patch_stretch = 1 violates > 1");
  o = WindowOptions();
  o.searched_points_only = true;
  o.depth_search_range = 1.0;
  EXPECT_EQ(message(o),
            "window.searched_points_only = true violates false when window.depth_search_range is "
            "1 (no search)");
  o = WindowOptions();
  o.depth_prior_scale_fraction = 1.5;
  EXPECT_EQ(message(o), "window.depth_prior_scale_fraction = 1.5 violates in [0, 1]");
  o = WindowOptions();
  o.max_depth_edge_slope = -1.0;
  EXPECT_EQ(message(o), "window.max_depth_edge_slope = -1 violates >= 0");
  o = WindowOptions();
  o.outlier_gate_percentile = 1.5;
  EXPECT_NE(message(o).find("window.outlier_gate_percentile"), std::string::npos);
  EXPECT_THROW(WindowOptimizer bad(o), ConfigError);
}

}  // namespace
}  // namespace dfo
