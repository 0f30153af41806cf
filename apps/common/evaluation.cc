#include "apps/common/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace dfo::apps {

std::string DeltaUnitName(DeltaUnit unit) { return unit == DeltaUnit::kFrames ? "frames" : "m"; }

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

// 1 - ATE rmse^2 / spread^2: the share of the ground truth's spread the aligned estimate explains.
double ExplainedSpread(const TrajectoryEvaluation& e) {
  const double spread = Spread(e.ground_truth);
  if (!(spread > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return 1.0 - (e.ate.stats.rmse * e.ate.stats.rmse) / (spread * spread);
}

}  // namespace

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

io::JsonValue EvaluationToJson(const TrajectoryEvaluation& e) {
  io::JsonValue out = io::JsonValue::Object();
  out.Set("num_poses", static_cast<int64_t>(e.ground_truth.size()));
  out.Set("num_gt_poses", static_cast<int64_t>(e.num_gt_poses));
  out.Set("num_est_poses", static_cast<int64_t>(e.num_est_poses));
  out.Set("format", e.format);
  out.Set("alignment", AlignmentTypeName(e.options.alignment));
  out.Set("scale", e.alignment.transform.scale);
  out.Set("ate_rmse", e.ate.stats.rmse);
  out.Set("ate_mean", e.ate.stats.mean);
  out.Set("ate_median", e.ate.stats.median);
  out.Set("ate_std", e.ate.stats.std);
  out.Set("ate_min", e.ate.stats.min);
  out.Set("ate_max", e.ate.stats.max);
  out.Set("rpe_delta", e.options.rpe.delta);
  out.Set("rpe_delta_unit", DeltaUnitName(e.options.rpe.delta_unit));
  out.Set("rpe_num_pairs", static_cast<int64_t>(e.rpe.pairs.size()));
  out.Set("rpe_trans_rmse", e.rpe.translation.rmse);
  out.Set("rpe_trans_mean", e.rpe.translation.mean);
  out.Set("rpe_rot_rmse_deg", e.rpe.rotation_deg.rmse);
  out.Set("rpe_rot_mean_deg", e.rpe.rotation_deg.mean);
  out.Set("kitti_num_segments", static_cast<int64_t>(e.kitti.num_segments));
  out.Set("kitti_t_rel_pct", e.kitti.t_rel_pct);
  out.Set("kitti_r_rel_deg_per_100m", e.kitti.r_rel_deg_per_100m);
  out.Set("snippet_num", static_cast<int64_t>(e.snippet.errors.size()));
  out.Set("snippet_ate_mean", e.snippet.mean);
  out.Set("snippet_ate_std", e.snippet.std);
  out.Set("scale_drift_segment_m", e.scale_drift.segment_length_m);
  out.Set("scale_drift_log_std", e.scale_drift.log_std);
  out.Set("scale_drift_min", e.scale_drift.min);
  out.Set("scale_drift_max", e.scale_drift.max);
  const auto array = [](const std::vector<double>& values) {
    io::JsonValue a = io::JsonValue::Array();
    for (double v : values) a.Push(io::JsonValue(v));
    return a;
  };
  out.Set("scale_drift_ratios", array(e.scale_drift.ratios));
  out.Set("step_scale_frames", static_cast<int64_t>(e.step_scale.segment_frames));
  out.Set("step_scale_log_std", e.step_scale.log_std);
  out.Set("step_scale_min", e.step_scale.min);
  out.Set("step_scale_max", e.step_scale.max);
  out.Set("step_scale_ratios", array(e.step_scale.ratios));
  out.Set("explained_spread", ExplainedSpread(e));
  out.Set("ate_rmse_directions_only", e.ate_split.directions_rmse);
  out.Set("ate_rmse_lengths_only", e.ate_split.lengths_rmse);
  io::JsonValue warnings = io::JsonValue::Array();
  for (const std::string& w : EvaluationWarnings(e)) warnings.Push(w);
  out.Set("warnings", std::move(warnings));
  return out;
}

std::vector<std::string> EvaluationPlotLines(const TrajectoryEvaluation& e) {
  std::vector<std::string> lines;
  lines.push_back("ATE rmse " + FormatFixed(e.ate.stats.rmse, 4) + " m, mean " +
                  FormatFixed(e.ate.stats.mean, 4) + " m, max " + FormatFixed(e.ate.stats.max, 4) +
                  " m   (" + std::to_string(e.ground_truth.size()) + " poses, " +
                  AlignmentTypeName(e.options.alignment) + " alignment, scale " +
                  FormatScale(e.alignment.transform.scale, 4) + ")");
  const bool frames = e.options.rpe.delta_unit == DeltaUnit::kFrames;
  std::string line2 = "RPE (" + FormatFixed(e.options.rpe.delta, frames ? 0 : 3) + " " +
                      DeltaUnitName(e.options.rpe.delta_unit) + ") rmse " +
                      FormatFixed(e.rpe.translation.rmse, 4) + " m, " +
                      FormatFixed(e.rpe.rotation_deg.rmse, 4) + " deg";
  if (e.kitti.num_segments > 0) {
    line2 += "   KITTI t_rel " + FormatFixed(e.kitti.t_rel_pct, 2) + " %, r_rel " +
             FormatFixed(e.kitti.r_rel_deg_per_100m, 3) + " deg/100m";
  }
  lines.push_back(line2);
  return lines;
}

}  // namespace dfo::apps
