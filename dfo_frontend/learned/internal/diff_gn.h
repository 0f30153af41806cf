// Differentiable Gauss-Newton feature-metric alignment: the tracker's maths (dfo_frontend/
// tracker.h) written with LibTorch operations, so that the pose it returns can be differentiated
// with respect to the feature maps of both views and the reference depth. This is how training
// gets the relative pose between the target and each source view: from the direct method itself
// (unrolled Gauss-Newton iterations in autograd), not from a pose network.
//
// Internal header (includes <torch/torch.h>).
//
// Per level l, coarsest first (as Tracker::Track with one hypothesis):
//  - points: the patch centres that Tracker::SetReference selects on the same (detached) features
//    and depth (selection is discrete, so it carries no gradient; reusing the tracker guarantees
//    the same points), K x K patches around them, p = d(u) K^-1 u;
//  - inverse-compositional Jacobians J = dF_ref/du (central differences) * dpi/dp * [I, -hat(p)],
//    built once per level, per patch H_i = sum J^T J;
//  - each iteration: residuals r = F_ref(u) - F_cur(pi(T p)) (bilinear), patches valid when every
//    pixel projects in front of the camera and inside the image, the paper's outlier rule
//    (energy > 0.5 (median + max) of the valid patches' energies; the threshold is a constant for
//    autograd), delta = -(sum w_i H_i)^-1 sum w_i J_i^T r_i, T <- T Exp(delta)^-1; stop after the
//    tracker's iteration limit or when |delta| (translation / mean depth) < its threshold;
//  - between levels the translation is rescaled by mean_depth(l) / mean_depth(l + 1).
// w_i is 1, or the reference's soft attention mask at the patch centre when masks are given (the
// mask branch then receives gradients through the pose; the weighted solve does not depend on a
// common scale of the weights). Points are selected on the masks only with select_on_masks: in
// training with soft masks near the target density that leaves too few points (measured: every
// alignment failed once the AE stage had pushed the masks to rho).
// Residuals are evaluated in float (as the tracker); geometry, Jacobians and the 6 x 6 solves in
// double.
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_DIFF_GN_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_DIFF_GN_H_

#include <torch/torch.h>

#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/lie.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/tracker.h"

namespace dfo::learned {

// A pose as tensors: x' = rotation * x + translation (double, rotation 3 x 3, translation 3).
struct PoseTensor {
  torch::Tensor rotation;
  torch::Tensor translation;

  // From / to a dfo SE3 (the tensor version is detached).
  static PoseTensor FromSE3(const SE3d& pose);
  SE3d ToSE3() const;
  // this * other.
  PoseTensor Compose(const PoseTensor& other) const;
};

// Exp of a twist [upsilon; omega] (double tensor of 6) as rotation and translation, with the
// Taylor series near omega = 0 so that values and gradients stay finite there.
PoseTensor ExpSE3(const torch::Tensor& xi);

// One view's inputs to the alignment, per level (index 0 = finest): features C x H_l x W_l
// (float, z-scored per channel as the tracker expects), the level's camera, and for the reference
// view the depth H_l x W_l (metres, > 0 valid) and optionally a soft mask H_l x W_l in [0, 1].
struct AlignmentView {
  std::vector<torch::Tensor> features;
  std::vector<PinholeCamera> cameras;
  std::vector<torch::Tensor> depth;  // reference only
  std::vector<torch::Tensor> masks;  // reference only; empty = no weights
  // Reference only: select points only where the mask exceeds 0.5 (the tracker's mask
  // selection); false: the tracker's gradient selection, the masks only weight the patches.
  bool select_on_masks = false;
};

// Per-level diagnostics of one alignment.
struct DiffGnLevelStats {
  int num_points = 0;
  int num_inliers = 0;  // at the last evaluation
  int iterations = 0;
  bool ok = false;  // enough inliers and a finite pose (else the level's update is dropped)
};

// Result of DifferentiableAlign.
struct DiffGnResult {
  PoseTensor cur_from_ref;  // differentiable (see the file comment)
  bool ok = false;          // the finest level succeeded (Tracker's "not lost" part of the rule)
  int iterations = 0;       // Gauss-Newton updates over all levels
  std::vector<DiffGnLevelStats> levels;
};

// Converts C x H x W tensors (detached, float) into the tracker's FeaturePyramid / DepthPyramid.
// Masks (H x W soft values), when given, become the FeatureLevel mask "value > mask_threshold".
FeaturePyramid ToFeaturePyramid(const AlignmentView& view, double mask_threshold = 0.5);
DepthPyramid ToDepthPyramid(const AlignmentView& view);

// Aligns `cur` to `ref` from the start pose cur_from_ref (at the finest level's depth scale),
// as Tracker::Track with the single hypothesis `start` and `options` (num_levels, patch_size,
// selection, iterations, convergence, outlier rule). Both views need options.num_levels levels of
// equal sizes (InputError otherwise). A failed alignment is `ok = false`, never an exception; the
// pose is then the last one reached (possibly the start).
DiffGnResult DifferentiableAlign(const AlignmentView& ref, const AlignmentView& cur,
                                 const PoseTensor& start, const TrackerOptions& options);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_DIFF_GN_H_
