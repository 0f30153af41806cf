#include "dfo_core/trajectory_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace dfo {

std::string FormatFixed(double v, int decimals) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  // Beyond 1e15 fixed notation is a wall of meaningless digits.
  std::snprintf(buf, sizeof(buf), std::abs(v) >= 1e15 ? "%.*e" : "%.*f", decimals, v);
  return buf;
}

std::string FormatScale(double scale, int decimals) {
  if (std::isfinite(scale) && scale != 0.0 && (std::abs(scale) < 1e-3 || std::abs(scale) >= 1e6)) {
    char buf[64];
    std::snprintf(buf, sizeof(buf), "%.*e", decimals, scale);
    return buf;
  }
  return FormatFixed(scale, decimals);
}

TrajectoryEvaluation EvaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const TrajectoryEvaluationOptions& options) {
  TrajectoryEvaluation e;
  e.options = options;
  e.num_gt_poses = ground_truth.size();
  e.num_est_poses = estimate.size();
  e.format = "frames";
  TrajectoryAlignmentOptions align;
  align.type = options.alignment;
  // Every metric uses the aligned estimate, as evo_ape / evo_rpe with -a / -as do.
  e.alignment = AlignTrajectory(estimate, ground_truth, align);
  e.ground_truth = ground_truth;
  const Trajectory& aligned = e.alignment.aligned_estimate;
  e.ate = ComputeAte(ground_truth, aligned);
  e.rpe = ComputeRpe(ground_truth, aligned, options.rpe);
  e.kitti = ComputeKittiOdometryErrors(ground_truth, aligned);
  e.snippet = ComputeSnippetAte(ground_truth, aligned);
  e.scale_drift = ComputeScaleDrift(ground_truth, aligned);
  e.step_scale = ComputeStepScale(ground_truth, aligned);
  e.ate_split = ComputeAteSplit(ground_truth, estimate, align);
  e.gt_path_length_m = ground_truth.PathLength();
  return e;
}

namespace {

// RMS distance of the positions from their centroid.
double Spread(const Trajectory& t) {
  if (t.empty()) return 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < t.size(); ++i) centroid += t[i].world_from_cam.translation();
  centroid /= static_cast<double>(t.size());
  double sum = 0.0;
  for (size_t i = 0; i < t.size(); ++i) {
    sum += (t[i].world_from_cam.translation() - centroid).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(t.size()));
}

}  // namespace

double ExplainedSpread(const TrajectoryEvaluation& e) {
  const double spread = Spread(e.ground_truth);
  if (!(spread > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return 1.0 - (e.ate.stats.rmse * e.ate.stats.rmse) / (spread * spread);
}

std::vector<std::string> EvaluationWarnings(const TrajectoryEvaluation& e) {
  std::vector<std::string> warnings;
  const double explained = ExplainedSpread(e);
  if (std::isfinite(explained) && explained < kMinExplainedSpread) {
    warnings.push_back("degenerate alignment: the aligned estimate explains " +
                       FormatFixed(100.0 * std::max(explained, 0.0), 0) +
                       " % of the ground truth's spread (ATE rmse " +
                       FormatFixed(e.ate.stats.rmse, 4) + " against a spread of " +
                       FormatFixed(Spread(e.ground_truth), 4) + ", " +
                       AlignmentTypeName(e.options.alignment) + " scale " +
                       FormatScale(e.alignment.transform.scale, 4) + ", estimated path " +
                       FormatScale(e.alignment.aligned_estimate.PathLength() /
                                       std::max(e.alignment.transform.scale, 1e-300),
                                   4) +
                       "): an estimate that barely moves or moves unlike the truth; its figures "
                       "say little");
  }
  const size_t used = e.ground_truth.size();
  if (e.num_est_poses > 0 && used < kMinPoseShare * static_cast<double>(e.num_est_poses)) {
    warnings.push_back("the alignment rests on " + std::to_string(used) + " of the " +
                       std::to_string(e.num_est_poses) +
                       " estimated poses (the others have no ground truth)");
  }
  if (e.num_tracked_poses > 0 && e.num_tracked_poses < kMinPoseShare * static_cast<double>(used)) {
    warnings.push_back("only " + std::to_string(e.num_tracked_poses) + " of the " +
                       std::to_string(used) +
                       " evaluated poses were tracked (the others are lost frames holding the "
                       "last good pose)");
  }
  return warnings;
}

}  // namespace dfo
