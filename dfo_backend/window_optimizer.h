// The sliding window of keyframes with feature-metric bundle adjustment and marginalisation
// (issue 5; DESIGN.md, backend: DSO's window and marginalisation policy, VINS-Mono's Ceres prior,
// PixSfM's feature-metric cost).
//
//   WindowOptimizer window(options);
//   for each new keyframe (from the frontend):
//     WindowResult result = window.AddKeyframe(std::move(keyframe_data));
//     // result.keyframe_poses: every window keyframe's optimised world_from_cam;
//     // result.marginalized_frame_index / marginalized_pose: the keyframe that left, if any.
//
// What one AddKeyframe does:
//  1. Select up to points_per_keyframe points in the new keyframe at pyramid_level (mask pixels
//     if the level has a mask, else high feature gradient, one per grid cell, spread over the
//     image), each with one inverse depth from the keyframe's depth (pixels without a valid
//     depth, and with max_depth_edge_slope pixels on a depth edge, are skipped); create a
//     residual block (dfo_backend/feature_metric_cost.h) from every point to every other window
//     keyframe in which its patch is visible at a similar scale (max_patch_stretch), old points
//     included. With searched_points_only the selected points are candidates instead, and
//     every candidate in the window (this keyframe's and the earlier ones') enters only when a
//     search along its epipolar lines in the other keyframes finds its depth (see the option).
//  2. Solve with Ceres (each block as its 7-row CompressedFeatureMetricCost: the same cost,
//     gradient and normal equations): poses on the SE(3) manifold (pose_manifold.h), the oldest
//     keyframe held constant (gauge), inverse depths bounded below by min_inverse_depth
//     (projected after each solve), Huber or Cauchy loss, points eliminated first, optional
//     priors; then drop, per target keyframe, the blocks whose cost exceeds outlier_gate_factor x
//     the outlier_gate_percentile cost of that keyframe, and solve once more. A solve that fails
//     or ends with a non-finite cost restores the state it started from (result.optimized =
//     false, result.message says why).
//  3. If the window holds more than max_keyframes, one keyframe leaves (never the newest two):
//     the oldest with fewer than min_point_fraction of its selected points still observed in
//     the newest keyframe, else DSO's distance
//     choice (far from the newest, close to the others). Its points with at least
//     min_marginalized_observations blocks are marginalised into a prior on the kept poses, its
//     other points are dropped, blocks of other points into it are dropped
//     (dfo_backend/marginalization.h). marginalization = false only drops.
// Memory is bounded: at most max_keyframes + 1 keyframes, points_per_keyframe points (or
// candidates) each and one block per (point, other keyframe) exist at any time.
#ifndef DFO_BACKEND_WINDOW_OPTIMIZER_H_
#define DFO_BACKEND_WINDOW_OPTIMIZER_H_

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dfo_core/keyframe.h"
#include "dfo_core/lie.h"

namespace ceres {
class LossFunction;
}

namespace dfo {

class LinearPriorCost;
class SE3Manifold;

// Settings of the window (YAML sections "window" and, for the marginalisation switches,
// "backend"). Check() names the key: "window.max_keyframes = 3 violates >= 5".
struct WindowOptions {
  // Keyframes kept in the window after each step; >= 5 (DSO uses 5-7; issue: default 7).
  int max_keyframes = 7;
  // Pyramid level of the feature and depth maps the BA works on (0 = finest); >= 0 and less than
  // the number of levels of every keyframe.
  int pyramid_level = 0;
  // Levenberg-Marquardt iterations of a warm-up solve on the next coarser level
  // (pyramid_level + 1) before each keyframe's solve, in which only the newest keyframe's pose
  // and the inverse depths of its points move; 0 = none; >= 0. Coarser gradients reach further
  // (a wider basin for a new keyframe the frontend got less right); the solve at pyramid_level
  // that follows removes the coarse level's bias. Needs keyframes with that level. Off by default:
  // with the frontend's keyframe poses (about 1 cm off) it hurt (demo sequence, ground-truth
  // depth: windowed Sim3 ATE 1.53 m with 3 iterations against 0.30 m without), because the fine
  // solve's few iterations do not fully undo the coarse level's pull; it widens the basin for
  // poses that start far off (WindowOptimizerTest.PerturbedPosesAndDepthsReturnToGroundTruth).
  int coarse_iterations = 0;
  // Side K of the square feature patch per point, pixels at pyramid_level; odd, in [1, 9].
  int patch_size = 3;
  // Depth edges: a pixel is not selected as a point when the depth across its 3 x 3
  // neighbourhood (pyramid_level) changes faster than this, as the relative change
  // (largest / smallest - 1) per radian of viewing angle (the neighbourhood spans 2 / fx rad), so
  // that a scene gives the same points at any resolution (6: 5 % across the neighbourhood at
  // fx = 240 px, 10 % at 120 px). Its feature there mixes surfaces at different depths, whose
  // parallax differs, so no single inverse depth explains it in every keyframe; a true depth map
  // also gives it one side's depth at random. Surfaces seen at a grazing angle (the near road) go
  // too. Per-pixel depth noise of a few percent reads as edges everywhere
  // (WindowResult::depth_edge_fraction near 1): turn it off for such depth. Chosen over real and
  // synthetic video, true and learned depth (docs/window.md, "Points on depth edges"). 0 = off,
  // else > 0.
  double max_depth_edge_slope = 6.0;
  // A block is created only where the target sees the patch at a similar scale: both singular
  // values of the warp's derivative (feature_metric_cost.h, WarpStretch) within
  // [1 / max_patch_stretch, max_patch_stretch]. Features compared at different scales disagree
  // systematically (each pixel integrates a different footprint of the surface; blurs and
  // pyramid levels act in pixels), which biased the window's optimum by decimetres with forward
  // motion. The gate is applied once, when a block would be created (at the poses and inverse
  // depths of that moment: the new keyframe's from the frontend, the others' from the window). It
  // also leaves out the near points' long links, the strongest parallax, so the basin is
  // narrower (tests/backend/window_optimizer_test.cc); measured on 5 synthetic sequences it
  // helps with learned and true depth and makes the BA ~1.5x faster (docs/window.md). > 1 (a large
  // value turns the gate off).
  double max_patch_stretch = 1.5;
  // Points selected per keyframe; in [1, 100000]. 150 (7 keyframes: about 1,000 points in the
  // window; DSO's real-time setting keeps 800 at 424 x 320): over 8 synthetic sequences about as
  // accurate with learned depth as 300 (1-3%), 24-25% worse with true depth, half the BA time
  // (docs/window.md).
  int points_per_keyframe = 150;
  // Warp each point's patch as the surface of its keyframe's depth map (every patch pixel at the
  // map's depth relative to the centre's, scaled with the point's inverse depth) instead of as a
  // fronto-parallel plane at the centre's depth; factors outside [1/2, 2] or at invalid depths
  // are clamped or set to 1.
  bool patch_depth_shape = false;
  // Blur, in pixels, that the features already carry (the hand-made features' blur_sigma_px),
  // for comparing a patch seen at two scales at the same blur on the surface: where the target
  // sees a patch zoomed by s > 1 (the geometric mean of WarpStretch when the block is made), the
  // block samples the target's features blurred by a further zoom_blur_sigma_px sqrt(s^2 - 1)
  // (from a ladder of zooms 1.1, 1.2, ... up to max_patch_stretch, the nearest below s); where
  // s < 1 the host patch is sampled from the host blurred likewise for 1 / s. 0 = off.
  double zoom_blur_sigma_px = 0.0;
  // Compare gradient channels at the same steepness on the surface: where a block's target sees
  // the patch zoomed by s (the geometric mean of WarpStretch when the block is made), the host
  // patch's channels of derivative order n (FeatureLevel::derivative_order; the hand-made
  // features' x/y gradients and gradient magnitude) are scaled by s^-n, as the target sees them.
  // Features without derivative orders (learned) are unchanged.
  bool zoom_scaled_gradients = false;
  // Robust loss on each block: "huber" or "cauchy".
  std::string loss = "huber";
  // Scale of the loss per feature value: the Ceres loss parameter is loss_scale * sqrt(C K^2),
  // so a block whose RMS residual (z-scored feature units) is below loss_scale is quadratic
  // (Huber); > 0.
  double loss_scale = 0.5;
  // Ceres linear solver: "sparse_schur" (SuiteSparse) or "dense_schur".
  std::string linear_solver = "sparse_schur";
  // Levenberg-Marquardt iterations of the first solve per keyframe; the second solve (after the
  // outlier gate) gets half as many, at least 1. >= 1. The window is re-solved at every
  // keyframe, so few iterations per step add up (DSO: 1-6 Gauss-Newton iterations per keyframe).
  // Measured on 8 synthetic sequences: 2 as accurate as 3 (docs/window.md).
  int max_iterations = 2;
  // A solve stops when its last accepted Levenberg-Marquardt step moved the keyframes by less
  // than this in the image: the RMS over the free keyframes of fx * (rotation angle + translation
  // * mean inverse depth of the window's points), pixels at pyramid_level (DSO's rule, which
  // compares the rotation and the depth-normalised translation of a step with fixed thresholds,
  // here in pixels so that it holds at any resolution). 0 = off (only Ceres's tolerances and
  // max_iterations stop a solve); >= 0.
  double stop_step_px = 0.0;
  // Wall-time limit of one solve in seconds; > 0.
  double max_solver_time_s = 0.1;
  // Ceres threads; >= 1 (1 gives run-to-run identical results).
  int num_threads = 2;
  // Threads that evaluate the feature-metric blocks before each of Ceres's evaluations (through
  // a ceres::EvaluationCallback; Ceres then copies each block's result). Every block is
  // evaluated alone, so the results do not depend on this number: run-to-run identical with
  // num_threads = 1. 1 = Ceres evaluates the blocks itself. >= 1.
  int evaluation_threads = 2;
  // Lower bound of every inverse depth in 1/m (1e-3: points may lie up to 1 km away), enforced
  // by projection after each solve; >= 0.
  double min_inverse_depth = 1e-3;
  // Weight of the prior pulling each inverse depth toward its keyframe depth, on the relative
  // error (rho - rho0) / rho0; >= 0 (0 = off). Also fixes the scale gauge when > 0.
  double depth_prior_weight = 0.0;
  // Share of the depth prior's information that concerns each keyframe's overall depth scale,
  // in [0, 1]. 1: every inverse depth is pulled toward its keyframe's depth as it is (the sum of
  // the relative errors' squares). Below 1 the prior depths of each keyframe share a free scale
  // exp(s_k), rho -> rho0 exp(s_k), and s_k has its own prior sqrt(W_k) s_k with W_k = f / (1 - f)
  // w N_k (N_k: the keyframe's points in the solve), so that after eliminating s_k the prior on
  // the keyframe's mean log depth keeps the fraction f of its weight w N_k while the shape part
  // (the deviations from the mean) keeps all of it. 0: shape only, the scale is left to the
  // geometry. A marginalised keyframe's points keep their prior toward rho0 exp(s_k) at its last
  // s_k.
  double depth_prior_scale_fraction = 1.0;
  // Weight of the prior pulling the relative pose of consecutive window keyframes toward the
  // frontend's, on [2 vec(q_err) (rad); t_err (m)]; >= 0 (0 = off).
  double pose_prior_weight = 0.0;
  // Per-frame outlier gate after the first solve: a block is dropped when its cost exceeds
  // outlier_gate_factor x the outlier_gate_percentile quantile of the block costs of the same
  // target keyframe; percentile in (0, 1], factor >= 1.
  double outlier_gate_percentile = 0.9;
  double outlier_gate_factor = 2.0;
  // A keyframe with fewer than this fraction of its selected points observed in the newest
  // keyframe leaves first (DSO: 5%); in [0, 1].
  double min_point_fraction = 0.05;
  // Points of the leaving keyframe with at least this many residual blocks are marginalised, the
  // rest dropped; >= 1.
  int min_marginalized_observations = 2;
  // Depth search of new points (DSO's epipolar search of immature points, done in the window's
  // keyframes, whose poses are known): a point tries inverse depths from rho0 / depth_search_range
  // to rho0 * depth_search_range (rho0: from the keyframe's depth), one step per pixel of travel
  // along its epipolar line in the target with the longest line, and the sum over its blocks of
  // the robustified feature-metric cost picks the best; the search finds the depth when that best
  // is unique (the lowest cost at least depth_search_uniqueness times below every other local
  // minimum more than 2 steps away) and the line is at least 2 px long. The search trusts the
  // keyframes' current poses (a new keyframe's from tracking). depth_search_range: 1 = off, else
  // in (1, 10]; depth_search_uniqueness >= 1.
  //   searched_points_only false: a new keyframe's points enter the window at once, searched
  //     against the keyframes already in it before the solve; those whose depth the search finds
  //     start there, the others at rho0.
  //   searched_points_only true (needs the search): a keyframe's selected points are candidates,
  //     not in the problem. At every AddKeyframe (the host's own and each later one while it
  //     stays) each candidate is searched against every other window keyframe, older and newer,
  //     and enters at the depth found; an ambiguous search narrows its interval to the span of
  //     the competing minima for the next keyframe; candidates leave with their host. No point
  //     enters at a depth parallax has not confirmed (docs/tracking_against_the_window.md,
  //     "Points that enter with their depth found": it removes KITTI 03's collapse at 616 x 184
  //     and loses on KITTI 00 and 06).
  double depth_search_range = 2.0;
  double depth_search_uniqueness = 2.0;
  bool searched_points_only = false;
  // backend.marginalization: marginalise into a prior (true) or only drop (false).
  bool marginalization = true;
  // backend.first_estimate_jacobians: the prior's Jacobian stays the one at its linearisation
  // point, and factors of prior-connected poses are linearised at their first estimates.
  // Experimental: measured harmful on the synthetic bench (dfo_bench_backend --fej), because a
  // feature-metric Jacobian taken at a first-estimate projection samples the image gradient at
  // the wrong pixel (DSO keeps only the geometric part at the first estimate); keep it off.
  bool first_estimate_jacobians = false;
  // backend.prior_weight: weight of the marginalisation prior in each solve, in (0, 1]
  // (< 1 softens the inconsistency of relinearising prior-connected poses).
  double prior_weight = 1.0;
  // backend.relative_eigenvalue_floor: eigenvalues of the prior below this fraction of the
  // largest are dropped; in (0, 1).
  double relative_eigenvalue_floor = 1e-8;
  // backend.prior_scale_memory, in [0, 1]: with a depth prior (depth_prior_weight > 0) the scale
  // is observable, and the information the leaving keyframe's points' depth priors give about it
  // stays in the marginalisation prior multiplied by this factor at each marginalisation (the
  // scale direction's component of the projection is kept at sqrt of it), so older keyframes'
  // scale is forgotten geometrically; 0 removes the scale with the gauge at every
  // marginalisation (DSO's 7 directions), 1 keeps all of it. Without a depth prior the scale is
  // always removed.
  double prior_scale_memory = 0.0;

  // Throws ConfigError naming the key, its value and the rule.
  void Check() const;
};

// Zooms whose blurred features each keyframe keeps when WindowOptions::zoom_blur_sigma_px > 0:
// 1.1, 1.2, ... up to max_stretch (WindowOptions::max_patch_stretch), at most 30.
std::vector<double> WindowZoomLadder(double max_stretch);

// A point's depth as the window holds it, with what it rests on (WindowOptimizer::HostedPoints):
// the depth a keyframe's points settled on, e.g. to teach a depth network.
struct SettledPoint {
  // Pixel in the host keyframe at pyramid level 0 (pixel centres at integers; the window works at
  // WindowOptions::pyramid_level, whose pixel x is (x + 0.5) 2^level - 0.5 here).
  double u = 0.0, v = 0.0;
  double depth_m = 0.0;        // the window's estimate, at the window's scale
  double start_depth_m = 0.0;  // where it entered the window (the keyframe's depth map, scaled)
  // Residual blocks: the other window keyframes it is compared in now (after the outlier gate).
  int observations = 0;
  // RMS of those blocks' residuals per feature value (z-score units) at the current estimate.
  double rms_residual = 0.0;
};

// What one AddKeyframe did.
struct WindowResult {
  // True when a BA ran and its result was kept; false when it failed or diverged (the state
  // before the solve was kept, `message` says why) or there was nothing to optimise (fewer than
  // two keyframes).
  bool optimized = false;
  // Why optimized is false, and warnings (e.g. a rejected marginalisation prior); "" if none.
  std::string message;
  // (frame_index, world_from_cam) of every keyframe in the window after this step, oldest first.
  std::vector<std::pair<int, SE3d>> keyframe_poses;
  // The keyframe that left the window in this step (-1: none) and its final pose.
  int marginalized_frame_index = -1;
  SE3d marginalized_pose;
  // True when its information went into the marginalisation prior; false when it was dropped
  // (backend.marginalization false, or a prior that was rejected).
  bool marginalized_into_prior = false;
  // The points it hosted as they were when it left (HostedPoints just before).
  std::vector<SettledPoint> marginalized_points;
  // Ceres cost (0.5 sum of robustified squared residuals) before the first and after the last
  // solve.
  double initial_cost = 0.0;
  double final_cost = 0.0;
  // Window size after this step.
  int num_points = 0;
  int num_residual_blocks = 0;
  // Levenberg-Marquardt iterations of this step's solves (both, around the outlier gate), and
  // whether every one of them ended by Ceres's convergence tolerances (function, gradient or
  // parameter tolerance) or by WindowOptions::stop_step_px rather than at
  // window.max_iterations or the time limit.
  int num_iterations = 0;
  bool converged = false;
  // Whether a solve of this step stopped at window.max_solver_time_s (before its iteration cap
  // and Ceres's tolerances): its result then depends on the machine's speed and load.
  bool time_limited = false;
  // Image motion of the last accepted step of the last solve (WindowOptions::stop_step_px's
  // measure, pixels at pyramid_level); 0 when no step was accepted.
  double last_step_px = 0.0;
  // Number of blocks the outlier gate dropped.
  int num_gated_blocks = 0;
  // Depth search (WindowOptions::depth_search_range): points or candidates searched (those with
  // at least 2 px of epipolar line), those whose search found a unique depth (moved there, or
  // entered the window: WindowOptions::searched_points_only), and the candidates still waiting
  // after this step.
  int num_depth_searched = 0;
  int num_depth_found = 0;
  int num_candidates = 0;
  // Fraction of the new keyframe's pixels with a valid depth that WindowOptions::
  // max_depth_edge_slope left out (0 when off): 0.38-0.75 with the default model's depth at
  // 208 x 64 (the road and outlines), 0.06-0.32 with true depth at 416 x 128. Near 1 means a
  // depth map whose per-pixel noise the rule reads as edges everywhere.
  double depth_edge_fraction = 0.0;
  // Wall time of the solves (both) and of the marginalisation, milliseconds.
  double solve_ms = 0.0;
  double marginalization_ms = 0.0;
};

// The sliding-window optimiser. Not thread-safe; deterministic for num_threads = 1.
class WindowOptimizer {
 public:
  // Throws ConfigError when options.Check() fails.
  explicit WindowOptimizer(const WindowOptions& options);
  ~WindowOptimizer();
  WindowOptimizer(const WindowOptimizer&) = delete;
  WindowOptimizer& operator=(const WindowOptimizer&) = delete;

  // Inserts a keyframe, optimises, marginalises if the window is over max_keyframes (see the
  // file comment). Throws InputError (naming the frame index) when the keyframe lacks the BA
  // pyramid level, its depth and feature sizes differ, or its channel count differs from the
  // window's; NaN/zero depth is not an error (those pixels host no points). A keyframe with a
  // non-finite feature value at the BA level or a non-finite pose is not inserted: the result
  // has optimized = false, the unchanged window's poses and a message naming the frame.
  WindowResult AddKeyframe(KeyframeData keyframe);

  int num_keyframes() const;
  int num_points() const;
  int num_residual_blocks() const;
  // (frame_index, world_from_cam) of the window keyframes, oldest first.
  std::vector<std::pair<int, SE3d>> KeyframePoses() const;
  // The current marginalisation prior (nullptr: none) and the frame indices of its pose blocks
  // in the prior's block order.
  const LinearPriorCost* prior() const;
  std::vector<int> PriorFrameIndices() const;
  // Every live point: host frame index, pixel at the BA level and inverse depth (for tests and
  // diagnostics).
  struct PointInfo {
    int host_frame = 0;
    int x = 0, y = 0;
    double inverse_depth = 0.0;
  };
  std::vector<PointInfo> Points() const;
  // The live points hosted by window keyframe `frame_index` (those with at least one residual
  // block and a positive inverse depth), in selection order; empty when it is not in the window.
  std::vector<SettledPoint> HostedPoints(int frame_index) const;
  // Every live point (one with at least one residual block, or any point while the window holds
  // one keyframe) moved into the camera frame of window keyframe `frame_index` with the window's
  // current poses and inverse depths: what DSO's tracker builds its depth from. Points behind
  // that camera are left out. Empty when the frame is not in the window.
  std::vector<Eigen::Vector3d> PointsInKeyframe(int frame_index) const;
  // The same points moved into a camera at `world_from_cam` (e.g. a keyframe about to enter).
  std::vector<Eigen::Vector3d> PointsInCamera(const SE3d& world_from_cam) const;

  const WindowOptions& options() const { return options_; }

 private:
  struct KeyframeState;
  struct Block;
  struct PointState;

  // Returns the fraction of pixels with a valid depth left out by the depth-edge rule.
  double SelectPoints(KeyframeState* keyframe);
  void ConnectPoint(PointState* point, KeyframeState* target);
  // ConnectPoint into every window keyframe but the point's host.
  void ConnectToOtherKeyframes(PointState* point);
  void ConnectNewKeyframe(KeyframeState* keyframe);
  // WindowOptions::depth_search_range: moves the new keyframe's points to the depths found.
  void SearchNewPointDepths(const KeyframeState* keyframe, WindowResult* result);
  // WindowOptions::searched_points_only: searches every candidate's depth and moves those found
  // into points_; fills the result's depth-search counts.
  void ActivateCandidates(WindowResult* result);
  // One candidate's search over its blocks; true with point->inverse_depth at the unique best.
  bool SearchPointDepth(PointState* point, WindowResult* result);
  // One Ceres solve over the current state; false with *why on failure (state untouched then).
  // coarse: on pyramid_level + 1 (the warm-up), with blocks for the same (point, target) pairs.
  // Adds the solve's Levenberg-Marquardt iterations to result->num_iterations and clears
  // result->converged unless Ceres ended it by its convergence tolerances (when given).
  bool Solve(int max_iterations, double* initial_cost, double* final_cost, std::string* why,
             bool coarse = false, WindowResult* result = nullptr);
  int GateOutliers();
  int ChooseKeyframeToMarginalize() const;
  void MarginalizeKeyframe(int position, WindowResult* result);
  void RemovePointsWithoutResiduals();
  KeyframeState* FindKeyframe(int id) const;
  // |r|^2 of `block` (the point's block into keyframe target_id) at the current estimate;
  // `scratch` holds the residuals when they must be evaluated (reused across calls).
  double BlockSquaredNorm(const PointState& p, int target_id, const Block& block,
                          std::vector<double>* scratch) const;

  WindowOptions options_;
  std::unique_ptr<ceres::LossFunction> loss_;
  std::unique_ptr<SE3Manifold> manifold_;
  std::vector<std::unique_ptr<KeyframeState>> keyframes_;  // oldest first
  std::vector<std::unique_ptr<PointState>> points_;
  // WindowOptions::searched_points_only: selected points whose depth the search has not found
  // yet (no blocks between searches).
  std::vector<std::unique_ptr<PointState>> candidates_;
  std::unique_ptr<LinearPriorCost> prior_;
  std::vector<int> prior_keyframe_ids_;  // KeyframeState::id per prior block
  int next_keyframe_id_ = 0;
  int channels_ = 0;
  // WindowOptions::depth_prior_scale_fraction < 1 with a depth prior: each keyframe's prior
  // depths share a free log scale.
  bool scaled_depth_prior_ = false;
  // The zooms of WindowOptions::zoom_blur_sigma_px whose blurred features each keyframe keeps
  // (1.1, 1.2, ... up to max_patch_stretch); empty when off.
  std::vector<double> zoom_ladder_;
};

}  // namespace dfo

#endif  // DFO_BACKEND_WINDOW_OPTIMIZER_H_
