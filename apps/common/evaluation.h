// The apps' side of trajectory evaluation (the figures themselves:
// dfo_core/trajectory_evaluation.h): one function writes them as the JSON object of `dfo_eval traj
// --json` (also the `frontend` object of dfo_run's summary.json), one gives the text lines of the
// trajectory plot.
//
// Keys of the JSON object (numbers; NaN figures, e.g. KITTI on a path shorter than 100 m, are
// written as null):
//   num_poses, num_gt_poses, num_est_poses, format, alignment, scale,
//   ate_rmse, ate_mean, ate_median, ate_std, ate_min, ate_max,
//   rpe_delta, rpe_delta_unit, rpe_num_pairs, rpe_trans_rmse, rpe_trans_mean, rpe_rot_rmse_deg,
//   rpe_rot_mean_deg, kitti_num_segments, kitti_t_rel_pct, kitti_r_rel_deg_per_100m,
//   snippet_num, snippet_ate_mean, snippet_ate_std, scale_drift_segment_m, scale_drift_log_std,
//   scale_drift_min, scale_drift_max, scale_drift_ratios (50 m stretches), step_scale_frames,
//   step_scale_log_std, step_scale_min, step_scale_max, step_scale_ratios (20-frame stretches),
//   explained_spread (1 - ATE rmse^2 / the ground truth's spread^2),
//   ate_rmse_directions_only / ate_rmse_lengths_only (ComputeAteSplit: the ATE with the truth's
//   step lengths / step directions), warnings (EvaluationWarnings)
#ifndef DFO_APPS_COMMON_EVALUATION_H_
#define DFO_APPS_COMMON_EVALUATION_H_

#include <string>
#include <vector>

#include "dfo_core/metrics.h"
#include "dfo_core/trajectory_evaluation.h"
#include "dfo_io/json.h"

namespace dfo::apps {

// The `dfo_eval traj --json` object of an evaluation (keys in the file comment, in that order).
io::JsonValue EvaluationToJson(const TrajectoryEvaluation& evaluation);

// Two lines for a trajectory plot: ATE figures with the alignment, then RPE (and KITTI t_rel /
// r_rel when the path allows).
std::vector<std::string> EvaluationPlotLines(const TrajectoryEvaluation& evaluation);

// Name of an RPE delta unit as dfo_eval spells it: "frames" | "m".
std::string DeltaUnitName(DeltaUnit unit);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_EVALUATION_H_
