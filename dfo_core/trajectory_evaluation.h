// Trajectory evaluation: every figure dfo reports for an estimate against its ground truth (ATE
// after Umeyama alignment, RPE, KITTI t_rel / r_rel, SfMLearner snippet ATE, scale drift over
// 50 m stretches and 20-frame steps, the ATE split into step directions and lengths), with the
// warnings that say when they mean less than they seem. dfo_eval traj and dfo_run report them
// (apps/common/evaluation.h writes them as JSON); a program embedding dfo::Odometry calls
// EvaluateTrajectory on its trajectories directly.
#ifndef DFO_CORE_TRAJECTORY_EVALUATION_H_
#define DFO_CORE_TRAJECTORY_EVALUATION_H_

#include <string>
#include <vector>

#include "dfo_core/alignment.h"
#include "dfo_core/metrics.h"
#include "dfo_core/trajectory.h"

namespace dfo {

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
// 1 - ATE rmse^2 / spread^2: the share of the ground truth's spread that the aligned estimate
// explains (NaN when the ground truth has no spread).
double ExplainedSpread(const TrajectoryEvaluation& evaluation);

// Aligns `estimate` onto `ground_truth` (already associated: equal sizes) and computes every
// metric on the aligned estimate. Throws InputError on different sizes, on degenerate or
// non-finite geometry (fewer than 3 poses, positions that coincide or lie on one line, a scale
// or an error beyond the double range; see UmeyamaAlignment and metrics.h), and ConfigError on
// bad RPE options: every figure of a returned evaluation is finite or NaN for "not computed".
TrajectoryEvaluation EvaluateTrajectory(const Trajectory& ground_truth, const Trajectory& estimate,
                                        const TrajectoryEvaluationOptions& options = {});

// "%.<decimals>f" of v ("%.<decimals>e" from 1e15 on), "n/a" when v is not finite.
std::string FormatFixed(double v, int decimals = 6);
// A Sim3 scale: as FormatFixed between 1e-3 and 1e6, else "%.<decimals>e" (a scale of 1e-150
// must not print as 0.000000).
std::string FormatScale(double scale, int decimals = 6);

}  // namespace dfo

#endif  // DFO_CORE_TRAJECTORY_EVALUATION_H_
