// Trajectory evaluation shared by the apps: one function computes every figure dfo reports for an
// estimate against its ground truth (ATE after Umeyama alignment, RPE, KITTI t_rel / r_rel,
// SfMLearner snippet ATE), one writes them as the JSON object of `dfo_eval traj --json` (also the
// `frontend` object of dfo_run's summary.json), one gives the text lines of the trajectory plot.
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

#include "dfo_core/alignment.h"
#include "dfo_core/metrics.h"
#include "dfo_core/trajectory.h"
#include "dfo_io/json.h"

namespace dfo::apps {

// What to compute.
struct TrajectoryEvaluationOptions {
  // Alignment of the estimate onto the ground truth before every metric (sim3 for monocular).
  AlignmentType alignment = AlignmentType::kSim3;
  // RPE pairs (evo_rpe's defaults: delta 1 frame, consecutive pairs).
  RpeOptions rpe;
};

// Every figure of one evaluation. The two trajectories it was computed from are associated
// (pose i of one corresponds to pose i of the other).
struct TrajectoryEvaluation {
  TrajectoryEvaluationOptions options;
  size_t num_gt_poses = 0;        // poses in the ground-truth input, before association
  size_t num_est_poses = 0;       // poses in the estimate input, before association
  std::string format;             // "kitti" | "tum" | "frames": where the pairing came from
  TrajectoryAlignment alignment;  // the fitted transform and the aligned estimate
  Trajectory ground_truth;        // the associated ground truth
  AteResult ate;
  RpeResult rpe;
  KittiOdometryResult kitti;
  SnippetAteResult snippet;
  ScaleDriftResult scale_drift;   // 50 m stretches
  ScaleDriftResult step_scale;    // 20-frame stretches (ComputeStepScale)
  AteSplit ate_split;             // ComputeAteSplit of the estimate as given
  double gt_path_length_m = 0.0;  // length of the ground-truth path (world units)
  // Poses of the estimate that were tracked (dfo_run: frames not lost; lost frames hold the last
  // good pose); 0 = not known (dfo_eval).
  size_t num_tracked_poses = 0;
};

// What makes an evaluation's figures mean less than they seem, one sentence each (dfo_eval and
// dfo_run print them on stderr; EvaluationToJson writes them as "warnings"):
// - a degenerate alignment: the aligned estimate explains less than kMinExplainedSpread of the
//   ground truth's spread (1 - ATE rmse^2 / spread^2, the spread being the RMS distance of the
//   ground-truth positions from their centroid). An estimate that barely moves, or moves
//   unrelated to the truth, is then fitted by a scale that can take any value (40 frames of noise:
//   a path of 4e-6 m, Sim3 scale 2.4e7, ATE 4.61 m) and its ATE says nothing about a motion;
// - an alignment that rests on less than kMinPoseShare of the estimated poses (the others found
//   no ground truth), or on poses of which less than kMinPoseShare were tracked.
constexpr double kMinExplainedSpread = 0.5;
constexpr double kMinPoseShare = 0.5;
std::vector<std::string> EvaluationWarnings(const TrajectoryEvaluation& evaluation);

// Aligns `estimate` onto `ground_truth` (already associated: equal sizes) and computes every
// metric on the aligned estimate. Throws InputError on different sizes, on degenerate or
// non-finite geometry (fewer than 3 poses, positions that coincide or lie on one line, a scale
// or an error beyond the double range; see UmeyamaAlignment and metrics.h), and ConfigError on
// bad RPE options: every figure of a returned evaluation is finite or NaN for "not computed".
TrajectoryEvaluation EvaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const TrajectoryEvaluationOptions& options = {});

// The `dfo_eval traj --json` object of an evaluation (keys in the file comment, in that order).
io::JsonValue EvaluationToJson(const TrajectoryEvaluation& evaluation);

// Two lines for a trajectory plot: ATE figures with the alignment, then RPE (and KITTI t_rel /
// r_rel when the path allows).
std::vector<std::string> EvaluationPlotLines(const TrajectoryEvaluation& evaluation);

// Name of an RPE delta unit as dfo_eval spells it: "frames" | "m".
std::string DeltaUnitName(DeltaUnit unit);

// "%.<decimals>f" of v ("%.<decimals>e" from 1e15 on), "n/a" when v is not finite.
std::string FormatFixed(double v, int decimals = 6);
// A Sim3 scale: as FormatFixed between 1e-3 and 1e6, else "%.<decimals>e" (a scale of 1e-150
// must not print as 0.000000).
std::string FormatScale(double scale, int decimals = 6);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_EVALUATION_H_
