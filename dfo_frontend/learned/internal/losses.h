// Self-supervised training losses of the DFO paper (Yin & Liu), on LibTorch tensors.
//
// Internal header (includes <torch/torch.h>): only training code and its tests include it.
// Conventions: images are float N x 3 x H x W (or N x 1 x H x W) in [0, 1]; depth and disparity
// maps are N x 1 x H x W; masks are N x 1 x H x W in [0, 1]. Every loss returns a 0-dim tensor
// (a scalar) that autograd can differentiate.
//
// The appearance loss (Monodepth's mix, with the DFO paper's robust clamp):
//   L_ap = 0.85 * f_0.15(DSSIM / 2) + 0.15 * f_0.3(L1),
//   DSSIM = 1 - SSIM over 3 x 3 windows, L1 = mean over channels of |I - I'|,
//   f_eps(x) = x for x < eps, 0.1 x + 0.9 eps above (continuous at eps, slope 0.1 beyond: large
//   residuals from occlusions and moving objects pull ten times less).
// Edge-aware smoothness (Godard et al. 2017): mean |d/dx d*| exp(-|d/dx I|) + the same along y,
//   d* = disparity / mean(disparity) (per image; Monodepth2's normalisation keeps the term from
//   favouring a shrinking scale), |d/dx I| the mean over channels.
// Sparsity: KL(rho || m) = rho log(rho / m) + (1 - rho) log((1 - rho) / (1 - m)), m = mean of the
//   attention mask over the batch and the image.
// Autoencoder: mean squared error between the reconstruction and the input image.
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_LOSSES_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_LOSSES_H_

#include <torch/torch.h>

namespace dfo::learned {

// Loss weights and constants (training YAML section `train`, see TrainingOptions).
struct LossOptions {
  double ssim_weight = 0.85;   // alpha of the appearance mix, in [0, 1]
  double dssim_clamp = 0.15;   // eps of the robust clamp on DSSIM / 2, > 0
  double l1_clamp = 0.3;       // eps of the robust clamp on L1, > 0
  double smooth_weight = 0.1;  // lambda_sm (level l weighted lambda_sm / 2^l, l = 0 finest), >= 0
  double sparsity_weight = 0.01;  // lambda_sp, >= 0
  double sparsity_target = 0.1;   // rho, the target mask density, in (0, 1)
  double ae_weight = 0.01;        // lambda_ae, >= 0
  // Scale gauge of the joint stage (not in the paper; see training.h): depths are normalised to
  // this batch geometric mean (metres) before alignment and warping, 0 = off (then the scale
  // drifts freely), else > 0; and a prior depth_prior_weight * log(geometric mean /
  // depth_mean_m)^2 on the raw output, >= 0.
  double depth_mean_m = 10.0;
  double depth_prior_weight = 0.01;
  // What is brought to depth_mean_m: each image's median depth (only the median pixels carry the
  // normalisation's gradient) or the batch's geometric mean (every pixel does: gradient-free
  // pixels became levers on the others' scale and went to the floor or the ceiling).
  enum class DepthGauge { kMedian, kGeometricMean };
  DepthGauge depth_gauge = DepthGauge::kGeometricMean;
  // Monodepth2's auto-masking (Godard et al. 2019): the unwarped sources join the per-pixel
  // minimum of the view-synthesis loss, so a pixel that no warp explains better than "no motion"
  // contributes a constant instead of pulling its depth toward the 100 m ceiling (where the warp
  // tends to the rotation-only one). Measured without it: with translation directions still
  // 30-40 degrees off, the depth became bimodal, 60 % of the pixels at 100 m.
  bool automask = false;
  // Monodepth2's full-resolution multi-scale loss: every level's depth is upsampled (bilinear) to
  // the finest level and the view synthesis is computed there, against the full-resolution images
  // (false: each level at its own size with average-pooled images, SfMLearner's way). The coarse
  // levels then also learn from the fine texture instead of from blurred images, where "no
  // parallax" fits almost as well.
  bool full_resolution = false;
  // Geometry consistency (SC-SfMLearner, Bian et al. 2019), weight >= 0, 0 = off: the target's
  // depth moved into each source by the alignment's pose against the source's own predicted
  // depth at the projected pixel, |z - d_s| / (z + d_s) averaged over the pixels inside the
  // source (finest level; samples whose alignment failed are left out). The three frames' depths
  // share the target's gauge factor, so this ties the network's raw scale of consecutive frames
  // together: the per-image gauge alone leaves each image's scale free (every image then keeps
  // the prior's geometric mean, whatever its scene).
  double depth_consistency_weight = 0.0;
  // Depth targets from the system's own geometry (teacher.h; sequences with depth_targets): the
  // weight of their term in the joint stage (>= 0, 0 = off) and the Huber threshold on the
  // log-depth residual (> 0; 0.1: quadratic within about 10 %).
  double teacher_weight = 1.0;
  double teacher_huber = 0.1;

  // Throws ConfigError naming the field, value and rule.
  void Check() const;
};

// f_eps(x): x below eps, 0.1 x + 0.9 eps at and above (elementwise).
torch::Tensor RobustClamp(const torch::Tensor& x, double eps);

// Per-pixel (1 - SSIM) / 2 over 3 x 3 windows (reflection padding keeps the size), N x 1 x H x W
// (mean over channels), clamped to [0, 1]. Inputs N x C x H x W of equal shape.
torch::Tensor DssimMap(const torch::Tensor& a, const torch::Tensor& b);

// Per-pixel appearance error N x 1 x H x W:
//   ssim_weight * f(DssimMap) + (1 - ssim_weight) * f(mean_c |a - b|).
torch::Tensor AppearanceMap(const torch::Tensor& a, const torch::Tensor& b,
                            const LossOptions& options);

// Mean of AppearanceMap over the pixels where `valid` (N x 1 x H x W, 0/1 float) is 1; 0 when no
// pixel is valid. An undefined `valid` means every pixel.
torch::Tensor AppearanceLoss(const torch::Tensor& target, const torch::Tensor& reconstruction,
                             const torch::Tensor& valid, const LossOptions& options);

// Edge-aware first-order smoothness of `disparity` (N x 1 x H x W, > 0) guided by `image`
// (N x C x H x W, same H x W); see the file comment.
torch::Tensor SmoothnessLoss(const torch::Tensor& disparity, const torch::Tensor& image);

// KL(rho || mean(mask)); the mean is clamped to [1e-6, 1 - 1e-6]. rho in (0, 1).
torch::Tensor SparsityLoss(const torch::Tensor& mask, double rho);

// Mean squared error between `reconstruction` and `image` (equal shapes).
torch::Tensor ReconstructionLoss(const torch::Tensor& reconstruction, const torch::Tensor& image);

// Inverse warp (SfMLearner's projective warp): for every pixel u of the target view with depth
// d(u) (N x 1 x H x W, metres), p = d K^-1 u is moved into the source view by source_from_target
// (rotation N x 3 x 3, translation N x 3) and the source image (N x C x H x W) is sampled
// bilinearly at pi(K p). Returns the reconstruction of the target; *valid (optional) receives
// N x 1 x H x W with 1 where the sample lies inside the source image and in front of the camera;
// *projected_depth (optional) the depth of p in the source view, N x 1 x H x W, floored at 1 mm
// (differentiable).
// `intrinsics` is N x 4 (fx, fy, cx, cy) for this H x W, pixel centres at integers.
torch::Tensor InverseWarp(const torch::Tensor& source, const torch::Tensor& depth,
                          const torch::Tensor& rotation, const torch::Tensor& translation,
                          const torch::Tensor& intrinsics, torch::Tensor* valid = nullptr,
                          torch::Tensor* projected_depth = nullptr);

// The geometry-consistency term of LossOptions::depth_consistency_weight: target_depth and
// source_depth N x 1 x H x W (metres, same gauge), source_from_target as for InverseWarp,
// sample_weight N (1 = use the sample, 0 = leave it out). Mean of |z - d_s(u')| / (z + d_s(u'))
// over the pixels whose projection u' lies inside the source and in front of it; 0 when none.
torch::Tensor DepthConsistencyLoss(const torch::Tensor& target_depth,
                                   const torch::Tensor& source_depth, const torch::Tensor& rotation,
                                   const torch::Tensor& translation,
                                   const torch::Tensor& intrinsics,
                                   const torch::Tensor& sample_weight);

// Samples `image` (N x C x H x W) bilinearly at pixel coordinates `x`, `y` (N x ...; pixel
// centres at integers, align_corners semantics); outside the image, the nearest border pixel
// (Monodepth2's border padding). Returns N x C x (shape of x
// without N) flattened as N x C x M with M the number of points per batch element.
torch::Tensor SampleBilinear(const torch::Tensor& image, const torch::Tensor& x,
                             const torch::Tensor& y);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_LOSSES_H_
