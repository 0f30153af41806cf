#include "apps/common/evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

namespace dfo::apps {

std::string DeltaUnitName(DeltaUnit unit) { return unit == DeltaUnit::kFrames ? "frames" : "m"; }

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
