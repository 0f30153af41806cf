// The configuration sections keyframe / window / backend and run.mode against the backend's
// structs: the schema in dfo_io cannot see them, so these tests keep the two in step.
#include "apps/common/backend_config.h"

#include <gtest/gtest.h>

#include <string>

#include "dfo_core/error.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

TEST(BackendConfig, SchemaDefaultsEqualKeyframeOptionsDefaults) {
  const io::Config config(io::DfoSchema());
  const KeyframeOptions k = apps::KeyframeOptionsFromConfig(config);
  const KeyframeOptions d;
  EXPECT_EQ(k.translation_ratio, d.translation_ratio);
  EXPECT_EQ(k.rotation_deg, d.rotation_deg);
  EXPECT_EQ(k.residual_ratio, d.residual_ratio);
  EXPECT_EQ(k.min_inlier_ratio, d.min_inlier_ratio);
  EXPECT_EQ(k.min_interval, d.min_interval);
  EXPECT_EQ(k.max_interval, d.max_interval);
  // By default the keyframe manager drives the frontend, and dfo_run compares both trajectories.
  EXPECT_EQ(apps::ReferencePolicyFromConfig(config), "external");
  EXPECT_EQ(apps::RunModeFromConfig(config), apps::RunMode::kBoth);
}

TEST(BackendConfig, SchemaDefaultsEqualTrackingDepthOptionsDefaults) {
  const io::Config config(io::DfoSchema());
  const TrackingDepthOptions t = apps::TrackingDepthOptionsFromConfig(config);
  const TrackingDepthOptions d;
  EXPECT_EQ(t.depth, d.depth);
  EXPECT_EQ(t.fill, d.fill);
  EXPECT_EQ(t.min_window_points, d.min_window_points);
  EXPECT_EQ(t.splat_radius_px, d.splat_radius_px);
  EXPECT_EQ(t.initial_depth_scale, d.initial_depth_scale);
  EXPECT_EQ(t.source_scale, d.source_scale);
  const OdometryOptions o = apps::OdometryOptionsFromConfig(config);
  EXPECT_EQ(o.mode, OdometryMode::kBoth);
  EXPECT_EQ(o.tracking.depth, "window");
}

TEST(BackendConfig, TrackingDepthKeysAreValidated) {
  const auto load = [](const std::string& text) {
    return apps::TrackingDepthOptionsFromConfig(
        io::LoadConfigFromString(text, "t.yaml", io::DfoSchema()));
  };
  EXPECT_EQ(load("tracker:\n  depth: source\n").depth, "source");
  EXPECT_THROW(load("tracker:\n  depth: both\n"), ConfigError);
  EXPECT_THROW(load("tracker:\n  depth_fill: zeros\n"), ConfigError);
  EXPECT_THROW(load("tracker:\n  min_window_points: 0\n"), ConfigError);
  EXPECT_THROW(load("window:\n  initial_depth_scale: network\n"), ConfigError);
  EXPECT_EQ(load("window:\n  source_scale: run_median\n").source_scale, "run_median");
  EXPECT_THROW(load("window:\n  source_scale: median\n"), ConfigError);
  TrackingDepthOptions bad;
  bad.splat_radius_px = -1;
  EXPECT_THROW(bad.Check(), ConfigError);
}

TEST(BackendConfig, SchemaDefaultsEqualWindowOptionsDefaults) {
  const io::Config config(io::DfoSchema());
  const WindowOptions w = apps::WindowOptionsFromConfig(config);
  const WindowOptions d;
  EXPECT_EQ(w.max_keyframes, d.max_keyframes);
  EXPECT_EQ(w.pyramid_level, d.pyramid_level);
  EXPECT_EQ(w.patch_size, d.patch_size);
  EXPECT_EQ(w.points_per_keyframe, d.points_per_keyframe);
  EXPECT_EQ(w.loss, d.loss);
  EXPECT_EQ(w.loss_scale, d.loss_scale);
  EXPECT_EQ(w.linear_solver, d.linear_solver);
  EXPECT_EQ(w.max_iterations, d.max_iterations);
  EXPECT_EQ(w.max_solver_time_s, apps::kDeterministicSolverTimeS);  // run.deterministic
  EXPECT_EQ(w.min_inverse_depth, d.min_inverse_depth);
  EXPECT_EQ(w.depth_prior_weight, d.depth_prior_weight);
  EXPECT_EQ(w.pose_prior_weight, d.pose_prior_weight);
  EXPECT_EQ(w.outlier_gate_percentile, d.outlier_gate_percentile);
  EXPECT_EQ(w.outlier_gate_factor, d.outlier_gate_factor);
  EXPECT_EQ(w.min_point_fraction, d.min_point_fraction);
  EXPECT_EQ(w.min_marginalized_observations, d.min_marginalized_observations);
  EXPECT_EQ(w.max_depth_edge_slope, d.max_depth_edge_slope);
  EXPECT_EQ(w.depth_search_range, d.depth_search_range);
  EXPECT_EQ(w.depth_search_uniqueness, d.depth_search_uniqueness);
  EXPECT_EQ(w.searched_points_only, d.searched_points_only);
  EXPECT_EQ(w.marginalization, d.marginalization);
  EXPECT_EQ(w.first_estimate_jacobians, d.first_estimate_jacobians);
  EXPECT_EQ(w.prior_weight, d.prior_weight);
  EXPECT_EQ(w.relative_eigenvalue_floor, d.relative_eigenvalue_floor);
  // The deliberate difference: threads come from run.threads, and run.deterministic (default
  // true) makes Ceres single-threaded.
  EXPECT_EQ(w.num_threads, 1);
  const io::Config fast = io::LoadConfigFromString("run:\n  deterministic: false\n  threads: 3\n",
                                                   "f.yaml", io::DfoSchema());
  EXPECT_EQ(apps::WindowOptionsFromConfig(fast).num_threads, 3);
  EXPECT_EQ(apps::WindowOptionsFromConfig(fast).max_solver_time_s, d.max_solver_time_s);
}

TEST(BackendConfig, EveryWindowAndBackendKeyReachesItsField) {
  const io::Config config = io::LoadConfigFromString(
      "window:\n"
      "  max_keyframes: 5\n"
      "  pyramid_level: 2\n"
      "  patch_size: 5\n"
      "  points_per_keyframe: 123\n"
      "  loss: cauchy\n"
      "  loss_scale: 0.75\n"
      "  linear_solver: dense_schur\n"
      "  max_iterations: 4\n"
      "  max_solver_time_s: 0.05\n"
      "  min_inverse_depth: 0.01\n"
      "  depth_prior_weight: 0.5\n"
      "  pose_prior_weight: 0.25\n"
      "  outlier_gate_percentile: 0.8\n"
      "  outlier_gate_factor: 3.0\n"
      "  min_point_fraction: 0.1\n"
      "  min_marginalized_observations: 3\n"
      "backend:\n"
      "  marginalization: false\n"
      "  first_estimate_jacobians: true\n"
      "  prior_weight: 0.5\n"
      "  relative_eigenvalue_floor: 1e-6\n"
      "run:\n"
      "  deterministic: false\n",
      "all.yaml", io::DfoSchema());
  const WindowOptions w = apps::WindowOptionsFromConfig(config);
  EXPECT_EQ(w.max_keyframes, 5);
  EXPECT_EQ(w.pyramid_level, 2);
  EXPECT_EQ(w.patch_size, 5);
  EXPECT_EQ(w.points_per_keyframe, 123);
  EXPECT_EQ(w.loss, "cauchy");
  EXPECT_EQ(w.loss_scale, 0.75);
  EXPECT_EQ(w.linear_solver, "dense_schur");
  EXPECT_EQ(w.max_iterations, 4);
  EXPECT_EQ(w.max_solver_time_s, 0.05);
  EXPECT_EQ(w.min_inverse_depth, 0.01);
  EXPECT_EQ(w.depth_prior_weight, 0.5);
  EXPECT_EQ(w.pose_prior_weight, 0.25);
  EXPECT_EQ(w.outlier_gate_percentile, 0.8);
  EXPECT_EQ(w.outlier_gate_factor, 3.0);
  EXPECT_EQ(w.min_point_fraction, 0.1);
  EXPECT_EQ(w.min_marginalized_observations, 3);
  EXPECT_FALSE(w.marginalization);
  EXPECT_TRUE(w.first_estimate_jacobians);
  EXPECT_EQ(w.prior_weight, 0.5);
  EXPECT_EQ(w.relative_eigenvalue_floor, 1e-6);
}

TEST(BackendConfig, EveryKeyframeKeyReachesItsField) {
  const io::Config config = io::LoadConfigFromString(
      "keyframe:\n"
      "  decided_by: frontend\n"
      "  translation_ratio: 0.25\n"
      "  rotation_deg: 7.5\n"
      "  residual_ratio: 1.5\n"
      "  min_inlier_ratio: 0.3\n"
      "  min_interval: 2\n"
      "  max_interval: 6\n"
      "run:\n"
      "  mode: windowed\n",
      "all.yaml", io::DfoSchema());
  const KeyframeOptions k = apps::KeyframeOptionsFromConfig(config);
  EXPECT_EQ(k.translation_ratio, 0.25);
  EXPECT_EQ(k.rotation_deg, 7.5);
  EXPECT_EQ(k.residual_ratio, 1.5);
  EXPECT_EQ(k.min_inlier_ratio, 0.3);
  EXPECT_EQ(k.min_interval, 2);
  EXPECT_EQ(k.max_interval, 6);
  EXPECT_EQ(apps::ReferencePolicyFromConfig(config), "internal");
  EXPECT_EQ(apps::RunModeFromConfig(config), apps::RunMode::kWindowed);
}

// Contradicting keyframe settings are rejected at start-up with the key names.
TEST(BackendConfig, ContradictionsNameTheKeys) {
  const io::Config config = io::LoadConfigFromString(
      "keyframe:\n  min_interval: 12\n  max_interval: 10\n", "bad.yaml", io::DfoSchema());
  try {
    apps::KeyframeOptionsFromConfig(config);
    FAIL() << "no ConfigError for min_interval > max_interval";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe.min_interval = 12"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("keyframe.max_interval"), std::string::npos) << e.what();
  }
  // A ratio <= 0 is already outside the schema's range: the loader names file, key and line.
  EXPECT_THROW(
      io::LoadConfigFromString("keyframe:\n  translation_ratio: 0\n", "zero.yaml", io::DfoSchema()),
      ConfigError);
  EXPECT_THROW(apps::ParseRunMode("window"), ConfigError);
  EXPECT_STREQ(apps::RunModeName(apps::ParseRunMode("both")), "both");
}

TEST(BackendConfig, EveryShippedConfigGivesValidBackendOptions) {
  for (const char* name :
       {"default.yaml", "demo.yaml", "demo_learned.yaml", "kitti.yaml", "tum.yaml"}) {
    SCOPED_TRACE(name);
    const io::Config config =
        io::LoadConfig(test::SourceDir() + "/configs/" + name, io::DfoSchema());
    EXPECT_NO_THROW(apps::KeyframeOptionsFromConfig(config));
    EXPECT_NO_THROW(apps::RunModeFromConfig(config));
    EXPECT_NO_THROW(apps::WindowOptionsFromConfig(config));
  }
}

}  // namespace
}  // namespace dfo
