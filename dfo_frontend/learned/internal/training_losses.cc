// The joint stage's losses that need the trainer's batch: view synthesis over the sources, the
// depth scale gauge, and the alignment's pose error against the ground truth (a diagnostic).
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "dfo_frontend/learned/internal/training.h"

namespace dfo::learned {

namespace F = torch::nn::functional;

torch::Tensor ViewSynthesisLoss(const Trainer::Batch& batch,
                                const std::vector<torch::Tensor>& depth,
                                const torch::Tensor rotations[2],
                                const torch::Tensor translations[2], const LossOptions& options) {
  const int levels = static_cast<int>(depth.size());
  const std::vector<torch::Tensor> targets = ImagePyramid(batch.target, levels);
  const std::vector<torch::Tensor> sources[2] = {ImagePyramid(batch.previous, levels),
                                                 ImagePyramid(batch.next, levels)};
  torch::Tensor appearance = torch::zeros({}, batch.target.options());
  for (int l = 0; l < levels; ++l) {
    // The level whose images and intrinsics the view synthesis uses.
    const int il = options.full_resolution ? 0 : l;
    const double scale = 1.0 / (1 << il);
    // Level intrinsics: PyramidLevel's (c + 0.5) / 2^l - 0.5.
    torch::Tensor k = batch.intrinsics.clone();
    k.select(1, 0).mul_(scale);
    k.select(1, 1).mul_(scale);
    k.select(1, 2).add_(0.5).mul_(scale).sub_(0.5);
    k.select(1, 3).add_(0.5).mul_(scale).sub_(0.5);
    torch::Tensor d = depth[l].contiguous();
    if (il != l) {
      d = F::interpolate(d, F::InterpolateFuncOptions()
                                .size(std::vector<int64_t>{targets[0].size(2), targets[0].size(3)})
                                .mode(torch::kBilinear)
                                .align_corners(false))
              .contiguous();
    }
    DFO_CHECK(d.size(2) == targets[il].size(2) && d.size(3) == targets[il].size(3))
        << "level " << l << " depth " << d.sizes() << " vs image " << targets[il].sizes();
    std::vector<torch::Tensor> maps;
    for (int s = 0; s < 2; ++s) {
      torch::Tensor valid;
      const torch::Tensor warped =
          InverseWarp(sources[s][il].contiguous(), d, rotations[s], translations[s], k, &valid);
      const torch::Tensor map = AppearanceMap(targets[il].contiguous(), warped, options);
      // A pixel that falls outside this source (border-padded sample) or behind its camera
      // loses the minimum to a valid source by a constant 1 (larger than any error of the
      // clamped mix); it is never excluded. Excluding pixels invalid in both sources rewarded
      // warping them out of view: the bottom rows, which leave the image in the next frame,
      // went to the 0.1 m floor of the depth (measured, hand-made-feature alignment).
      maps.push_back(map + (1.0 - valid));
    }
    if (options.automask) {
      // The unwarped sources; + 1e-5 lets a warp win an exact tie (Monodepth2 adds noise).
      for (int s = 0; s < 2; ++s) {
        maps.push_back(
            AppearanceMap(targets[il].contiguous(), sources[s][il].contiguous(), options).detach() +
            1e-5);
      }
    }
    const torch::Tensor best = std::get<0>(torch::min(torch::cat(maps, 1), 1, true));
    appearance = appearance + best.mean();
  }
  return appearance / levels;
}

std::vector<torch::Tensor> NormaliseDepthScale(const std::vector<torch::Tensor>& raw,
                                               const LossOptions& options, torch::Tensor* prior,
                                               torch::Tensor* factor) {
  // Scale gauge: monocular snippets leave the depth scale unobservable (the alignment's
  // translation scales with it), so the depths are normalised (LossOptions::depth_gauge) to
  // depth_mean_m, and a weak prior keeps the raw output's geometric mean there (metric-ish, away
  // from the sigmoid's saturated ends). The geometric mean, not the mean: a prior on the
  // arithmetic mean was met by a few pixels at the 100 m ceiling with the rest at the 0.1 m floor
  // (measured: median depth 0.0999 m while the mean read 10 m). (Also with ground-truth poses:
  // unnormalised, the initial 0.2 m depths put every warped pixel outside the sources and the
  // depth collapsed to the 0.1 m floor; measured.)
  *prior = torch::zeros({}, raw[0].options());
  if (factor) *factor = torch::ones({raw[0].size(0), 1, 1, 1}, raw[0].options());
  if (options.depth_mean_m <= 0.0) return raw;
  const torch::Tensor log_mean = torch::log(raw[0]).mean();
  const double log_target = std::log(options.depth_mean_m);
  torch::Tensor gauge;
  if (options.depth_gauge == LossOptions::DepthGauge::kGeometricMean) {
    gauge = torch::exp(log_target - log_mean).view({1, 1, 1, 1}).expand({raw[0].size(0), 1, 1, 1});
  } else {
    // Per image: its median depth goes to depth_mean_m. Only each image's median pixel carries
    // the normalisation's gradient. With the batch geometric mean every pixel did: d L / d log
    // raw_i = g_i - mean_j g_j, so a pixel without a photometric gradient of its own
    // (auto-masked, e.g. the uniform road at the bottom) was pushed to the 0.1 m floor or the
    // 100 m ceiling whenever the rest wanted to move together (measured). Detaching the factor
    // instead let the raw scale drift to the ceiling.
    const int64_t n = raw[0].size(0);
    const torch::Tensor median = std::get<0>(raw[0].reshape({n, -1}).median(1));
    gauge = (options.depth_mean_m / median).view({n, 1, 1, 1});
  }
  std::vector<torch::Tensor> out;
  for (const torch::Tensor& d : raw) out.push_back(d * gauge);
  *prior = (log_mean - log_target).pow(2);
  if (factor) *factor = gauge;
  return out;
}

PoseError ComparePoses(const SE3d& estimate, const SE3d& truth) {
  PoseError e;
  const Eigen::Matrix3d dr = estimate.rotationMatrix().transpose() * truth.rotationMatrix();
  const double c = std::clamp((dr.trace() - 1.0) / 2.0, -1.0, 1.0);
  e.rotation_deg = std::acos(c) * 180.0 / M_PI;
  const Eigen::Vector3d a = estimate.translation(), b = truth.translation();
  if (a.norm() < 1e-9 || b.norm() < 1e-9) {
    e.direction_deg = std::numeric_limits<double>::quiet_NaN();
  } else {
    const double cd = std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0);
    e.direction_deg = std::acos(cd) * 180.0 / M_PI;
  }
  return e;
}

}  // namespace dfo::learned
