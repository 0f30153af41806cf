// Trajectory error metrics, each computed exactly as the public tool its figures are compared
// with:
//  - ATE (absolute trajectory error of positions): evo's APE, translation part (evo_ape).
//  - RPE (relative pose error) over a frame or a path-length delta: evo's RPE (evo_rpe).
//  - KITTI odometry t_rel (%) and r_rel (deg / 100 m): the KITTI devkit's evaluate_odometry.cpp.
//  - 5-frame snippet ATE: SfMLearner's kitti_eval compute_ate (as reported by SfMLearner, DFO...).
// All functions take an already associated and (where wanted) aligned pair of trajectories of
// equal size: pose i of the estimate corresponds to pose i of the ground truth (see alignment.h).
// A metric that cannot be computed (too short a trajectory) gives NaN figures, not an exception.
#ifndef DFO_CORE_METRICS_H_
#define DFO_CORE_METRICS_H_

#include <cstddef>
#include <utility>
#include <vector>

#include "dfo_core/alignment.h"
#include "dfo_core/trajectory.h"

namespace dfo {

// Summary statistics of a list of errors, as evo's PE.get_all_statistics(): rmse = sqrt(mean
// e^2), median averages the two middle values for an even count (numpy), std is the population
// standard deviation (numpy's default ddof = 0), sse = sum e^2. All NaN (count 0) when empty.
struct ErrorStatistics {
  size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;
  double std = 0.0;
  double min = 0.0;
  double max = 0.0;
  double sse = 0.0;
};

// Statistics of `errors` (see ErrorStatistics).
ErrorStatistics ComputeStatistics(const std::vector<double>& errors);

// Absolute trajectory error of positions.
struct AteResult {
  std::vector<double> errors;  // |p_est_i - p_gt_i| per pose, metres (world units)
  ErrorStatistics stats;
};

// ATE of positions (evo APE, PoseRelation.translation_part): the distance between the estimated
// and true camera positions of every pose. Align the estimate first (AlignTrajectory) to get
// evo_ape -a / -as figures. Throws InputError when the sizes differ.
AteResult ComputeAte(const Trajectory& ground_truth, const Trajectory& estimate);

// Unit of the RPE delta.
enum class DeltaUnit {
  kFrames,  // pose index distance
  kMeters,  // travelled path length (evo's Unit.meters: filter_pairs_by_path)
};

// Options of ComputeRpe; defaults are evo_rpe's.
struct RpeOptions {
  double delta = 1.0;  // > 0; a whole number for kFrames
  DeltaUnit delta_unit = DeltaUnit::kFrames;
  // Use every pair (i, i + delta) instead of consecutive pairs (0, d), (d, 2d), ... (evo
  // --all_pairs).
  bool all_pairs = false;
  // Relative tolerance on a metre delta in all-pairs mode (evo's rel_delta_tol), >= 0.
  double rel_delta_tol = 0.1;
  // Choose the pairs on the ground truth instead of the estimate (evo's --pairs_from_reference;
  // evo's default is the estimate).
  bool pairs_from_reference = false;
  // Throws ConfigError naming the field, its value and the rule.
  void Check() const;
};

// Relative pose errors, E_ij = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j) with Q the ground truth and P the
// estimate (evo's rpe_base, TUM RGB-D benchmark notation).
struct RpeResult {
  std::vector<std::pair<size_t, size_t>> pairs;  // the index pairs (i, j) compared
  std::vector<double> translation_errors;        // |t(E_ij)|, metres
  std::vector<double> rotation_errors_deg;       // angle of R(E_ij), degrees
  ErrorStatistics translation;                   // statistics of translation_errors
  ErrorStatistics rotation_deg;                  // statistics of rotation_errors_deg
};

// RPE as evo_rpe (translation_part and rotation_angle_deg). Pairs:
//  - kFrames, consecutive: ids 0, delta, 2 delta, ...; pairs of consecutive ids.
//  - kFrames, all pairs: (i, i + delta) for every i.
//  - kMeters, consecutive: evo's filter_pairs_by_path: walk the path, take an id each time the
//    path length since the last id reaches delta (the first id is where it first reaches delta,
//    not 0: an evo quirk kept so figures match); pairs of consecutive ids.
//  - kMeters, all pairs: for every i the j > i whose path length from i is nearest to delta,
//    kept when within delta * (1 +- rel_delta_tol).
// No pair (too short a trajectory) gives empty errors and NaN statistics. Throws InputError when
// the sizes differ, ConfigError on bad options.
RpeResult ComputeRpe(const Trajectory& ground_truth, const Trajectory& estimate,
                     const RpeOptions& options = {});

// Options of ComputeKittiOdometryErrors; defaults are the KITTI devkit's.
struct KittiOdometryOptions {
  // Segment lengths in metres of ground-truth path (devkit: 100, 200, ..., 800). Each > 0.
  std::vector<double> lengths_m = {100, 200, 300, 400, 500, 600, 700, 800};
  // A segment starts every step_frames frames (devkit: 10, one second at 10 Hz). > 0.
  int step_frames = 10;
  void Check() const;
};

// Errors of one segment length.
struct KittiLengthErrors {
  double length_m = 0.0;
  size_t num_segments = 0;
  double t_rel_pct = 0.0;           // mean translation error / length, percent; NaN if none
  double r_rel_deg_per_100m = 0.0;  // mean rotation error / length, deg per 100 m; NaN if none
};

// KITTI odometry benchmark errors.
struct KittiOdometryResult {
  size_t num_segments = 0;  // segments over all lengths and start frames
  double t_rel_pct = 0.0;   // average of t_err / length over all segments, x 100; NaN if none
  double r_rel_deg_per_100m = 0.0;  // average of r_err / length (rad/m) x 180/pi x 100; NaN if none
  std::vector<KittiLengthErrors> per_length;  // one entry per options.lengths_m
};

// t_rel / r_rel exactly as the KITTI devkit (evaluate_odometry.cpp calcSequenceErrors): path
// distances on the ground truth; for first frames 0, 10, 20, ... and each length L, the last
// frame is the first one whose path distance exceeds dist[first] + L (segments that do not fit are
// skipped); error pose E = (P_first^-1 P_last)^-1 (Q_first^-1 Q_last); t_err = |t(E)|,
// r_err = acos(clamp((trace(R(E)) - 1) / 2)); both divided by L and averaged over all segments
// (not per length). Double precision where the devkit uses float. Throws InputError when the sizes
// differ.
KittiOdometryResult ComputeKittiOdometryErrors(const Trajectory& ground_truth,
                                               const Trajectory& estimate,
                                               const KittiOdometryOptions& options = {});

// Options of ComputeSnippetAte; defaults are SfMLearner's.
struct SnippetAteOptions {
  int snippet_length = 5;  // frames per snippet, >= 2
  int stride = 1;          // start frames 0, stride, 2 stride, ...; >= 1
  void Check() const;
};

// Snippet ATE figures.
struct SnippetAteResult {
  std::vector<double> errors;  // one per snippet
  double mean = 0.0;           // NaN when no snippet fits
  double std = 0.0;            // population std (numpy), NaN when no snippet fits
};

// SfMLearner's snippet ATE (kitti_eval/pose_evaluation_utils.py compute_ate): every snippet of
// snippet_length consecutive frames is expressed relative to its first frame (positions of
// T_first^-1 T_k) for both trajectories; the estimate is offset so the first positions agree,
// one scale s = sum(gt . est) / sum(est . est) is fitted by least squares, and the error is
// sqrt(sum_k |s est_k - gt_k|^2) / N with N = snippet_length (not an RMSE: SfMLearner's quirk,
// kept so figures compare with the papers' tables). Independent of any global similarity applied
// to the estimate. A snippet whose estimate does not move uses s = 0 (numpy would give NaN).
// Throws InputError when the sizes differ.
SnippetAteResult ComputeSnippetAte(const Trajectory& ground_truth, const Trajectory& estimate,
                                   const SnippetAteOptions& options = {});

// Scale drift of a monocular estimate: on consecutive stretches of `segment_length_m` metres of
// ground-truth path (the last, shorter one left out), the estimate's path length over the ground
// truth's, both measured along chords between the poses where the ground truth has covered each
// fifth of a stretch (frame-to-frame jitter would otherwise lengthen the estimate's path). The estimate is used as given (already Sim3-aligned: one global scale), so ratios
// away from 1 are the scale wandering along the run; log_std is the population standard
// deviation of their logarithms (0 = no drift), NaN with fewer than 2 stretches, as min and max
// with none.
struct ScaleDriftResult {
  double segment_length_m = 0.0;  // ComputeScaleDrift's stretches (0 for ComputeStepScale's)
  int segment_frames = 0;         // ComputeStepScale's stretches (0 for ComputeScaleDrift's)
  std::vector<double> ratios;       // one per stretch
  std::vector<size_t> first_index;  // the pose each stretch starts at
  double log_std = 0.0;
  double min = 0.0;
  double max = 0.0;
};

// Throws InputError when the trajectories differ in size or segment_length_m is not > 0.
ScaleDriftResult ComputeScaleDrift(const Trajectory& ground_truth, const Trajectory& estimate,
                                   double segment_length_m = 50.0);

// The same ratios on consecutive stretches of `segment_frames` poses (the last, shorter one left
// out) instead of metres, for runs too short for 50 m stretches: the estimate's path length over
// the ground truth's along chords between every (segment_frames / 5)-th pose (at least every
// pose). A stretch whose ground truth does not move is left out (its ratio has no meaning).
// Throws InputError when the trajectories differ in size or segment_frames is not >= 1.
ScaleDriftResult ComputeStepScale(const Trajectory& ground_truth, const Trajectory& estimate,
                                  int segment_frames = 20);

// Where an estimate's ATE comes from. Its path is rebuilt step by step (pose i to i + 1) twice:
// with its own step directions and the ground truth's step lengths (`directions_rmse`: what the
// errors of heading and direction alone cost), and with its own step lengths along the ground
// truth's step directions (`lengths_rmse`: what the errors of the step lengths, a monocular
// run's scale drift, alone cost); each rebuilt path is aligned as `alignment` says and measured
// by its ATE rmse. A step whose direction source does not move is a step of zero. A figure whose
// rebuilt path cannot be aligned (collinear or coinciding positions) is NaN. Throws InputError
// when the sizes differ or fewer than 2 poses are given.
struct AteSplit {
  double directions_rmse = 0.0;  // the estimate's directions, the truth's step lengths
  double lengths_rmse = 0.0;     // the estimate's step lengths, the truth's directions
};
AteSplit ComputeAteSplit(const Trajectory& ground_truth, const Trajectory& estimate,
                         const TrajectoryAlignmentOptions& alignment);

}  // namespace dfo

#endif  // DFO_CORE_METRICS_H_
