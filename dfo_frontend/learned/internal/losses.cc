// Training losses. References: SSIM of Wang et al. 2004 with 3 x 3 mean windows and the 0.85 /
// 0.15 SSIM / L1 mix of Godard et al. (Monodepth, CVPR 2017); the robust clamp and the weights
// lambda_sm, lambda_sp, lambda_ae of the DFO paper; the projective inverse warp of SfMLearner
// (Zhou et al. 2017, projective_inverse_warp).
#include "dfo_frontend/learned/internal/losses.h"

#include <sstream>

#include "dfo_core/error.h"

namespace dfo::learned {

namespace F = torch::nn::functional;

namespace {

void Require(bool ok, const char* field, double value, const char* rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << "train." << field << " = " << value << " violates " << rule;
  throw ConfigError(msg.str());
}

}  // namespace

void LossOptions::Check() const {
  Require(ssim_weight >= 0.0 && ssim_weight <= 1.0, "ssim_weight", ssim_weight, "in [0, 1]");
  Require(dssim_clamp > 0.0, "dssim_clamp", dssim_clamp, "> 0");
  Require(depth_consistency_weight >= 0.0, "depth_consistency_weight", depth_consistency_weight,
          ">= 0");
  Require(l1_clamp > 0.0, "l1_clamp", l1_clamp, "> 0");
  Require(smooth_weight >= 0.0, "smooth_weight", smooth_weight, ">= 0");
  Require(sparsity_weight >= 0.0, "sparsity_weight", sparsity_weight, ">= 0");
  Require(sparsity_target > 0.0 && sparsity_target < 1.0, "sparsity_target", sparsity_target,
          "in (0, 1)");
  Require(ae_weight >= 0.0, "ae_weight", ae_weight, ">= 0");
  Require(depth_mean_m >= 0.0, "depth_mean_m", depth_mean_m, ">= 0");
  Require(depth_prior_weight >= 0.0, "depth_prior_weight", depth_prior_weight, ">= 0");
  Require(teacher_weight >= 0.0, "teacher_weight", teacher_weight, ">= 0");
  Require(teacher_huber > 0.0, "teacher_huber", teacher_huber, "> 0");
}

torch::Tensor RobustClamp(const torch::Tensor& x, double eps) {
  // f(x) = x below eps, 0.1 x + 0.9 eps above: continuous at eps with a tenth of the slope.
  return torch::where(x < eps, x, 0.1 * x + 0.9 * eps);
}

torch::Tensor DssimMap(const torch::Tensor& a, const torch::Tensor& b) {
  DFO_CHECK(a.sizes() == b.sizes() && a.dim() == 4) << a.sizes() << " vs " << b.sizes();
  // SSIM with 3 x 3 mean windows (Monodepth2's SSIM module: reflection padding, C1 = 0.01^2,
  // C2 = 0.03^2 for images in [0, 1]).
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;
  auto pool = [](const torch::Tensor& t) {
    return F::avg_pool2d(F::pad(t, F::PadFuncOptions({1, 1, 1, 1}).mode(torch::kReflect)),
                         F::AvgPool2dFuncOptions(3).stride(1));
  };
  const torch::Tensor mu_a = pool(a), mu_b = pool(b);
  const torch::Tensor sigma_a = pool(a * a) - mu_a * mu_a;
  const torch::Tensor sigma_b = pool(b * b) - mu_b * mu_b;
  const torch::Tensor sigma_ab = pool(a * b) - mu_a * mu_b;
  const torch::Tensor numerator = (2 * mu_a * mu_b + kC1) * (2 * sigma_ab + kC2);
  const torch::Tensor denominator = (mu_a * mu_a + mu_b * mu_b + kC1) * (sigma_a + sigma_b + kC2);
  const torch::Tensor dssim = torch::clamp((1 - numerator / denominator) / 2, 0.0, 1.0);
  return dssim.mean(1, /*keepdim=*/true);
}

torch::Tensor AppearanceMap(const torch::Tensor& a, const torch::Tensor& b,
                            const LossOptions& options) {
  const torch::Tensor dssim = RobustClamp(DssimMap(a, b), options.dssim_clamp);
  const torch::Tensor l1 = RobustClamp((a - b).abs().mean(1, true), options.l1_clamp);
  return options.ssim_weight * dssim + (1.0 - options.ssim_weight) * l1;
}

torch::Tensor AppearanceLoss(const torch::Tensor& target, const torch::Tensor& reconstruction,
                             const torch::Tensor& valid, const LossOptions& options) {
  const torch::Tensor map = AppearanceMap(target, reconstruction, options);
  if (!valid.defined()) return map.mean();
  // Mean over valid pixels; the clamp on the count makes an all-invalid batch give 0, not NaN.
  return (map * valid).sum() / valid.sum().clamp_min(1.0);
}

torch::Tensor SmoothnessLoss(const torch::Tensor& disparity, const torch::Tensor& image) {
  DFO_CHECK(disparity.dim() == 4 && disparity.size(1) == 1 && image.dim() == 4 &&
            image.size(2) == disparity.size(2) && image.size(3) == disparity.size(3))
      << disparity.sizes() << " vs " << image.sizes();
  const torch::Tensor mean = disparity.mean({2, 3}, true);
  const torch::Tensor d = disparity / (mean + 1e-7);
  using torch::indexing::None;
  using torch::indexing::Slice;
  const torch::Tensor dx = (d.index({Slice(), Slice(), Slice(), Slice(1, None)}) -
                            d.index({Slice(), Slice(), Slice(), Slice(None, -1)}))
                               .abs();
  const torch::Tensor dy = (d.index({Slice(), Slice(), Slice(1, None), Slice()}) -
                            d.index({Slice(), Slice(), Slice(None, -1), Slice()}))
                               .abs();
  const torch::Tensor ix = (image.index({Slice(), Slice(), Slice(), Slice(1, None)}) -
                            image.index({Slice(), Slice(), Slice(), Slice(None, -1)}))
                               .abs()
                               .mean(1, true);
  const torch::Tensor iy = (image.index({Slice(), Slice(), Slice(1, None), Slice()}) -
                            image.index({Slice(), Slice(), Slice(None, -1), Slice()}))
                               .abs()
                               .mean(1, true);
  return (dx * torch::exp(-ix)).mean() + (dy * torch::exp(-iy)).mean();
}

torch::Tensor SparsityLoss(const torch::Tensor& mask, double rho) {
  DFO_CHECK(rho > 0.0 && rho < 1.0) << rho;
  const torch::Tensor m = mask.mean().clamp(1e-6, 1.0 - 1e-6);
  return rho * torch::log(rho / m) + (1.0 - rho) * torch::log((1.0 - rho) / (1.0 - m));
}

torch::Tensor ReconstructionLoss(const torch::Tensor& reconstruction, const torch::Tensor& image) {
  DFO_CHECK(reconstruction.sizes() == image.sizes())
      << reconstruction.sizes() << " vs " << image.sizes();
  return (reconstruction - image).pow(2).mean();
}

torch::Tensor SampleBilinear(const torch::Tensor& image, const torch::Tensor& x,
                             const torch::Tensor& y) {
  const int64_t n = image.size(0), h = image.size(2), w = image.size(3);
  // align_corners = true maps -1 / +1 to the centres of the first / last pixels, which is dfo's
  // integer pixel-centre convention.
  const torch::Tensor gx = x.reshape({n, 1, -1}) * (2.0 / std::max<int64_t>(w - 1, 1)) - 1.0;
  const torch::Tensor gy = y.reshape({n, 1, -1}) * (2.0 / std::max<int64_t>(h - 1, 1)) - 1.0;
  const torch::Tensor grid = torch::stack({gx, gy}, -1).to(image.dtype());
  const torch::Tensor out = F::grid_sample(image, grid,
                                           F::GridSampleFuncOptions()
                                               .mode(torch::kBilinear)
                                               .padding_mode(torch::kBorder)
                                               .align_corners(true));
  return out.reshape({n, image.size(1), -1});
}

torch::Tensor InverseWarp(const torch::Tensor& source, const torch::Tensor& depth,
                          const torch::Tensor& rotation, const torch::Tensor& translation,
                          const torch::Tensor& intrinsics, torch::Tensor* valid,
                          torch::Tensor* projected_depth) {
  const int64_t n = source.size(0), c = source.size(1), h = source.size(2), w = source.size(3);
  DFO_CHECK(depth.size(0) == n && depth.size(2) == h && depth.size(3) == w)
      << depth.sizes() << " vs " << source.sizes();
  const auto opts = depth.options();
  const torch::Tensor xs = torch::arange(w, opts).view({1, 1, w}).expand({n, h, w});
  const torch::Tensor ys = torch::arange(h, opts).view({1, h, 1}).expand({n, h, w});
  const torch::Tensor fx = intrinsics.select(1, 0).view({n, 1, 1});
  const torch::Tensor fy = intrinsics.select(1, 1).view({n, 1, 1});
  const torch::Tensor cx = intrinsics.select(1, 2).view({n, 1, 1});
  const torch::Tensor cy = intrinsics.select(1, 3).view({n, 1, 1});
  const torch::Tensor d = depth.squeeze(1);
  // p = d K^-1 u, q = R p + t.
  const torch::Tensor p =
      torch::stack({(xs - cx) / fx * d, (ys - cy) / fy * d, d}, 1).reshape({n, 3, h * w});
  const torch::Tensor q = torch::bmm(rotation, p) + translation.view({n, 3, 1});
  const torch::Tensor z = q.select(1, 2);
  const torch::Tensor z_safe = torch::where(z > 1e-3, z, torch::full_like(z, 1e-3));
  const torch::Tensor u = fx.view({n, 1}) * q.select(1, 0) / z_safe + cx.view({n, 1});
  const torch::Tensor v = fy.view({n, 1}) * q.select(1, 1) / z_safe + cy.view({n, 1});
  const torch::Tensor out = SampleBilinear(source, u, v).reshape({n, c, h, w});
  if (valid) {
    torch::NoGradGuard no_grad;
    *valid = ((z > 1e-3) & (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1))
                 .to(source.dtype())
                 .reshape({n, 1, h, w});
  }
  if (projected_depth) *projected_depth = z_safe.reshape({n, 1, h, w});
  return out;
}

torch::Tensor DepthConsistencyLoss(const torch::Tensor& target_depth,
                                   const torch::Tensor& source_depth, const torch::Tensor& rotation,
                                   const torch::Tensor& translation,
                                   const torch::Tensor& intrinsics,
                                   const torch::Tensor& sample_weight) {
  const int64_t n = target_depth.size(0);
  DFO_CHECK(source_depth.sizes() == target_depth.sizes())
      << source_depth.sizes() << " vs " << target_depth.sizes();
  DFO_CHECK(sample_weight.numel() == n) << sample_weight.sizes() << " for " << n << " samples";
  torch::Tensor valid, z;
  const torch::Tensor sampled =
      InverseWarp(source_depth, target_depth, rotation, translation, intrinsics, &valid, &z);
  const torch::Tensor difference = (z - sampled).abs() / (z + sampled);
  const torch::Tensor weight = valid * sample_weight.to(valid.dtype()).view({n, 1, 1, 1}).detach();
  return (difference * weight).sum() / weight.sum().clamp_min(1.0);
}

}  // namespace dfo::learned
