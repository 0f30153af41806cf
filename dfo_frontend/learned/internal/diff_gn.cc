// Differentiable inverse-compositional Gauss-Newton (Baker & Matthews 2004) on feature patches,
// mirroring dfo_frontend/tracker.cc step by step (DFO paper, Yin & Liu, Sec. III; the unrolled
// solver in autograd follows the idea of BA-Net, Tang & Tan 2019, and of the DFO paper's
// training, where the pose comes from the alignment itself).
#include "dfo_frontend/learned/internal/diff_gn.h"

#include <cmath>
#include <limits>
#include <sstream>

#include "dfo_core/error.h"

namespace dfo::learned {

namespace {

// The tracker's minimum number of valid patches for a 6-DoF solve (tracker.cc).
constexpr int kMinPatchesPerLevel = 12;

torch::TensorOptions Double() { return torch::TensorOptions().dtype(torch::kFloat64); }

// 3 x 3 skew-symmetric matrices of a (3) tensor.
torch::Tensor Hat(const torch::Tensor& w) {
  const torch::Tensor zero = torch::zeros({}, w.options());
  const torch::Tensor x = w[0], y = w[1], z = w[2];
  return torch::stack(
      {torch::stack({zero, -z, y}), torch::stack({z, zero, -x}), torch::stack({-y, x, zero})});
}

// Number of valid (> 0) depths and their mean (differentiable).
torch::Tensor MeanValidDepth(const torch::Tensor& depth) {
  const torch::Tensor valid = (depth > 0).to(depth.dtype());
  return (depth * valid).sum().to(torch::kFloat64) / valid.sum().clamp_min(1.0).to(torch::kFloat64);
}

}  // namespace

PoseTensor PoseTensor::FromSE3(const SE3d& pose) {
  PoseTensor out;
  const Eigen::Matrix3d r = pose.rotationMatrix();
  out.rotation = torch::empty({3, 3}, Double());
  out.translation = torch::empty({3}, Double());
  auto ra = out.rotation.accessor<double, 2>();
  auto ta = out.translation.accessor<double, 1>();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) ra[i][j] = r(i, j);
    ta[i] = pose.translation()(i);
  }
  return out;
}

SE3d PoseTensor::ToSE3() const {
  const torch::Tensor r = rotation.detach().to(torch::kCPU, torch::kFloat64).contiguous();
  const torch::Tensor t = translation.detach().to(torch::kCPU, torch::kFloat64).contiguous();
  Eigen::Matrix3d m;
  Eigen::Vector3d v;
  auto ra = r.accessor<double, 2>();
  auto ta = t.accessor<double, 1>();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m(i, j) = ra[i][j];
    v(i) = ta[i];
  }
  return SE3d(SO3d::FromMatrix(m), v);
}

PoseTensor PoseTensor::Compose(const PoseTensor& other) const {
  return {torch::matmul(rotation, other.rotation),
          torch::matmul(rotation, other.translation) + translation};
}

PoseTensor ExpSE3(const torch::Tensor& xi) {
  DFO_CHECK(xi.numel() == 6) << xi.sizes();
  const torch::Tensor upsilon = xi.slice(0, 0, 3), omega = xi.slice(0, 3, 6);
  const torch::Tensor theta_sq = (omega * omega).sum();
  // Rodrigues: R = I + A W + B W^2, V = I + B W + C W^2 (the left Jacobian), with
  // A = sin t / t, B = (1 - cos t) / t^2, C = (t - sin t) / t^3. Below t^2 = 1e-8 the series
  // (error O(t^4) ~ 1e-16) replaces the ratios; the `where` on a safe t^2 keeps the gradient of
  // the unused branch finite (no NaN from sqrt(0)).
  const bool small = theta_sq.item<double>() < 1e-8;
  torch::Tensor a, b, c;
  if (small) {
    a = 1.0 - theta_sq / 6.0;
    b = 0.5 - theta_sq / 24.0;
    c = 1.0 / 6.0 - theta_sq / 120.0;
  } else {
    const torch::Tensor theta = torch::sqrt(theta_sq);
    const torch::Tensor s = torch::sin(theta), co = torch::cos(theta);
    a = s / theta;
    b = (1.0 - co) / theta_sq;
    c = (theta - s) / (theta_sq * theta);
  }
  const torch::Tensor w = Hat(omega);
  const torch::Tensor w2 = torch::matmul(w, w);
  const torch::Tensor eye = torch::eye(3, xi.options());
  const torch::Tensor r = eye + a * w + b * w2;
  const torch::Tensor v = eye + b * w + c * w2;
  return {r, torch::matmul(v, upsilon)};
}

FeaturePyramid ToFeaturePyramid(const AlignmentView& view, double mask_threshold) {
  FeaturePyramid out;
  for (size_t l = 0; l < view.features.size(); ++l) {
    const torch::Tensor f = view.features[l].detach().to(torch::kCPU, torch::kFloat32).contiguous();
    DFO_CHECK(f.dim() == 3) << "level " << l << " features " << f.sizes();
    FeatureLevel level(static_cast<int>(f.size(2)), static_cast<int>(f.size(1)),
                       static_cast<int>(f.size(0)), view.cameras.at(l));
    std::copy(f.data_ptr<float>(), f.data_ptr<float>() + f.numel(), level.data.begin());
    if (l < view.masks.size() && view.masks[l].defined()) {
      const torch::Tensor m = (view.masks[l].detach().reshape({-1}) > mask_threshold)
                                  .to(torch::kCPU, torch::kUInt8)
                                  .contiguous();
      DFO_CHECK(m.numel() == static_cast<int64_t>(level.width) * level.height) << "mask " << l;
      level.mask.assign(m.data_ptr<uint8_t>(), m.data_ptr<uint8_t>() + m.numel());
    }
    out.levels.push_back(std::move(level));
  }
  return out;
}

DepthPyramid ToDepthPyramid(const AlignmentView& view) {
  DepthPyramid out;
  for (size_t l = 0; l < view.depth.size(); ++l) {
    const torch::Tensor d = view.depth[l].detach().to(torch::kCPU, torch::kFloat32).contiguous();
    const int64_t h = d.size(-2), w = d.size(-1);
    ImageF image(static_cast<int>(w), static_cast<int>(h), 1);
    const float* src = d.data_ptr<float>();
    for (int64_t y = 0; y < h; ++y) {
      for (int64_t x = 0; x < w; ++x) {
        const float z = src[y * w + x];
        image(static_cast<int>(x), static_cast<int>(y)) = std::isfinite(z) && z > 0.0f ? z : 0.0f;
      }
    }
    out.levels.push_back(std::move(image));
  }
  return out;
}

namespace {

// Reference data of one level (the tensors carry the autograd history).
struct LevelData {
  int num_patches = 0;
  int patch_pixels = 0;
  torch::Tensor points;     // M x 3 double, p = d K^-1 u
  torch::Tensor values;     // M x C float, F_ref(u)
  torch::Tensor jacobians;  // M x C x 6 double
  torch::Tensor hessians;   // N x 6 x 6 double, per patch sum of J^T J
  torch::Tensor weights;    // N double (ones without masks)
  double mean_depth = 0.0;  // detached, for the convergence test
};

LevelData BuildLevel(const Tracker& tracker, int level, const AlignmentView& ref, int patch_size) {
  LevelData lv;
  const std::vector<Eigen::Vector2i> centres = tracker.reference_points(level);
  lv.num_patches = static_cast<int>(centres.size());
  lv.patch_pixels = patch_size * patch_size;
  lv.mean_depth = tracker.reference_mean_depth(level);
  if (lv.num_patches == 0) return lv;
  const torch::Tensor& f = ref.features[level];
  const int64_t c = f.size(0), h = f.size(1), w = f.size(2);
  const PinholeCamera& cam = ref.cameras[level];
  const int half = patch_size / 2;
  // Pixel coordinates of every patch pixel, in the tracker's order (patch by patch, rows of dx).
  std::vector<int64_t> xs, ys;
  xs.reserve(static_cast<size_t>(lv.num_patches) * lv.patch_pixels);
  ys.reserve(xs.capacity());
  for (const Eigen::Vector2i& ctr : centres) {
    for (int dy = -half; dy <= half; ++dy) {
      for (int dx = -half; dx <= half; ++dx) {
        xs.push_back(ctr.x() + dx);
        ys.push_back(ctr.y() + dy);
      }
    }
  }
  // Index tensors on the features' device (the reference's tensors are all on one device).
  const auto long_opts = torch::TensorOptions().dtype(torch::kLong).device(f.device());
  const torch::Tensor x = torch::tensor(xs, long_opts), y = torch::tensor(ys, long_opts);
  const torch::Tensor flat = f.reshape({c, h * w});
  auto gather = [&](int64_t ox, int64_t oy) {
    return flat.index_select(1, (y + oy) * w + (x + ox)).transpose(0, 1);  // M x C
  };
  lv.values = gather(0, 0).contiguous();
  // Central differences, as the tracker (its point selection keeps one pixel of border).
  const torch::Tensor gx = (0.5 * (gather(1, 0) - gather(-1, 0))).to(torch::kFloat64);
  const torch::Tensor gy = (0.5 * (gather(0, 1) - gather(0, -1))).to(torch::kFloat64);
  const torch::Tensor d =
      ref.depth[level].reshape({h * w}).index_select(0, y * w + x).to(torch::kFloat64);
  const torch::Tensor xd = x.to(torch::kFloat64), yd = y.to(torch::kFloat64);
  const torch::Tensor px = (xd - cam.cx) / cam.fx * d, py = (yd - cam.cy) / cam.fy * d;
  lv.points = torch::stack({px, py, d}, 1);
  // du/d delta = dpi/dp [I, -hat(p)] written out (p = (X, Y, Z)):
  //   row u: [fx/Z, 0, -fx X/Z^2, -fx X Y/Z^2, fx (1 + X^2/Z^2), -fx Y/Z]
  //   row v: [0, fy/Z, -fy Y/Z^2, -fy (1 + Y^2/Z^2), fy X Y/Z^2, fy X/Z]
  const torch::Tensor iz = 1.0 / d, xz = px * iz, yz = py * iz;
  const torch::Tensor zero = torch::zeros_like(d);
  const torch::Tensor ju =
      cam.fx * torch::stack({iz, zero, -xz * iz, -xz * yz, 1.0 + xz * xz, -yz}, 1);
  const torch::Tensor jv =
      cam.fy * torch::stack({zero, iz, -yz * iz, -(1.0 + yz * yz), xz * yz, xz}, 1);
  lv.jacobians = gx.unsqueeze(2) * ju.unsqueeze(1) + gy.unsqueeze(2) * jv.unsqueeze(1);
  const torch::Tensor jp = lv.jacobians.reshape({lv.num_patches, lv.patch_pixels * c, 6});
  lv.hessians = torch::matmul(jp.transpose(1, 2), jp);
  if (static_cast<size_t>(level) < ref.masks.size() && ref.masks[level].defined()) {
    std::vector<int64_t> centre_idx;
    for (const Eigen::Vector2i& ctr : centres) centre_idx.push_back(ctr.y() * w + ctr.x());
    lv.weights = ref.masks[level]
                     .reshape({h * w})
                     .index_select(0, torch::tensor(centre_idx, long_opts))
                     .to(torch::kFloat64);
  } else {
    lv.weights = torch::ones({lv.num_patches}, Double().device(f.device()));
  }
  return lv;
}

// One evaluation at a pose: residuals, per-patch energy and gradient, validity.
struct Evaluation {
  torch::Tensor energy;    // N double (detached copy in energies)
  torch::Tensor gradient;  // N x 6 double, sum J^T r
  std::vector<double> energies;
  std::vector<uint8_t> valid;
  int num_valid = 0;
};

Evaluation Evaluate(const LevelData& lv, const torch::Tensor& cur, const PoseTensor& pose,
                    const PinholeCamera& cam, bool need_gradient) {
  Evaluation ev;
  const int64_t c = cur.size(0), h = cur.size(1), w = cur.size(2);
  const torch::Tensor q = torch::matmul(lv.points, pose.rotation.transpose(0, 1)) +
                          pose.translation.unsqueeze(0);  // M x 3
  const torch::Tensor z = q.select(1, 2);
  const torch::Tensor z_safe = torch::where(z > 1e-6, z, torch::ones_like(z));
  const torch::Tensor u = cam.fx * q.select(1, 0) / z_safe + cam.cx;
  const torch::Tensor v = cam.fy * q.select(1, 1) / z_safe + cam.cy;
  {
    torch::NoGradGuard no_grad;
    const torch::Tensor inside = ((z > 1e-6) & (u >= 0) & (v >= 0) & (u <= w - 1) & (v <= h - 1))
                                     .reshape({lv.num_patches, lv.patch_pixels})
                                     .all(1)
                                     .to(torch::kCPU, torch::kUInt8)
                                     .contiguous();
    ev.valid.assign(inside.data_ptr<uint8_t>(), inside.data_ptr<uint8_t>() + lv.num_patches);
  }
  // Bilinear sample (zeros outside; only patches fully inside are used).
  const torch::Tensor gx = (u * (2.0 / (w - 1)) - 1.0).to(torch::kFloat32);
  const torch::Tensor gy = (v * (2.0 / (h - 1)) - 1.0).to(torch::kFloat32);
  const torch::Tensor grid = torch::stack({gx, gy}, 1).view({1, 1, -1, 2});
  namespace F = torch::nn::functional;
  const torch::Tensor sampled = F::grid_sample(cur.to(torch::kFloat32).unsqueeze(0), grid,
                                               F::GridSampleFuncOptions()
                                                   .mode(torch::kBilinear)
                                                   .padding_mode(torch::kZeros)
                                                   .align_corners(true))
                                    .view({c, -1})
                                    .transpose(0, 1);                 // M x C
  const torch::Tensor r = (lv.values - sampled).to(torch::kFloat64);  // M x C
  const torch::Tensor rp = r.reshape({lv.num_patches, -1});
  ev.energy = (rp * rp).sum(1);
  {
    const torch::Tensor e = ev.energy.detach().to(torch::kCPU).contiguous();
    ev.energies.assign(e.data_ptr<double>(), e.data_ptr<double>() + lv.num_patches);
  }
  for (int i = 0; i < lv.num_patches; ++i) {
    if (!std::isfinite(ev.energies[i])) ev.valid[i] = 0;
    ev.num_valid += ev.valid[i];
  }
  if (need_gradient) {
    // g_i = sum over the patch's pixels and channels of J^T r.
    ev.gradient = (lv.jacobians * r.unsqueeze(2)).reshape({lv.num_patches, -1, 6}).sum(1);
  }
  return ev;
}

// Inlier flags (valid and energy <= the outlier threshold) and their count.
int Inliers(const Evaluation& ev, bool outlier_rule, std::vector<uint8_t>* inlier) {
  std::vector<double> energies;
  for (size_t i = 0; i < ev.valid.size(); ++i) {
    if (ev.valid[i]) energies.push_back(ev.energies[i]);
  }
  const double threshold =
      outlier_rule ? Tracker::OutlierThreshold(energies) : std::numeric_limits<double>::infinity();
  inlier->assign(ev.valid.size(), 0);
  int n = 0;
  for (size_t i = 0; i < ev.valid.size(); ++i) {
    if (ev.valid[i] && ev.energies[i] <= threshold) {
      (*inlier)[i] = 1;
      ++n;
    }
  }
  return n;
}

bool Finite(const PoseTensor& pose) {
  return torch::isfinite(pose.rotation.detach()).all().item<bool>() &&
         torch::isfinite(pose.translation.detach()).all().item<bool>();
}

// Tracker::AlignLevel with tensors. Returns the level stats; *pose is updated in place.
DiffGnLevelStats AlignLevel(const LevelData& lv, const torch::Tensor& cur, const PinholeCamera& cam,
                            const TrackerOptions& options, int level, PoseTensor* pose) {
  DiffGnLevelStats stats;
  stats.num_points = lv.num_patches;
  const int max_iterations = options.MaxIterations(level);
  const double threshold = options.ConvergenceThreshold(level);
  const double depth_scale = lv.mean_depth > 0.0 ? lv.mean_depth : 1.0;
  std::vector<uint8_t> inlier;
  PoseTensor current = *pose;
  for (int iteration = 0;; ++iteration) {
    Evaluation ev = Evaluate(lv, cur, current, cam, /*need_gradient=*/true);
    stats.iterations = iteration;
    if (ev.num_valid < kMinPatchesPerLevel) {
      stats.num_inliers = 0;
      *pose = current;
      return stats;  // not ok
    }
    const int inliers = Inliers(ev, options.outlier_rule, &inlier);
    stats.num_inliers = inliers;
    if (iteration >= max_iterations || inliers < kMinPatchesPerLevel) break;
    // Weighted sums over the inliers (fixed order, as the tracker).
    std::vector<int64_t> ids;
    for (int i = 0; i < lv.num_patches; ++i) {
      if (inlier[i]) ids.push_back(i);
    }
    const torch::Tensor idx =
        torch::tensor(ids, torch::TensorOptions().dtype(torch::kLong).device(lv.weights.device()));
    const torch::Tensor wts = lv.weights.index_select(0, idx);
    const torch::Tensor hess = (lv.hessians.index_select(0, idx) * wts.view({-1, 1, 1})).sum(0);
    const torch::Tensor grad = (ev.gradient.index_select(0, idx) * wts.view({-1, 1})).sum(0);
    // Gauss-Newton step of min |r + J delta|^2; the tracker's T <- T Exp(delta)^-1.
    torch::Tensor delta;
    try {
      delta = -torch::linalg::solve(hess, grad.unsqueeze(1), /*left=*/true).squeeze(1);
    } catch (const c10::Error&) {
      // A singular system (e.g. feature channels that are constant over the patches: zero
      // Jacobians) throws in torch where the tracker's LDLT gives a non-finite step: stop the
      // level as the tracker does (measured: it stopped a training run on its first step).
      break;
    }
    const torch::Tensor delta_detached = delta.detach();
    if (!torch::isfinite(delta_detached).all().item<bool>()) break;
    current = current.Compose(ExpSE3(-delta));
    torch::Tensor scaled = delta_detached.clone();
    scaled.slice(0, 0, 3).div_(depth_scale);
    if (scaled.norm().item<double>() < threshold) {
      // Converged: the final statistics at the updated pose (no gradient needed).
      torch::NoGradGuard no_grad;
      const Evaluation last = Evaluate(lv, cur, current, cam, /*need_gradient=*/false);
      stats.iterations = iteration + 1;
      if (last.num_valid < kMinPatchesPerLevel) {
        stats.num_inliers = 0;
        *pose = current;
        return stats;
      }
      stats.num_inliers = Inliers(last, options.outlier_rule, &inlier);
      break;
    }
  }
  *pose = current;
  stats.ok = stats.num_inliers >= kMinPatchesPerLevel && Finite(current);
  return stats;
}

}  // namespace

DiffGnResult DifferentiableAlign(const AlignmentView& ref, const AlignmentView& cur,
                                 const PoseTensor& start, const TrackerOptions& options) {
  const int num_levels = options.num_levels;
  if (static_cast<int>(ref.features.size()) < num_levels ||
      static_cast<int>(ref.depth.size()) < num_levels ||
      static_cast<int>(cur.features.size()) < num_levels ||
      static_cast<int>(ref.cameras.size()) < num_levels) {
    std::ostringstream msg;
    msg << "differentiable alignment: " << ref.features.size() << " reference feature, "
        << ref.depth.size() << " depth and " << cur.features.size()
        << " current feature levels given; tracker.num_levels = " << num_levels
        << " needs at least that many of each";
    throw InputError(msg.str());
  }
  for (int l = 0; l < num_levels; ++l) {
    if (ref.features[l].sizes() != cur.features[l].sizes()) {
      std::ostringstream msg;
      msg << "differentiable alignment: level " << l << " features " << cur.features[l].sizes()
          << " differ from the reference's " << ref.features[l].sizes();
      throw InputError(msg.str());
    }
  }
  // Point selection by the tracker itself on the detached maps: identical points by construction.
  Tracker tracker(options);
  FeaturePyramid selection = ToFeaturePyramid(ref);
  if (!ref.select_on_masks) {
    for (FeatureLevel& level : selection.levels) level.mask.clear();
  }
  tracker.SetReference(selection, ToDepthPyramid(ref));

  DiffGnResult result;
  result.levels.assign(num_levels, DiffGnLevelStats());
  // The start pose (often a CPU PoseTensor::FromSE3) on the reference's device.
  const torch::Device device = ref.features[0].device();
  PoseTensor pose{start.rotation.to(device, torch::kFloat64),
                  start.translation.to(device, torch::kFloat64)};
  if (tracker.num_reference_points(0) < std::max(options.min_inliers_lost, kMinPatchesPerLevel)) {
    result.cur_from_ref = pose;
    return result;
  }
  // Mean depths (differentiable) for the translation rescaling between levels.
  std::vector<torch::Tensor> mean_depth(num_levels);
  std::vector<double> mean_depth_value(num_levels);
  for (int l = 0; l < num_levels; ++l) {
    mean_depth[l] = MeanValidDepth(ref.depth[l]);
    mean_depth_value[l] = tracker.reference_mean_depth(l);
  }
  auto rescale = [&](int from, int to) {
    if (mean_depth_value[from] > 0.0 && mean_depth_value[to] > 0.0) {
      pose.translation = pose.translation * (mean_depth[to] / mean_depth[from]);
    }
  };
  rescale(0, num_levels - 1);
  bool finest_ok = false;
  for (int l = num_levels - 1; l >= 0; --l) {
    if (l < num_levels - 1) rescale(l + 1, l);
    if (tracker.num_reference_points(l) < kMinPatchesPerLevel) continue;
    const LevelData lv = BuildLevel(tracker, l, ref, options.patch_size);
    PoseTensor level_pose = pose;
    const DiffGnLevelStats stats =
        AlignLevel(lv, cur.features[l], ref.cameras[l], options, l, &level_pose);
    result.iterations += stats.iterations;
    result.levels[l] = stats;
    if (!stats.ok) {
      if (l == 0) break;
      continue;  // the tracker keeps the pose from before this level
    }
    pose = level_pose;
    if (l == 0) finest_ok = true;
  }
  result.cur_from_ref = pose;
  result.ok = finest_ok && Finite(pose);
  return result;
}

}  // namespace dfo::learned
