// The direct feature-metric tracker of the DFO paper (Yin & Liu): coarse-to-fine Gauss-Newton
// alignment of a current frame's feature pyramid to a reference frame's features and depth, with
// inverse-compositional updates, and DSO's multi-hypothesis initialisation.
//
//   Tracker tracker(options);
//   tracker.SetReference(ref_features, ref_depth);        // selects points, builds Jacobians
//   TrackResult r = tracker.Track(cur_features, {guess}); // guess: cur_from_ref hypotheses
//
// Per level l (coarsest first), selected reference pixels u with depth d give K x K patches of
// 3D points p = d K^-1 u; the residual of a patch pixel is the C-vector
//   r(u) = F_ref(u) - F_cur(pi(T p)),  T = cur_from_ref,
// over all channels of the z-scored features. Inverse compositional (Baker & Matthews 2004):
// linearise F_ref(pi(Exp(delta) p)) at delta = 0, J = dF_ref/du * dpi/dp * [I, -hat(p)], which
// depends on the reference only, so J and each patch's J^T J are computed once per level; each
// iteration solves (sum J^T J) delta = -sum J^T r over the inlier patches and updates
// T <- T * Exp(delta)^-1. Outliers: patches whose squared residual norm exceeds
// 0.5 * (median + max) of all patches' squared norms, recomputed every iteration (the paper).
#ifndef DFO_FRONTEND_TRACKER_H_
#define DFO_FRONTEND_TRACKER_H_

#include <Eigen/Core>
#include <vector>

#include "dfo_core/lie.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"

namespace dfo {

// Options of the tracker. Level indices: 0 = finest (working resolution).
struct TrackerOptions {
  // Pyramid levels used, >= 1 (the paper: 4). Feature and depth pyramids need at least as many.
  int num_levels = 4;
  // Patch side K in pixels, odd, in [1, 7] (K x K pixels around each selected point).
  int patch_size = 3;
  // Most points (patch centres) selected per level, >= 1. Points are the best-gradient pixel of
  // each cell of a grid sized so that the image holds about this many cells (or the mask's
  // pixels when the feature level has a mask).
  int max_points = 600;
  // Smallest grid cell side in pixels, >= 1 (coarse levels have few pixels).
  int min_cell_px = 2;
  // A candidate needs a feature gradient norm (z-score units per pixel, summed over channels in
  // quadrature) of at least this, >= 0. Avoids flat regions (sky, blank walls).
  double min_gradient = 0.05;
  // Reject a candidate whose patch, grown by one pixel, spans depths with max / min above this
  // (a depth edge: its colours mix surfaces with different parallax); 0 = off, else > 1.
  double max_patch_depth_ratio = 0.0;
  // Gauss-Newton iteration limit per level, index = level; each >= 1. Shorter than num_levels:
  // the last value repeats.
  std::vector<int> max_iterations = {10, 15, 20, 30};
  // Convergence per level: stop when |delta| (translation in mean-depth units and rotation in
  // rad, as one 6-vector norm) falls below this, index = level, each > 0; last value repeats.
  std::vector<double> convergence_threshold = {1e-6, 1e-5, 1e-5, 1e-5};
  // Apply the paper's outlier rule (0.5 * (median + max) of squared patch residual norms).
  bool outlier_rule = true;
  // DSO's initial hypotheses besides the caller's: zero, half and double motion (relative to the
  // constant-velocity guess) and, when > 0, small rotations of this many degrees about each
  // axis (both signs). In [0, 10].
  double rotation_hypotheses_deg = 0.0;
  // A hypothesis is abandoned when its RMSE at a level exceeds this times the best RMSE any
  // hypothesis reached at that level, > 1 (DSO: 1.5).
  double hypothesis_abandon_ratio = 1.5;
  // Stop trying further hypotheses once one finishes with RMSE below this (z-score units), >= 0.
  // 0 = always try all.
  double good_enough_rmse = 0.25;
  // Status thresholds (finest level; inlier ratio = inliers / selected points):
  // ok when inliers >= min_inliers_ok, ratio >= min_inlier_ratio_ok and rmse <= max_rmse_ok;
  // lost when inliers < min_inliers_lost or rmse > max_rmse_lost or the pose is not finite;
  // degraded otherwise. Counts >= 0, ratios in [0, 1], rmse > 0, ok thresholds stricter.
  int min_inliers_ok = 100;
  double min_inlier_ratio_ok = 0.5;
  double max_rmse_ok = 0.5;
  int min_inliers_lost = 30;
  double max_rmse_lost = 1.0;

  // Throws ConfigError naming the field ("tracker.patch_size = 4 violates odd"), value and rule.
  void Check() const;
  // Iteration limit and convergence threshold of level l (the last entry repeats).
  int MaxIterations(int level) const;
  double ConvergenceThreshold(int level) const;
};

// Per-level outcome of the best hypothesis.
struct TrackLevelStats {
  int num_points = 0;   // patches selected in the reference at this level
  int num_valid = 0;    // patches inside the current image at the last iteration
  int num_inliers = 0;  // patches kept by the outlier rule at the last iteration
  int iterations = 0;
  double rmse = 0.0;  // RMS residual per feature value over the inliers
};

// Result of Tracker::Track.
struct TrackResult {
  TrackingStatus status = TrackingStatus::kLost;  // kOk, kDegraded or kLost
  SE3d cur_from_ref;          // estimated pose of the reference in the current camera
  int num_points = 0;         // finest-level selected patches
  int num_inliers = 0;        // finest-level inliers
  double inlier_ratio = 0.0;  // num_inliers / num_points (0 when no points)
  double rmse = 0.0;          // finest-level RMSE (z-score units)
  int iterations = 0;         // all levels and hypotheses
  int hypothesis = -1;        // index of the winning hypothesis in the tried list
  int hypotheses_tried = 0;
  std::vector<TrackLevelStats> levels;  // index = level, of the winning hypothesis
};

// Frame-to-reference tracker. Not thread-safe; deterministic.
class Tracker {
 public:
  // Throws ConfigError when options.Check() fails.
  explicit Tracker(const TrackerOptions& options);
  ~Tracker();
  Tracker(Tracker&&) noexcept;
  Tracker& operator=(Tracker&&) noexcept;
  Tracker(const Tracker&);  // copies the reference (the frontend restores one after a re-track)
  Tracker& operator=(const Tracker&);

  // Sets the reference: per level, selects points, gathers K x K patches with valid depth and
  // precomputes the inverse-compositional Jacobians. The pyramids need >= num_levels levels of
  // equal sizes (InputError otherwise). Returns the number of finest-level points; a reference
  // with fewer than min_inliers_lost points (e.g. a depth map of zeros) makes Track report lost.
  int SetReference(const FeaturePyramid& features, const DepthPyramid& depth);
  bool has_reference() const { return !levels_.empty(); }
  // Mean valid depth of the reference at each level (metres; the translation rescaling uses
  // the ratios), and of the finest level.
  double reference_mean_depth(int level = 0) const;
  // The depth at which a translation gives the reference's points at `level` their mean parallax:
  // 1 / (mean inverse depth of the selected patch centres), metres; 0 without points. Unlike the
  // mean depth it is not dominated by far background and sky, which move little in the image.
  double reference_parallax_depth(int level = 0) const;
  int num_reference_points(int level = 0) const;
  // Patch centres (pixels) selected in the reference at `level`, in patch order.
  std::vector<Eigen::Vector2i> reference_points(int level = 0) const;
  // Depth (m) of those centres, in the same order.
  std::vector<float> reference_depths(int level = 0) const;

  // Tracks `features` (same channel count and sizes as the reference) from the initial guesses
  // of cur_from_ref, tried in order (first = preferred, e.g. constant velocity); an empty list
  // means identity. Trying stops once a hypothesis ends with RMSE <= max(good_enough_rmse,
  // hypothesis_abandon_ratio x the last successful Track's RMSE) (DSO's re-track rule). Guesses are
  // expressed at the finest level's depth scale. Never throws on failure: a failed alignment is
  // status kLost. Throws InputError on mismatched sizes and InternalError without a reference.
  TrackResult Track(const FeaturePyramid& features, const std::vector<SE3d>& hypotheses);

  // DSO's hypothesis list from a constant-velocity guess: {cv, zero, half, double} motion,
  // where motion = cv_cur_from_ref * last_from_ref^-1 (i.e. the last inter-frame motion), then
  // rotations of options.rotation_hypotheses_deg about +-x, +-y, +-z applied to cv.
  std::vector<SE3d> MakeHypotheses(const SE3d& last_from_ref, const SE3d& motion) const;

  // --- For tests and diagnostics. ---
  // Residuals (patch-pixel C-vectors stacked, patch by patch) and inverse-compositional
  // Jacobians (one row per residual value, 6 columns) of level l at pose cur_from_ref, for the
  // patches fully inside the current image; `patch_ids` receives their indices.
  void Linearize(const FeaturePyramid& features, int level, const SE3d& cur_from_ref,
                 Eigen::VectorXd* residuals, Eigen::MatrixXd* jacobian,
                 std::vector<int>* patch_ids) const;
  // Reference-side residual function for the Jacobian test: F_ref(pi(Exp(delta) p)) - F_cur(
  // pi(T p)) for every value of the valid patches of level l (bilinear F_ref).
  Eigen::VectorXd InverseCompositionalResiduals(const FeaturePyramid& features, int level,
                                                const SE3d& cur_from_ref,
                                                const Vector6d& delta) const;
  // The outlier threshold 0.5 * (median + max) of the given squared norms (0 for none).
  static double OutlierThreshold(std::vector<double> squared_norms);

  const TrackerOptions& options() const { return options_; }

 private:
  struct Level;
  struct LevelResult;
  LevelResult AlignLevel(const FeaturePyramid& features, int level, SE3d* cur_from_ref) const;

  TrackerOptions options_;
  std::vector<Level> levels_;  // reference data per level (complete type in tracker.cc)
  double last_rmse_ = -1.0;    // finest RMSE of the last successful Track (-1: none)
};

}  // namespace dfo

#endif  // DFO_FRONTEND_TRACKER_H_
