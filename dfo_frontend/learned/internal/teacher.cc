#include "dfo_frontend/learned/internal/teacher.h"

#include <cmath>
#include <limits>

namespace dfo::learned {

namespace F = torch::nn::functional;

std::vector<DepthTarget> MoveTargets(const std::vector<DepthTarget>& targets,
                                     const PinholeCamera& from, const PinholeCamera& to) {
  std::vector<DepthTarget> out;
  out.reserve(targets.size());
  for (const DepthTarget& t : targets) {
    DepthTarget m = t;
    m.u = static_cast<float>(to.fx * (t.u - from.cx) / from.fx + to.cx);
    m.v = static_cast<float>(to.fy * (t.v - from.cy) / from.fy + to.cy);
    if (m.u < -0.5f || m.v < -0.5f || m.u > to.width - 0.5f || m.v > to.height - 0.5f) continue;
    out.push_back(m);
  }
  return out;
}

torch::Tensor TargetsToTensor(const std::vector<DepthTarget>& targets) {
  if (targets.empty()) return torch::Tensor();
  torch::Tensor t = torch::empty({static_cast<int64_t>(targets.size()), 4}, torch::kFloat32);
  auto a = t.accessor<float, 2>();
  for (size_t i = 0; i < targets.size(); ++i) {
    a[i][0] = targets[i].u;
    a[i][1] = targets[i].v;
    a[i][2] = targets[i].depth_m;
    a[i][3] = targets[i].weight;
  }
  return t;
}

torch::Tensor TeacherDepthLoss(const torch::Tensor& depth,
                               const std::vector<torch::Tensor>& targets,
                               const std::vector<double>& log_scales, double delta,
                               std::vector<double>* offsets) {
  const int64_t n = depth.size(0), h = depth.size(2), w = depth.size(3);
  offsets->assign(static_cast<size_t>(n), std::numeric_limits<double>::quiet_NaN());
  torch::Tensor sum = torch::zeros({}, depth.options());
  torch::Tensor weights = torch::zeros({}, depth.options());
  bool any = false;
  for (int64_t b = 0; b < n; ++b) {
    const torch::Tensor& t = targets[static_cast<size_t>(b)];
    if (!t.defined() || t.size(0) == 0) continue;
    any = true;
    // Pixel centres at integers -> grid_sample's [-1, 1] with align_corners = false.
    const torch::Tensor gx = (t.select(1, 0) + 0.5) * (2.0 / w) - 1.0;
    const torch::Tensor gy = (t.select(1, 1) + 0.5) * (2.0 / h) - 1.0;
    const torch::Tensor grid = torch::stack({gx, gy}, 1).view({1, 1, -1, 2}).to(depth.dtype());
    const torch::Tensor sampled =
        F::grid_sample(depth.narrow(0, b, 1), grid,
                       F::GridSampleFuncOptions().mode(torch::kBilinear).align_corners(false))
            .view({-1});
    const torch::Tensor log_target = t.select(1, 2).to(depth.dtype()).log();
    const torch::Tensor log_pred = sampled.clamp_min(1e-6).log();
    (*offsets)[static_cast<size_t>(b)] = (log_target - log_pred).detach().median().item<double>();
    const double s = std::isfinite(log_scales[static_cast<size_t>(b)])
                         ? log_scales[static_cast<size_t>(b)]
                         : (*offsets)[static_cast<size_t>(b)];
    const torch::Tensor r = log_pred + s - log_target;
    const torch::Tensor huber =
        torch::where(r.abs() <= delta, 0.5 * r * r, delta * (r.abs() - 0.5 * delta));
    const torch::Tensor wt = t.select(1, 3).to(depth.dtype());
    sum = sum + (wt * huber).sum();
    weights = weights + wt.sum();
  }
  if (!any) return torch::zeros({}, depth.options());
  return sum / weights.clamp_min(1e-12);
}

}  // namespace dfo::learned
