#include "apps/common/frontend_config.h"

#include <algorithm>
#include <thread>

namespace dfo::apps {

int ThreadsFromConfig(const io::Config& config) {
  const int threads = config.GetInt("run.threads");
  if (threads > 0) return threads;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

FrontendOptions FrontendOptionsFromConfig(const io::Config& config, bool dataset_has_depth) {
  FrontendOptions o;
  o.features = config.GetString("frontend.features");
  o.depth = config.GetString("frontend.depth");
  if (o.depth == "auto") o.depth = dataset_has_depth ? "gt" : "learned";
  o.handmade.descriptor = config.GetString("frontend.handmade_descriptor");
  o.handmade.blur_sigma_px = config.GetDouble("frontend.handmade_blur_sigma_px");
  o.handmade.keyframe_blur_sigma_px = config.GetDouble("frontend.handmade_keyframe_blur_sigma_px");
  o.depth_scale = config.GetString("frontend.depth_scale");
  o.retrack_on_loss = config.GetBool("frontend.retrack_on_loss");
  o.retrack_residual_ratio = config.GetDouble("frontend.retrack_residual_ratio");

  TrackerOptions& t = o.tracker;
  t.num_levels = config.GetInt("tracker.num_levels");
  t.patch_size = config.GetInt("tracker.patch_size");
  t.max_points = config.GetInt("tracker.max_points");
  t.min_cell_px = config.GetInt("tracker.min_cell_px");
  t.min_gradient = config.GetDouble("tracker.min_gradient");
  t.max_patch_depth_ratio = config.GetDouble("tracker.max_patch_depth_ratio");
  t.max_iterations = config.GetIntList("tracker.max_iterations");
  t.convergence_threshold = config.GetDoubleList("tracker.convergence_threshold");
  t.outlier_rule = config.GetBool("tracker.outlier_rule");
  t.rotation_hypotheses_deg = config.GetDouble("tracker.rotation_hypotheses_deg");
  t.hypothesis_abandon_ratio = config.GetDouble("tracker.hypothesis_abandon_ratio");
  t.good_enough_rmse = config.GetDouble("tracker.good_enough_rmse");
  t.min_inliers_ok = config.GetInt("tracker.min_inliers_ok");
  t.min_inlier_ratio_ok = config.GetDouble("tracker.min_inlier_ratio_ok");
  t.max_rmse_ok = config.GetDouble("tracker.max_rmse_ok");
  t.min_inliers_lost = config.GetInt("tracker.min_inliers_lost");
  t.max_rmse_lost = config.GetDouble("tracker.max_rmse_lost");

  ReferenceOptions& r = o.reference;
  r.translation_ratio = config.GetDouble("reference.translation_ratio");
  r.rotation_deg = config.GetDouble("reference.rotation_deg");
  r.min_inlier_ratio = config.GetDouble("reference.min_inlier_ratio");
  r.max_interval = config.GetInt("reference.max_interval");

  o.num_threads = ThreadsFromConfig(config);
  CheckInConfigTerms(config, [&] { o.Check(); });
  return o;
}

void CheckInConfigTerms(const io::Config& config, const std::function<void()>& check) {
  try {
    check();
  } catch (const ConfigError& e) {
    const std::string message = e.what();
    const std::string key = message.substr(0, message.find(' '));
    // The library nests sections ("frontend.tracker.", "odometry.window."): the configuration's
    // key is the longest tail of the path that the schema declares.
    for (size_t at = 0; at != std::string::npos; at = key.find('.', at + 1)) {
      const std::string tail = at == 0 ? key : key.substr(at + 1);
      if (config.schema().Find(tail) == nullptr) continue;
      throw ConfigError(tail + message.substr(key.size()) + " (" + config.Source(tail) + ")");
    }
    throw;
  }
}

}  // namespace dfo::apps
