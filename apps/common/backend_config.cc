#include "apps/common/backend_config.h"

#include "apps/common/frontend_config.h"
#include "dfo_core/error.h"

namespace dfo::apps {

const char* RunModeName(RunMode mode) { return OdometryModeName(mode); }

RunMode ParseRunMode(const std::string& value) {
  if (value == "frontend") return RunMode::kFrontend;
  if (value == "windowed") return RunMode::kWindowed;
  if (value == "both") return RunMode::kBoth;
  throw ConfigError("run.mode = " + value + " violates one of {frontend, windowed, both}");
}

RunMode RunModeFromConfig(const io::Config& config) {
  return ParseRunMode(config.GetString("run.mode"));
}

KeyframeOptions KeyframeOptionsFromConfig(const io::Config& config) {
  KeyframeOptions o;
  o.translation_ratio = config.GetDouble("keyframe.translation_ratio");
  o.rotation_deg = config.GetDouble("keyframe.rotation_deg");
  o.residual_ratio = config.GetDouble("keyframe.residual_ratio");
  o.min_inlier_ratio = config.GetDouble("keyframe.min_inlier_ratio");
  o.min_interval = config.GetInt("keyframe.min_interval");
  o.max_interval = config.GetInt("keyframe.max_interval");
  CheckInConfigTerms(config, [&] { o.Check(); });
  return o;
}

WindowOptions WindowOptionsFromConfig(const io::Config& config) {
  WindowOptions o;
  o.max_keyframes = config.GetInt("window.max_keyframes");
  o.pyramid_level = config.GetInt("window.pyramid_level");
  o.coarse_iterations = config.GetInt("window.coarse_iterations");
  o.patch_size = config.GetInt("window.patch_size");
  o.max_patch_stretch = config.GetDouble("window.max_patch_stretch");
  o.points_per_keyframe = config.GetInt("window.points_per_keyframe");
  o.loss = config.GetString("window.loss");
  o.loss_scale = config.GetDouble("window.loss_scale");
  o.linear_solver = config.GetString("window.linear_solver");
  o.max_iterations = config.GetInt("window.max_iterations");
  o.stop_step_px = config.GetDouble("window.stop_step_px");
  o.max_solver_time_s = config.GetDouble("window.max_solver_time_s");
  o.min_inverse_depth = config.GetDouble("window.min_inverse_depth");
  o.depth_prior_weight = config.GetDouble("window.depth_prior_weight");
  o.depth_prior_scale_fraction = config.GetDouble("window.depth_prior_scale_fraction");
  o.patch_depth_shape = config.GetBool("window.patch_depth_shape");
  o.zoom_blur_sigma_px = config.GetDouble("window.zoom_blur_sigma_px");
  o.zoom_scaled_gradients = config.GetBool("window.zoom_scaled_gradients");
  o.pose_prior_weight = config.GetDouble("window.pose_prior_weight");
  o.outlier_gate_percentile = config.GetDouble("window.outlier_gate_percentile");
  o.outlier_gate_factor = config.GetDouble("window.outlier_gate_factor");
  o.min_point_fraction = config.GetDouble("window.min_point_fraction");
  o.min_marginalized_observations = config.GetInt("window.min_marginalized_observations");
  o.max_depth_edge_slope = config.GetDouble("window.max_depth_edge_slope");
  o.depth_search_range = config.GetDouble("window.depth_search_range");
  o.depth_search_uniqueness = config.GetDouble("window.depth_search_uniqueness");
  o.searched_points_only = config.GetBool("window.searched_points_only");
  o.marginalization = config.GetBool("backend.marginalization");
  o.first_estimate_jacobians = config.GetBool("backend.first_estimate_jacobians");
  o.prior_weight = config.GetDouble("backend.prior_weight");
  o.relative_eigenvalue_floor = config.GetDouble("backend.relative_eigenvalue_floor");
  o.prior_scale_memory = config.GetDouble("backend.prior_scale_memory");
  o.num_threads = ThreadsFromConfig(config);
  o.evaluation_threads = o.num_threads;  // the result does not depend on it
  if (config.GetBool("run.deterministic")) {
    // Identical results run to run: one Ceres thread, and no wall-clock limit on a solve (where
    // a solve stops would depend on the machine's load); the iteration limit still holds.
    o.num_threads = 1;
    o.max_solver_time_s = kDeterministicSolverTimeS;
  }
  CheckInConfigTerms(config, [&] { o.Check(); });
  return o;
}

std::string ReferencePolicyFromConfig(const io::Config& config) {
  return config.GetString("keyframe.decided_by") == "manager" ? "external" : "internal";
}

TrackingDepthOptions TrackingDepthOptionsFromConfig(const io::Config& config) {
  TrackingDepthOptions o;
  o.depth = config.GetString("tracker.depth");
  o.fill = config.GetString("tracker.depth_fill");
  o.min_window_points = config.GetInt("tracker.min_window_points");
  o.splat_radius_px = config.GetInt("tracker.splat_radius_px");
  o.initial_depth_scale = config.GetString("window.initial_depth_scale");
  o.source_scale = config.GetString("window.source_scale");
  o.rescale_source_steps = config.GetBool("window.rescale_source_steps");
  CheckInConfigTerms(config, [&] { o.Check(); });
  return o;
}

KeyframeStereoOptions KeyframeStereoOptionsFromConfig(const io::Config& config) {
  KeyframeStereoOptions o;
  o.views = config.GetInt("stereo.views");
  o.depth_samples = config.GetInt("stereo.depth_samples");
  o.window_radius = config.GetInt("stereo.window_radius");
  o.min_epipolar_px = config.GetDouble("stereo.min_epipolar_px");
  o.max_cost = config.GetDouble("stereo.max_cost");
  o.uniqueness = config.GetDouble("stereo.uniqueness");
  o.max_source_ratio = config.GetDouble("stereo.max_source_ratio");
  o.num_threads = ThreadsFromConfig(config);  // the sweep's result does not depend on it
  CheckInConfigTerms(config, [&] { o.Check(); });
  return o;
}

OdometryOptions OdometryOptionsFromConfig(const io::Config& config) {
  OdometryOptions o;
  o.mode = RunModeFromConfig(config);
  o.keyframe = KeyframeOptionsFromConfig(config);
  o.window = WindowOptionsFromConfig(config);
  o.tracking = TrackingDepthOptionsFromConfig(config);
  o.stereo = KeyframeStereoOptionsFromConfig(config);
  // With the tracker on each keyframe's source depth the run's results do not depend on when a
  // solve finishes (OdometryOptions::backend_thread); with it on the window's depth they do.
  o.backend_thread = config.GetBool("run.backend_thread") &&
                     (!config.GetBool("run.deterministic") || o.tracking.depth == "source");
  CheckInConfigTerms(config, [&] { o.Check(); });
  return o;
}

}  // namespace dfo::apps
