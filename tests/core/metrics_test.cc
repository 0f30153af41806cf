#include "dfo_core/metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>

#include "dfo_core/alignment.h"
#include "dfo_core/error.h"

namespace dfo {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Straight drive along +z (the KITTI camera's forward axis), `step` metres per frame.
Trajectory StraightLine(int n, double step) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    t.Add(static_cast<int64_t>(i) * 100000000LL, SE3d(SO3d(), Eigen::Vector3d(0, 0, step * i)));
  }
  return t;
}

// A smooth curving trajectory with changing orientation (fixed seed).
Trajectory Curvy(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.05);
  Trajectory t;
  SE3d pose;
  for (int i = 0; i < n; ++i) {
    t.Add(static_cast<int64_t>(i) * 100000000LL, pose);
    Vector6d xi;
    xi << noise(rng), noise(rng), 1.0 + noise(rng), noise(rng), 0.05 + noise(rng), noise(rng);
    pose = pose * SE3d::Exp(xi);
  }
  return t;
}

TEST(Statistics, MatchNumpyDefinitions) {
  const ErrorStatistics s = ComputeStatistics({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(s.count, 4u);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5));
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);           // mean of the two middle values
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));  // population std
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 4.0);
  EXPECT_DOUBLE_EQ(s.sse, 30.0);
  EXPECT_DOUBLE_EQ(ComputeStatistics({3.0, 1.0, 2.0}).median, 2.0);
  const ErrorStatistics empty = ComputeStatistics({});
  EXPECT_EQ(empty.count, 0u);
  EXPECT_TRUE(std::isnan(empty.rmse));
  EXPECT_TRUE(std::isnan(empty.median));
}

// Errors beyond 1e154 square to inf: the statistics are computed on values scaled by a power of
// two instead, so they stay right wherever the result is representable.
TEST(Statistics, HugeErrorsDoNotOverflow) {
  const ErrorStatistics s = ComputeStatistics({4e200, 1e200, 3e200, 2e200});
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(7.5) * 1e200);
  EXPECT_DOUBLE_EQ(s.mean, 2.5e200);
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25) * 1e200);
  EXPECT_EQ(s.max, 4e200);
  EXPECT_TRUE(std::isinf(s.sse));  // the sum of squares itself is beyond the double range
  const ErrorStatistics near_max = ComputeStatistics({1.5e308, 1.7e308, 1.6e308});
  EXPECT_DOUBLE_EQ(near_max.mean, 1.6e308);
  EXPECT_TRUE(std::isfinite(near_max.rmse));
  EXPECT_TRUE(std::isfinite(near_max.std));
  const ErrorStatistics tiny = ComputeStatistics({3e-200, 4e-200});
  EXPECT_DOUBLE_EQ(tiny.rmse, std::sqrt(12.5) * 1e-200);
}

// Every metric of a pair scaled by 2^600 (about 4e180) is the ordinary one scaled, instead of
// n/a or 0 from squares that overflowed.
TEST(Metrics, ExactAtAnyMagnitude) {
  Trajectory gt = Curvy(40, 3);
  Trajectory est = gt;
  std::mt19937 rng(2);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (auto& p : est.poses()) {
    p.world_from_cam =
        p.world_from_cam * SE3d::Exp((Vector6d() << noise(rng), noise(rng), noise(rng),
                                      0.1 * noise(rng), 0.1 * noise(rng), 0.1 * noise(rng))
                                         .finished());
  }
  // Both through TransformTrajectory (which rebuilds the rotations), with scale 1 and 2^600.
  SimilarityTransform up;
  gt = TransformTrajectory(gt, up);
  est = TransformTrajectory(est, up);
  up.scale = std::ldexp(1.0, 600);
  const Trajectory big_gt = TransformTrajectory(gt, up);
  const Trajectory big_est = TransformTrajectory(est, up);
  // Relative 1e-12: the relative poses (T_i^-1 T_j) are rounded differently at the two scales.
  const auto expect_scaled = [](double big, double base) {
    EXPECT_NEAR(big / std::ldexp(base, 600), 1.0, 1e-12) << big << " vs " << base;
  };
  const AteResult ate = ComputeAte(gt, est), big_ate = ComputeAte(big_gt, big_est);
  expect_scaled(big_ate.stats.rmse, ate.stats.rmse);
  expect_scaled(big_ate.stats.std, ate.stats.std);
  expect_scaled(big_ate.stats.max, ate.stats.max);
  const RpeResult rpe = ComputeRpe(gt, est), big_rpe = ComputeRpe(big_gt, big_est);
  expect_scaled(big_rpe.translation.rmse, rpe.translation.rmse);
  EXPECT_NEAR(big_rpe.rotation_deg.rmse, rpe.rotation_deg.rmse, 1e-12);
  const SnippetAteResult snippet = ComputeSnippetAte(gt, est);
  const SnippetAteResult big_snippet = ComputeSnippetAte(big_gt, big_est);
  expect_scaled(big_snippet.mean, snippet.mean);
  expect_scaled(big_gt.PathLength(), gt.PathLength());
  const KittiOdometryResult big_kitti = ComputeKittiOdometryErrors(big_gt, big_est);
  EXPECT_GT(big_kitti.num_segments, 0u);
  EXPECT_TRUE(std::isfinite(big_kitti.t_rel_pct));
}

// A difference of positions beyond the double range is an InputError naming the pose, not an
// ATE of inf.
TEST(Ate, ErrorBeyondTheDoubleRangeIsAnInputError) {
  Trajectory gt = Curvy(5, 1), est = gt;
  gt[3].world_from_cam.translation().x() = 1.7e308;
  est[3].world_from_cam.translation().x() = -1.7e308;
  try {
    ComputeAte(gt, est);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("ATE: the error of pose 3 is inf"), std::string::npos)
        << e.what();
  }
  est[3].world_from_cam.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(ComputeAte(gt, est), InputError);
  EXPECT_THROW(ComputeRpe(gt, est), InputError);
}

TEST(Ate, IdentityIsZeroAndOffsetIsItsLength) {
  const Trajectory gt = Curvy(30, 1);
  EXPECT_EQ(ComputeAte(gt, gt).stats.max, 0.0);
  Trajectory est = gt;
  for (auto& p : est.poses()) p.world_from_cam.translation() += Eigen::Vector3d(0.3, 0.4, 0.0);
  const AteResult ate = ComputeAte(gt, est);
  ASSERT_EQ(ate.errors.size(), 30u);
  EXPECT_NEAR(ate.stats.rmse, 0.5, 1e-12);
  EXPECT_NEAR(ate.stats.min, 0.5, 1e-12);
  EXPECT_THROW(ComputeAte(gt, Curvy(29, 1)), InputError);
}

TEST(Rpe, KnownPerStepErrorForFrameDelta) {
  // gt moves 1 m per frame; the estimate 1.1 m and turns 1 degree per frame about the
  // direction of travel. E = Q_rel^-1 P_rel: translation error 0.1 per frame of delta, rotation
  // 1 degree per frame of delta (the extra translation is along the rotation axis).
  const int n = 21;
  const Trajectory gt = StraightLine(n, 1.0);
  Trajectory est;
  for (int i = 0; i < n; ++i) {
    est.Add(gt[i].timestamp_ns,
            SE3d(SO3d::Exp(Eigen::Vector3d(0, 0, i * kDegToRad)), Eigen::Vector3d(0, 0, 1.1 * i)));
  }
  RpeResult rpe = ComputeRpe(gt, est);
  ASSERT_EQ(rpe.pairs.size(), 20u);
  EXPECT_NEAR(rpe.translation.rmse, 0.1, 1e-12);
  EXPECT_NEAR(rpe.translation.max, 0.1, 1e-12);
  EXPECT_NEAR(rpe.rotation_deg.rmse, 1.0, 1e-9);

  RpeOptions options;
  options.delta = 4;  // consecutive pairs (0,4), (4,8), ..., (16,20)
  rpe = ComputeRpe(gt, est, options);
  ASSERT_EQ(rpe.pairs.size(), 5u);
  EXPECT_EQ(rpe.pairs[1], std::make_pair(size_t{4}, size_t{8}));
  EXPECT_NEAR(rpe.translation.mean, 0.4, 1e-12);
  EXPECT_NEAR(rpe.rotation_deg.mean, 4.0, 1e-9);

  options.all_pairs = true;  // (i, i + 4) for every i
  rpe = ComputeRpe(gt, est, options);
  EXPECT_EQ(rpe.pairs.size(), 17u);
  EXPECT_NEAR(rpe.translation.median, 0.4, 1e-12);
}

TEST(Rpe, MetreDeltaFollowsEvoPathFilter) {
  const Trajectory gt = StraightLine(20, 1.0);
  RpeOptions options;
  options.delta = 3.0;
  options.delta_unit = DeltaUnit::kMeters;
  // evo's consecutive path filter takes ids 3, 6, 9, ... (not 0).
  const RpeResult rpe = ComputeRpe(gt, gt, options);
  ASSERT_EQ(rpe.pairs.size(), 5u);
  EXPECT_EQ(rpe.pairs[0], std::make_pair(size_t{3}, size_t{6}));
  EXPECT_EQ(rpe.pairs[4], std::make_pair(size_t{15}, size_t{18}));
  EXPECT_EQ(rpe.translation.max, 0.0);

  options.all_pairs = true;  // (i, i + 3) for every i with 3 m left
  const RpeResult all = ComputeRpe(gt, gt, options);
  ASSERT_EQ(all.pairs.size(), 17u);
  EXPECT_EQ(all.pairs[0], std::make_pair(size_t{0}, size_t{3}));
}

TEST(Rpe, TooShortGivesNaNAndBadOptionsThrow) {
  const Trajectory gt = StraightLine(3, 1.0);
  RpeOptions options;
  options.delta = 5;
  const RpeResult rpe = ComputeRpe(gt, gt, options);
  EXPECT_TRUE(rpe.pairs.empty());
  EXPECT_TRUE(std::isnan(rpe.translation.rmse));
  options.delta = 1.5;  // frames must be whole
  EXPECT_THROW(ComputeRpe(gt, gt, options), ConfigError);
  options.delta = 0;
  EXPECT_THROW(ComputeRpe(gt, gt, options), ConfigError);
}

TEST(KittiOdometry, ConstantScaleErrorGivesTenPercent) {
  // est = 1.1 x gt without alignment: every segment's translation error is 10% of the segment's
  // true length. The devkit divides by the nominal length L while the segment runs to the first
  // frame beyond L, i.e. L + step: hence 10 (1 + step / L) %, within 0.002 for step = 0.02 m.
  const double step = 0.02;
  const Trajectory gt = StraightLine(42000, step);  // 840 m
  Trajectory est = gt;
  for (auto& p : est.poses()) p.world_from_cam.translation() *= 1.1;
  const KittiOdometryResult r = ComputeKittiOdometryErrors(gt, est);
  EXPECT_GT(r.num_segments, 1000u);
  EXPECT_NEAR(r.t_rel_pct, 10.0, 0.003);
  EXPECT_GE(r.t_rel_pct, 10.0 - 1e-9);
  EXPECT_NEAR(r.r_rel_deg_per_100m, 0.0, 1e-6);
  ASSERT_EQ(r.per_length.size(), 8u);
  EXPECT_EQ(r.per_length[7].length_m, 800.0);
  EXPECT_GT(r.per_length[7].num_segments, 0u);
  EXPECT_NEAR(r.per_length[7].t_rel_pct, 10.0, 0.001);
  // Perfect estimate: zero.
  const KittiOdometryResult zero = ComputeKittiOdometryErrors(gt, gt);
  EXPECT_NEAR(zero.t_rel_pct, 0.0, 1e-9);
}

TEST(KittiOdometry, ConstantHeadingDriftGivesKnownRotationError) {
  // The estimate's orientation turns by theta per frame about the forward axis while its
  // positions are exact: r_err = k theta / L with k = L / step + 1 frames per segment, so
  // r_rel = theta / step (1 + step / L) rad/m. theta chosen for 1 deg / 100 m.
  const double step = 0.05;
  const double theta = step * kDegToRad / 100.0;
  const Trajectory gt = StraightLine(17000, step);  // 850 m
  Trajectory est;
  for (size_t i = 0; i < gt.size(); ++i) {
    est.Add(gt[i].timestamp_ns,
            SE3d(SO3d::Exp(Eigen::Vector3d(0, 0, theta * i)), gt[i].world_from_cam.translation()));
  }
  const KittiOdometryResult r = ComputeKittiOdometryErrors(gt, est);
  EXPECT_NEAR(r.r_rel_deg_per_100m, 1.0, 0.001);
}

TEST(KittiOdometry, ShortTrajectoryHasNoSegment) {
  const Trajectory gt = StraightLine(50, 1.2);  // 60 m, like the shared KITTI extract
  const KittiOdometryResult r = ComputeKittiOdometryErrors(gt, gt);
  EXPECT_EQ(r.num_segments, 0u);
  EXPECT_TRUE(std::isnan(r.t_rel_pct));
  EXPECT_TRUE(std::isnan(r.r_rel_deg_per_100m));
  KittiOdometryOptions options;
  options.step_frames = 0;
  EXPECT_THROW(ComputeKittiOdometryErrors(gt, gt, options), ConfigError);
}

TEST(SnippetAte, ScaledAndMovedTrajectoryScoresZero) {
  const Trajectory gt = Curvy(40, 3);
  SimilarityTransform s;
  s.scale = 0.37;
  s.rotation = SO3d::Exp(Eigen::Vector3d(0.2, 1.0, -0.4)).Matrix();
  s.translation = Eigen::Vector3d(3, 2, 1);
  const Trajectory est = TransformTrajectory(gt, s);
  const SnippetAteResult r = ComputeSnippetAte(gt, est);
  ASSERT_EQ(r.errors.size(), 36u);  // stride 1, 5 frames
  EXPECT_LT(r.mean, 1e-12);
  EXPECT_LT(r.std, 1e-12);
}

TEST(SnippetAte, KnownSnippetValueWithTheDivideByNQuirk) {
  // One snippet: gt at z = 0..4, the estimate's last position off by 1 m sideways.
  Trajectory gt = StraightLine(5, 1.0);
  Trajectory est = gt;
  est[4].world_from_cam.translation().x() = 1.0;
  // s = sum(gt . est) / sum(est . est) = 30 / 31; error = sqrt(sum |s est - gt|^2) / 5.
  const double s = 30.0 / 31.0;
  double sum_sq = 0.0;
  for (int k = 0; k < 5; ++k) {
    const Eigen::Vector3d e(k == 4 ? s : 0.0, 0.0, (s - 1.0) * k);
    sum_sq += e.squaredNorm();
  }
  const SnippetAteResult r = ComputeSnippetAte(gt, est);
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NEAR(r.errors[0], std::sqrt(sum_sq) / 5.0, 1e-12);
  EXPECT_NEAR(r.std, 0.0, 1e-15);
  // Too short: no snippet, NaN.
  const SnippetAteResult none = ComputeSnippetAte(StraightLine(4, 1.0), StraightLine(4, 1.0));
  EXPECT_TRUE(none.errors.empty());
  EXPECT_TRUE(std::isnan(none.mean));
}

TEST(SnippetAte, StrideAndLengthOptions) {
  const Trajectory gt = Curvy(23, 4);
  SnippetAteOptions options;
  options.snippet_length = 3;
  options.stride = 5;  // starts 0, 5, 10, 15, 20
  EXPECT_EQ(ComputeSnippetAte(gt, gt, options).errors.size(), 5u);
  options.snippet_length = 1;
  EXPECT_THROW(ComputeSnippetAte(gt, gt, options), ConfigError);
}

}  // namespace
}  // namespace dfo

namespace dfo {
namespace {

// An estimate that drives the same line with its step length times `factor` from frame `from`.
Trajectory StepScaledFrom(const Trajectory& gt, size_t from, double factor) {
  Trajectory est;
  Eigen::Vector3d position = gt[0].world_from_cam.translation();
  for (size_t i = 0; i < gt.size(); ++i) {
    if (i > 0) {
      const Eigen::Vector3d step =
          gt[i].world_from_cam.translation() - gt[i - 1].world_from_cam.translation();
      position += (i > from ? factor : 1.0) * step;
    }
    est.Add(gt[i].timestamp_ns, SE3d(gt[i].world_from_cam.so3(), position));
  }
  return est;
}

TEST(ScaleDrift, RatiosFollowTheStepLengthAlongTheRun) {
  const Trajectory gt = StraightLine(1001, 0.2);  // 200 m, 4 stretches of 50 m
  ScaleDriftResult same = ComputeScaleDrift(gt, gt);
  ASSERT_EQ(same.ratios.size(), 4u);
  for (double r : same.ratios) EXPECT_NEAR(r, 1.0, 1e-9);
  EXPECT_NEAR(same.log_std, 0.0, 1e-9);
  EXPECT_EQ(same.first_index[0], 0u);
  EXPECT_EQ(same.first_index[1], 250u);

  // The second half 1.2 times too long: two stretches at 1, two at 1.2.
  const ScaleDriftResult half = ComputeScaleDrift(gt, StepScaledFrom(gt, 500, 1.2));
  ASSERT_EQ(half.ratios.size(), 4u);
  EXPECT_NEAR(half.ratios[0], 1.0, 1e-9);
  EXPECT_NEAR(half.ratios[1], 1.0, 1e-9);
  EXPECT_NEAR(half.ratios[2], 1.2, 1e-9);
  EXPECT_NEAR(half.ratios[3], 1.2, 1e-9);
  EXPECT_NEAR(half.log_std, 0.5 * std::log(1.2), 1e-9);
  EXPECT_NEAR(half.min, 1.0, 1e-9);
  EXPECT_NEAR(half.max, 1.2, 1e-9);
}

TEST(ScaleDrift, FrameToFrameJitterIsNotScale) {
  // 5 cm of sideways jitter every frame (0.2 m steps) would lengthen a frame-to-frame path by
  // about 12 %; along the chords it stays below 0.1 %.
  const Trajectory gt = StraightLine(1001, 0.2);
  Trajectory jittery;
  for (size_t i = 0; i < gt.size(); ++i) {
    const Eigen::Vector3d offset(i % 2 ? 0.05 : -0.05, 0.0, 0.0);
    jittery.Add(gt[i].timestamp_ns,
                SE3d(gt[i].world_from_cam.so3(), gt[i].world_from_cam.translation() + offset));
  }
  const ScaleDriftResult drift = ComputeScaleDrift(gt, jittery);
  ASSERT_EQ(drift.ratios.size(), 4u);
  for (double r : drift.ratios) EXPECT_NEAR(r, 1.0, 1e-3);
}

// Per 20-frame stretches, for runs too short for 50 m ones: the second half of a 101-pose run 1.2
// times too long gives 1, 1, then 1.2 twice (the stretch from frame 40 straddles the change at
// frame 50: half at each), the last 20 frames (a stretch from frame 100 would need pose 120) left
// out; a stretch whose ground truth stands still has no ratio.
TEST(StepScale, RatiosPerFrameStretchFollowTheStepLength) {
  const Trajectory gt = StraightLine(101, 0.2);
  const ScaleDriftResult same = ComputeStepScale(gt, gt);
  EXPECT_EQ(same.segment_frames, 20);
  ASSERT_EQ(same.ratios.size(), 5u);
  for (double r : same.ratios) EXPECT_NEAR(r, 1.0, 1e-9);
  const ScaleDriftResult half = ComputeStepScale(gt, StepScaledFrom(gt, 50, 1.2));
  ASSERT_EQ(half.ratios.size(), 5u);
  EXPECT_NEAR(half.ratios[0], 1.0, 1e-9);
  EXPECT_NEAR(half.ratios[1], 1.0, 1e-9);
  EXPECT_NEAR(half.ratios[2], 1.1, 1e-9);
  EXPECT_NEAR(half.ratios[3], 1.2, 1e-9);
  EXPECT_NEAR(half.ratios[4], 1.2, 1e-9);
  EXPECT_EQ(half.first_index[3], 60u);
  EXPECT_NEAR(half.min, 1.0, 1e-9);
  EXPECT_NEAR(half.max, 1.2, 1e-9);
  EXPECT_GT(half.log_std, 0.0);

  Trajectory stopped;
  for (int i = 0; i < 41; ++i) {
    const double x = i < 20 ? 0.0 : 0.2 * (i - 20);  // stands still for the first 20 frames
    stopped.Add(i * 100000000LL, SE3d(SO3d(), Eigen::Vector3d(x, 0.0, 0.0)));
  }
  const ScaleDriftResult skipped = ComputeStepScale(stopped, stopped);
  ASSERT_EQ(skipped.ratios.size(), 1u);
  EXPECT_EQ(skipped.first_index[0], 20u);
  EXPECT_TRUE(std::isnan(skipped.log_std));  // one stretch

  EXPECT_THROW(ComputeStepScale(gt, gt, 0), InputError);
  EXPECT_THROW(ComputeStepScale(gt, StraightLine(100, 0.2)), InputError);
}

TEST(ScaleDrift, ShortRunsGiveNaNAndBadInputThrows) {
  const Trajectory gt = StraightLine(200, 0.2);  // 40 m: no full stretch
  const ScaleDriftResult none = ComputeScaleDrift(gt, gt);
  EXPECT_TRUE(none.ratios.empty());
  EXPECT_TRUE(std::isnan(none.log_std));
  EXPECT_TRUE(std::isnan(none.min));
  const ScaleDriftResult one = ComputeScaleDrift(gt, gt, 30.0);
  EXPECT_EQ(one.ratios.size(), 1u);
  EXPECT_TRUE(std::isnan(one.log_std));
  EXPECT_THROW(ComputeScaleDrift(gt, gt, 0.0), InputError);
  EXPECT_THROW(ComputeScaleDrift(gt, StraightLine(199, 0.2)), InputError);
}

// A path whose steps are those of `gt` with step i's length times length_factor(i) and its
// direction turned by yaw(i) radians about the vertical axis (y), from gt's first position.
template <typename LengthFactor, typename Yaw>
Trajectory ReshapedSteps(const Trajectory& gt, LengthFactor length_factor, Yaw yaw) {
  Trajectory out;
  Eigen::Vector3d p = gt[0].world_from_cam.translation();
  out.Add(gt[0].timestamp_ns, SE3d(SO3d(), p));
  for (size_t i = 1; i < gt.size(); ++i) {
    const Eigen::Vector3d d =
        gt[i].world_from_cam.translation() - gt[i - 1].world_from_cam.translation();
    p += SO3d::Exp(Eigen::Vector3d(0, yaw(i), 0)) * d * length_factor(i);
    out.Add(gt[i].timestamp_ns, SE3d(SO3d(), p));
  }
  return out;
}

TEST(AteSplit, SeparatesStepLengthsFromDirections) {
  const Trajectory gt = Curvy(200, 7);
  TrajectoryAlignmentOptions sim3;
  sim3.type = AlignmentType::kSim3;
  const auto ate = [&](const Trajectory& est) {
    return ComputeAte(gt, AlignTrajectory(est, gt, sim3).aligned_estimate).stats.rmse;
  };
  // Exact directions, the step length growing 1 -> 1.3 along the run (a monocular scale drift),
  // in a frame of its own (scaled 3x, moved): all of the ATE is the lengths'.
  const Trajectory drift = ReshapedSteps(
      gt, [](size_t i) { return 3.0 * (1.0 + 0.3 * i / 199.0); }, [](size_t) { return 0.0; });
  const AteSplit a = ComputeAteSplit(gt, drift, sim3);
  EXPECT_GT(ate(drift), 1.0);
  EXPECT_LT(a.directions_rmse, 1e-9);
  EXPECT_NEAR(a.lengths_rmse, ate(drift), 1e-9);
  // Exact lengths, the heading turning by a growing yaw (0.1 deg more every step): all of it is
  // the directions'.
  const Trajectory heading = ReshapedSteps(
      gt, [](size_t) { return 1.0; }, [](size_t i) { return 0.1 * kDegToRad * i; });
  const AteSplit b = ComputeAteSplit(gt, heading, sim3);
  EXPECT_GT(ate(heading), 1.0);
  EXPECT_LT(b.lengths_rmse, 1e-9);
  EXPECT_NEAR(b.directions_rmse, ate(heading), 1e-9);
  // Both at once: each part is less than the whole.
  const Trajectory both = ReshapedSteps(
      gt, [](size_t i) { return 1.0 + 0.3 * i / 199.0; },
      [](size_t i) { return 0.1 * kDegToRad * i; });
  const AteSplit c = ComputeAteSplit(gt, both, sim3);
  EXPECT_GT(c.directions_rmse, 0.5);
  EXPECT_GT(c.lengths_rmse, 0.5);
  EXPECT_LT(c.directions_rmse, ate(both));
  EXPECT_LT(c.lengths_rmse, ate(both));

  // An estimate that does not move: the path with its directions is a point, no alignment: NaN.
  Trajectory still;
  for (size_t i = 0; i < gt.size(); ++i) still.Add(gt[i].timestamp_ns, SE3d());
  EXPECT_TRUE(std::isnan(ComputeAteSplit(gt, still, sim3).directions_rmse));
  Trajectory shorter = gt;
  shorter.poses().pop_back();
  EXPECT_THROW(ComputeAteSplit(gt, shorter, sim3), InputError);
  Trajectory one;
  one.Add(0, SE3d());
  EXPECT_THROW(ComputeAteSplit(one, one, sim3), InputError);
}

}  // namespace
}  // namespace dfo
