// Check() of the tracker, reference and frontend options.
#include <algorithm>
#include <cmath>
#include <string>

#include "dfo_core/check_option.h"
#include "dfo_frontend/frontend.h"
#include "dfo_frontend/reference_options.h"
#include "dfo_frontend/tracker.h"

namespace dfo {

using internal::CheckOption;

void TrackerOptions::Check() const {
  CheckOption(num_levels >= 1 && num_levels <= 8, "tracker.num_levels", num_levels, "in [1, 8]");
  CheckOption(patch_size >= 1 && patch_size <= 7, "tracker.patch_size", patch_size, "in [1, 7]");
  CheckOption(patch_size % 2 == 1, "tracker.patch_size", patch_size, "odd");
  CheckOption(max_points >= 1, "tracker.max_points", max_points, ">= 1");
  CheckOption(min_cell_px >= 1, "tracker.min_cell_px", min_cell_px, ">= 1");
  CheckOption(std::isfinite(min_gradient) && min_gradient >= 0.0, "tracker.min_gradient",
              min_gradient, ">= 0");
  CheckOption(std::isfinite(max_patch_depth_ratio) &&
                  (max_patch_depth_ratio == 0.0 || max_patch_depth_ratio > 1.0),
              "tracker.max_patch_depth_ratio", max_patch_depth_ratio, "0 (off) or > 1");
  CheckOption(!max_iterations.empty(), "tracker.max_iterations", "[]", "non-empty");
  for (size_t i = 0; i < max_iterations.size(); ++i) {
    CheckOption(max_iterations[i] >= 1, "tracker.max_iterations[" + std::to_string(i) + "]",
                max_iterations[i], ">= 1");
  }
  CheckOption(!convergence_threshold.empty(), "tracker.convergence_threshold", "[]", "non-empty");
  for (size_t i = 0; i < convergence_threshold.size(); ++i) {
    CheckOption(std::isfinite(convergence_threshold[i]) && convergence_threshold[i] > 0.0,
                "tracker.convergence_threshold[" + std::to_string(i) + "]",
                convergence_threshold[i], "> 0");
  }
  CheckOption(std::isfinite(rotation_hypotheses_deg) && rotation_hypotheses_deg >= 0.0 &&
                  rotation_hypotheses_deg <= 10.0,
              "tracker.rotation_hypotheses_deg", rotation_hypotheses_deg, "in [0, 10]");
  CheckOption(std::isfinite(hypothesis_abandon_ratio) && hypothesis_abandon_ratio > 1.0,
              "tracker.hypothesis_abandon_ratio", hypothesis_abandon_ratio, "> 1");
  CheckOption(std::isfinite(good_enough_rmse) && good_enough_rmse >= 0.0,
              "tracker.good_enough_rmse", good_enough_rmse, ">= 0");
  CheckOption(min_inliers_lost >= 0, "tracker.min_inliers_lost", min_inliers_lost, ">= 0");
  CheckOption(min_inliers_ok >= min_inliers_lost, "tracker.min_inliers_ok", min_inliers_ok,
              ">= tracker.min_inliers_lost (" + std::to_string(min_inliers_lost) + ")");
  CheckOption(std::isfinite(min_inlier_ratio_ok) && min_inlier_ratio_ok >= 0.0 &&
                  min_inlier_ratio_ok <= 1.0,
              "tracker.min_inlier_ratio_ok", min_inlier_ratio_ok, "in [0, 1]");
  CheckOption(std::isfinite(max_rmse_lost) && max_rmse_lost > 0.0, "tracker.max_rmse_lost",
              max_rmse_lost, "> 0");
  CheckOption(std::isfinite(max_rmse_ok) && max_rmse_ok > 0.0 && max_rmse_ok <= max_rmse_lost,
              "tracker.max_rmse_ok", max_rmse_ok,
              "in (0, tracker.max_rmse_lost (" + std::to_string(max_rmse_lost) + ")]");
}

int TrackerOptions::MaxIterations(int level) const {
  DFO_CHECK(!max_iterations.empty() && level >= 0) << level;
  return max_iterations[std::min<size_t>(level, max_iterations.size() - 1)];
}

double TrackerOptions::ConvergenceThreshold(int level) const {
  DFO_CHECK(!convergence_threshold.empty() && level >= 0) << level;
  return convergence_threshold[std::min<size_t>(level, convergence_threshold.size() - 1)];
}

void ReferenceOptions::Check() const {
  CheckOption(policy == "internal" || policy == "external", "reference.policy", policy,
              "one of {internal, external}");
  CheckOption(std::isfinite(translation_ratio) && translation_ratio > 0.0,
              "reference.translation_ratio", translation_ratio, "> 0");
  CheckOption(std::isfinite(rotation_deg) && rotation_deg > 0.0, "reference.rotation_deg",
              rotation_deg, "> 0");
  CheckOption(std::isfinite(min_inlier_ratio) && min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0,
              "reference.min_inlier_ratio", min_inlier_ratio, "in [0, 1]");
  CheckOption(max_interval >= 1, "reference.max_interval", max_interval, ">= 1");
}

void FrontendOptions::Check() const {
  CheckOption(features == "handmade" || features == "learned", "frontend.features", features,
              "one of {handmade, learned}");
  CheckOption(depth == "gt" || depth == "learned", "frontend.depth", depth, "one of {gt, learned}");
  CheckOption(depth_scale == "none" || depth_scale == "propagate", "frontend.depth_scale",
              depth_scale, "one of {none, propagate}");
  CheckOption(retrack_residual_ratio == 0.0 || retrack_residual_ratio >= 1.0,
              "frontend.retrack_residual_ratio", retrack_residual_ratio, "0 (off) or >= 1");
  CheckOption(num_threads >= 1, "frontend.num_threads", num_threads, ">= 1");
  // Nested options name their own section; prefix it with "frontend.".
  try {
    handmade.Check();
    tracker.Check();
    reference.Check();
  } catch (const ConfigError& e) {
    throw ConfigError(std::string("frontend.") + e.what());
  }
}

}  // namespace dfo
