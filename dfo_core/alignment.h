// Trajectory alignment for evaluation: Umeyama (1991) least-squares rigid / similarity alignment
// of point sets, alignment of an estimated trajectory onto a ground truth, and timestamp
// association of two trajectories. Everything follows the evo package (MichaelGrupp/evo,
// evo/core/geometry.py `umeyama_alignment`, evo/core/sync.py `associate_trajectories`, and
// `PosePath3D.align`) so figures compare with `evo_ape -a` / `evo_ape -as`.
#ifndef DFO_CORE_ALIGNMENT_H_
#define DFO_CORE_ALIGNMENT_H_

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "dfo_core/lie.h"
#include "dfo_core/trajectory.h"

namespace dfo {

// Which transform aligns an estimate onto the ground truth before errors are measured.
enum class AlignmentType {
  kNone,  // no alignment: the estimate is compared as it is
  kSe3,   // rotation + translation (evo_ape -a); for stereo / RGB-D / metric-scale estimates
  kSim3,  // rotation + translation + scale (evo_ape -as); for monocular estimates
};

// "none" | "se3" | "sim3" (case-sensitive). Throws InputError naming the value otherwise.
AlignmentType ParseAlignmentType(const std::string& name);
// The inverse of ParseAlignmentType.
std::string AlignmentTypeName(AlignmentType type);

// A similarity transform target = scale * rotation * source + translation. Returned by the
// alignment functions; kept as its own small struct so evaluation does not depend on the Sim3
// class of lie.h.
struct SimilarityTransform {
  double scale = 1.0;                                      // > 0
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // proper rotation, det = +1
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  // Maps a point: scale * R * p + t.
  Eigen::Vector3d Apply(const Eigen::Vector3d& p) const {
    return scale * (rotation * p) + translation;
  }
  // Maps a camera pose world_from_cam into the target world the way evo does (first scale the
  // positions, then left-multiply the rigid part): R_out = R * R_in, t_out = s * R * t_in + t.
  SE3d Apply(const SE3d& world_from_cam) const;
  // 4x4 matrix [sR t; 0 1].
  Eigen::Matrix4d Matrix() const;
};

// Umeyama (1991) least-squares estimation of the similarity (with_scale) or rigid transform that
// maps `source` onto `target` (columns are corresponding points): minimises
// sum_i |target_i - (c R source_i + t)|^2. Exactly evo's `umeyama_alignment(x=source, y=target)`:
// covariance (1/n) sum (y_i - mean_y)(x_i - mean_x)^T, SVD U D V^T, S = diag(1, 1, -1) when
// det(U) det(V) < 0 (so R is a proper rotation even for reflected data), R = U S V^T,
// c = trace(D S) / sigma_x^2, t = mean_y - c R mean_x.
// Each point set is centred and scaled by powers of two before anything is squared (exact
// scalings, so ordinary inputs give evo's result to rounding): coordinates of any finite magnitude
// (1e-300 or 1e300) neither overflow nor underflow. Throws InputError (naming the set by
// source_name / target_name, e.g. "estimate") when the sizes differ, fewer than 3 points are given,
// a coordinate is not finite, a set's points coincide (also up to the last few bits of their
// coordinates) or lie on one line (the rotation about it would be rounding noise), the
// covariance has rank < 2 relative to the spreads (evo's "Degenerate covariance rank", made
// independent of the units), or the scale or translation leaves the double range. The result
// is always finite with scale > 0.
SimilarityTransform UmeyamaAlignment(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                     bool with_scale, const std::string& source_name = "source",
                                     const std::string& target_name = "target");

// Options of AlignTrajectory.
struct TrajectoryAlignmentOptions {
  AlignmentType type = AlignmentType::kSe3;  // which transform to fit
  // Fit on the first this many pose pairs only (evo's --n_to_align); 0 = all poses. >= 0.
  int num_poses_to_align = 0;
  // Throws ConfigError naming the field when a value is out of range.
  void Check() const;
};

// Result of AlignTrajectory.
struct TrajectoryAlignment {
  AlignmentType type = AlignmentType::kNone;
  SimilarityTransform transform;  // estimate world -> ground-truth world (identity for kNone)
  Trajectory aligned_estimate;    // the estimate mapped by `transform`, timestamps kept
  size_t num_poses_used = 0;      // pose pairs the fit used
};

// Aligns `estimate` onto `ground_truth`; the two must already be associated (same size, pose i
// of one corresponds to pose i of the other; see AssociateByTimestamp). Positions only, as evo.
// The scale is 1 unless options.type is kSim3. Throws InputError on different sizes, on an empty
// trajectory, on non-finite, coinciding or collinear positions and on a transform beyond double
// precision (see UmeyamaAlignment; messages say "estimate" and "ground-truth"), and when an
// aligned pose leaves the double range.
TrajectoryAlignment AlignTrajectory(const Trajectory& estimate, const Trajectory& ground_truth,
                                    const TrajectoryAlignmentOptions& options = {});

// Applies a similarity transform to every pose of a trajectory (see SimilarityTransform::Apply).
Trajectory TransformTrajectory(const Trajectory& trajectory, const SimilarityTransform& transform);

// evo-compatible timestamp association (evo/core/sync.py `associate_trajectories` with offset 0):
// for each stamp of the SHORTER trajectory (b when both have the same length, as evo), the
// nearest stamp of the other (the first one on ties, as numpy's argmin); the pair is kept when
// |difference| <= max_diff_ns. Returns index pairs (index in a, index in b) in the order of the
// shorter trajectory. An empty result means nothing matched (evo raises there: callers decide).
// An index of the longer trajectory may appear in several pairs, exactly as in evo.
std::vector<std::pair<size_t, size_t>> AssociateByTimestamp(const Trajectory& a,
                                                            const Trajectory& b,
                                                            int64_t max_diff_ns);

// Keeps the associated poses of a and b, in pair order, so the outputs have equal sizes.
void ApplyAssociation(const std::vector<std::pair<size_t, size_t>>& pairs, const Trajectory& a,
                      const Trajectory& b, Trajectory* a_out, Trajectory* b_out);

}  // namespace dfo

#endif  // DFO_CORE_ALIGNMENT_H_
