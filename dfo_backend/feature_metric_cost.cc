#include "dfo_backend/feature_metric_cost.h"

#include <algorithm>
#include <cmath>

#include "dfo_backend/pose_manifold.h"
#include "dfo_core/error.h"
#include "dfo_core/lie.h"

namespace dfo {

std::vector<double> SampleHostPatch(const FeatureLevel& level, int x, int y, int patch_size) {
  const int radius = patch_size / 2;
  DFO_CHECK(patch_size >= 1 && patch_size % 2 == 1) << "patch_size " << patch_size;
  DFO_CHECK(x - radius >= 0 && y - radius >= 0 && x + radius < level.width &&
            y + radius < level.height)
      << "patch at (" << x << ", " << y << ") leaves the " << level.width << "x" << level.height
      << " level";
  const int kk = patch_size * patch_size;
  std::vector<double> patch(static_cast<size_t>(level.channels) * kk);
  for (int c = 0; c < level.channels; ++c) {
    for (int dy = -radius; dy <= radius; ++dy) {
      for (int dx = -radius; dx <= radius; ++dx) {
        const int k = (dy + radius) * patch_size + (dx + radius);
        patch[static_cast<size_t>(c) * kk + k] = level.At(c, x + dx, y + dy);
      }
    }
  }
  return patch;
}

std::shared_ptr<const std::vector<double>> ZoomScaledPatch(const std::vector<double>& patch,
                                                           const std::vector<int>& orders,
                                                           int patch_size, double zoom) {
  if (std::all_of(orders.begin(), orders.end(), [](int n) { return n == 0; })) return nullptr;
  const size_t pixels = static_cast<size_t>(patch_size) * patch_size;
  auto scaled = std::make_shared<std::vector<double>>(patch);
  for (size_t c = 0; c < orders.size() && (c + 1) * pixels <= scaled->size(); ++c) {
    if (orders[c] == 0) continue;
    const double factor = std::pow(zoom, -orders[c]);
    for (size_t k = c * pixels; k < (c + 1) * pixels; ++k) (*scaled)[k] *= factor;
  }
  return scaled;
}

bool SampleHostPatchBilinear(const FeatureLevel& level, const Eigen::Vector2d& uv, int patch_size,
                             std::vector<double>* patch) {
  DFO_CHECK(patch_size >= 1 && patch_size % 2 == 1) << "patch_size " << patch_size;
  const int radius = patch_size / 2;
  const int w = level.width, h = level.height;
  if (!(uv.x() - radius >= 0.0 && uv.y() - radius >= 0.0 && uv.x() + radius <= w - 1.0 &&
        uv.y() + radius <= h - 1.0)) {
    return false;
  }
  const int kk = patch_size * patch_size;
  patch->assign(static_cast<size_t>(level.channels) * kk, 0.0);
  const size_t plane = static_cast<size_t>(w) * h;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const double x = uv.x() + dx, y = uv.y() + dy;
      const int x0 = std::min(static_cast<int>(std::floor(x)), w - 2);
      const int y0 = std::min(static_cast<int>(std::floor(y)), h - 2);
      const double ax = x - x0, ay = y - y0;
      const int k = (dy + radius) * patch_size + (dx + radius);
      for (int c = 0; c < level.channels; ++c) {
        const float* f = level.data.data() + c * plane + static_cast<size_t>(y0) * w + x0;
        (*patch)[static_cast<size_t>(c) * kk + k] =
            (1.0 - ay) * ((1.0 - ax) * f[0] + ax * f[1]) + ay * ((1.0 - ax) * f[w] + ax * f[w + 1]);
      }
    }
  }
  return true;
}

FeatureMetricCost::FeatureMetricCost(const FeatureLevel* target, const PinholeCamera& host_camera,
                                     const Eigen::Vector2d& host_uv, int patch_size,
                                     std::shared_ptr<const std::vector<double>> host_patch,
                                     std::shared_ptr<const std::vector<double>> depth_shape) {
  DFO_CHECK(target != nullptr && host_patch != nullptr);
  DFO_CHECK(depth_shape == nullptr ||
            depth_shape->size() == static_cast<size_t>(patch_size) * patch_size)
      << "depth shape of " << depth_shape->size() << " values for K = " << patch_size;
  DFO_CHECK(patch_size >= 1 && patch_size % 2 == 1) << "patch_size " << patch_size;
  DFO_CHECK(target->width >= 2 && target->height >= 2) << target->width << "x" << target->height;
  DFO_CHECK(host_patch->size() == static_cast<size_t>(target->channels) * patch_size * patch_size)
      << "host patch has " << host_patch->size() << " values for " << target->channels
      << " channels and K = " << patch_size;
  set_num_residuals(target->channels * patch_size * patch_size);
  mutable_parameter_block_sizes()->assign({kPoseAmbientSize, kPoseAmbientSize, 1});
  block_.target = target;
  block_.host_patch = host_patch->data();
  block_.host_patch_owner = std::move(host_patch);
  block_.center_ray = host_camera.Ray(host_uv);
  block_.ray_step_x = 1.0 / host_camera.fx;
  block_.ray_step_y = 1.0 / host_camera.fy;
  block_.patch_size = patch_size;
  if (depth_shape) {
    block_.depth_shape = depth_shape->data();
    block_.depth_shape_owner = std::move(depth_shape);
  }
}

namespace {

// Geometry shared by all patch pixels of one evaluation (see the header's derivation).
struct WarpSetup {
  Eigen::Matrix3d target_R_host;  // R_t^T R_h
  Eigen::Vector3d b;              // R_t^T (t_h - t_t) = dY / d rho
  Eigen::Matrix3d Rt_T;           // R_t^T
  Eigen::Matrix3d Rh;
  Eigen::Vector3d th;
};

WarpSetup MakeSetup(const double* host_pose, const double* target_pose) {
  const SE3d host = PoseFromParameters(host_pose);
  const SE3d target = PoseFromParameters(target_pose);
  WarpSetup s;
  s.Rh = host.rotationMatrix();
  s.Rt_T = target.rotationMatrix().transpose();
  s.th = host.translation();
  s.target_R_host = s.Rt_T * s.Rh;
  s.b = s.Rt_T * (host.translation() - target.translation());
  return s;
}

// The bilinear cell where a patch pixel (target camera coordinates Y, in front) is sampled.
// Outside the image the projection is clamped to the border (the derivative along a clamped axis
// is 0). A zero residual there would reward moving points out of view, a cost sink that converged
// windows fell into (measured: metres of drift on the synthetic sequence).
struct Cell {
  bool clamp_x, clamp_y;
  size_t i00;     // top-left pixel of the cell: x0 in [0, width - 2], so x0 + 1 is valid
  double ax, ay;  // position inside the cell, in [0, 1]
};

inline Cell CellAt(const PinholeCamera& cam, const Eigen::Vector3d& Y, int width, int height) {
  Eigen::Vector2d p = cam.Project(Y);
  Cell cell;
  cell.clamp_x = !(p.x() >= 0.0 && p.x() <= width - 1.0);
  cell.clamp_y = !(p.y() >= 0.0 && p.y() <= height - 1.0);
  if (cell.clamp_x) p.x() = p.x() < 0.0 ? 0.0 : (p.x() > width - 1.0 ? width - 1.0 : 0.0);
  if (cell.clamp_y) p.y() = p.y() < 0.0 ? 0.0 : (p.y() > height - 1.0 ? height - 1.0 : 0.0);
  // p is in [0, width - 1] x [0, height - 1] here, so truncation is floor (and cheaper).
  const int x0 = std::min(static_cast<int>(p.x()), width - 2);
  const int y0 = std::min(static_cast<int>(p.y()), height - 2);
  cell.ax = p.x() - x0;
  cell.ay = p.y() - y0;
  cell.i00 = static_cast<size_t>(y0) * width + x0;
  return cell;
}

// The bilinear interpolant of one channel plane at `cell` and its gradient (0 along a clamped
// axis).
struct Sample {
  double value, gx, gy;
};

inline Sample Interpolate(const float* plane, int width, const Cell& cell) {
  const float* f = plane + cell.i00;
  const double v00 = f[0], v10 = f[1], v01 = f[width], v11 = f[width + 1];
  const double ax = cell.ax, ay = cell.ay;
  Sample out;
  out.value = (1.0 - ay) * ((1.0 - ax) * v00 + ax * v10) + ay * ((1.0 - ax) * v01 + ax * v11);
  out.gx = cell.clamp_x ? 0.0 : (1.0 - ay) * (v10 - v00) + ay * (v11 - v01);
  out.gy = cell.clamp_y ? 0.0 : (1.0 - ax) * (v01 - v00) + ax * (v11 - v10);
  return out;
}

// d p / d [d_host (6), rho (1)] of one patch pixel, 2 x 7: dpi [dY/d d_host, dY/d rho] with
// dY/d d_host = [rho R_t^T, -R_t^T hat(Z_w)] and dY/d rho = b. With Q = dpi R_t^T (2 x 3):
// rho Q, and -q^T hat(Z_w) = (Z_w x q)^T for each row q of Q.
inline Eigen::Matrix<double, 2, 7> PixelJacobian(const WarpSetup& s, const PinholeCamera& cam,
                                                 const Eigen::Vector3d& Y,
                                                 const Eigen::Vector3d& ray, double inverse_depth) {
  const Eigen::Matrix<double, 2, 3> dpi = cam.ProjectJacobian(Y);
  const Eigen::Matrix<double, 2, 3> q = dpi * s.Rt_T;
  const Eigen::Vector3d Zw = s.Rh * ray + inverse_depth * s.th;
  Eigen::Matrix<double, 2, 7> dp;
  for (int a = 0; a < 2; ++a) {
    const Eigen::Vector3d qa = q.row(a).transpose();
    dp.row(a).head<3>() = inverse_depth * qa.transpose();
    dp.row(a).segment<3>(3) = Zw.cross(qa).transpose();
  }
  dp.col(6) = dpi * s.b;
  return dp;
}

// Patch pixel k behind the target camera is compared against the z-scored mean (0): its C
// residuals are the host values (no derivative).
void FillBehindCamera(const double* host_patch, int k, int kk, int channels, double* residuals) {
  for (int c = 0; c < channels; ++c) residuals[c * kk + k] = host_patch[c * kk + k];
}

}  // namespace

int FeatureMetricBlock::NumVisible(const double* host_pose, const double* target_pose,
                                   double inverse_depth) const {
  const WarpSetup s = MakeSetup(host_pose, target_pose);
  const int radius = patch_size / 2;
  const PinholeCamera& cam = target->camera;
  int visible = 0;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const Eigen::Vector3d ray = Ray((dy + radius) * patch_size + (dx + radius));
      const Eigen::Vector3d Y = s.target_R_host * ray + inverse_depth * s.b;
      if (!(Y.z() > 1e-9)) continue;
      const Eigen::Vector2d p = cam.Project(Y);
      if (p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= target->width - 1.0 &&
          p.y() <= target->height - 1.0) {
        ++visible;
      }
    }
  }
  return visible;
}

Eigen::Vector2d FeatureMetricBlock::WarpStretch(const double* host_pose, const double* target_pose,
                                                double inverse_depth) const {
  const WarpSetup s = MakeSetup(host_pose, target_pose);
  const Eigen::Vector3d Y = s.target_R_host * center_ray + inverse_depth * s.b;
  if (!(Y.z() > 1e-9)) return Eigen::Vector2d::Zero();
  // p = pi(Y(u)) with dY/du = target_R_host diag(1 / fx, 1 / fy): the ray's pixel derivative at
  // the point's (constant) inverse depth.
  Eigen::Matrix<double, 3, 2> dY_du;
  dY_du.col(0) = s.target_R_host.col(0) * ray_step_x;
  dY_du.col(1) = s.target_R_host.col(1) * ray_step_y;
  const Eigen::Matrix2d a = target->camera.ProjectJacobian(Y) * dY_du;
  // Singular values of a 2 x 2 matrix in closed form: with e, f, g, h below,
  // sigma = sqrt(e^2 + h^2) +- sqrt(f^2 + g^2).
  const double e = 0.5 * (a(0, 0) + a(1, 1)), f = 0.5 * (a(0, 0) - a(1, 1));
  const double g = 0.5 * (a(1, 0) + a(0, 1)), h = 0.5 * (a(1, 0) - a(0, 1));
  const double q = std::hypot(e, h), r = std::hypot(f, g);
  return Eigen::Vector2d(q + r, std::abs(q - r));
}

bool FeatureMetricCost::EvaluateTangent(const double* host_pose, const double* target_pose,
                                        double inverse_depth, double* residuals,
                                        double* jacobian_host, double* jacobian_target,
                                        double* jacobian_inverse_depth) const {
  return block_.Evaluate(host_pose, target_pose, inverse_depth, residuals, jacobian_host,
                         jacobian_target, jacobian_inverse_depth, /*ambient=*/false);
}

// Tangent (N x 6) or ambient (N x 7, J_tangent * PoseMinusJacobian) pose Jacobians. The ambient
// conversion is folded into the 2 x 6 geometric Jacobian of each patch pixel (2 x 7 per pose),
// so it costs O(K^2), not O(C K^2), per block.
bool FeatureMetricBlock::Evaluate(const double* host_pose, const double* target_pose,
                                  double inverse_depth, double* residuals, double* jacobian_host,
                                  double* jacobian_target, double* jacobian_inverse_depth,
                                  bool ambient) const {
  const WarpSetup s = MakeSetup(host_pose, target_pose);
  const int pose_cols = ambient ? kPoseAmbientSize : kPoseTangentSize;
  Matrix6x7d minus_host = Matrix6x7d::Zero(), minus_target = Matrix6x7d::Zero();
  if (ambient) {
    if (jacobian_host) minus_host = PoseMinusJacobian(host_pose);
    if (jacobian_target) minus_target = PoseMinusJacobian(target_pose);
  }
  const int radius = patch_size / 2;
  const int kk = patch_size * patch_size;
  const int channels = target->channels;
  const int width = target->width, height = target->height;
  const PinholeCamera& cam = target->camera;
  const bool need_pose = jacobian_host != nullptr || jacobian_target != nullptr;
  const bool need_jac = need_pose || jacobian_inverse_depth != nullptr;
  bool finite = true;

  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const int k = (dy + radius) * patch_size + (dx + radius);
      const Eigen::Vector3d ray = Ray(k);
      const Eigen::Vector3d Y = s.target_R_host * ray + inverse_depth * s.b;
      if (!(Y.z() > 1e-9)) {
        FillBehindCamera(host_patch, k, kk, channels, residuals);
        for (int c = 0; c < channels; ++c) {
          const int row = c * kk + k;
          if (jacobian_host) std::fill_n(jacobian_host + pose_cols * row, pose_cols, 0.0);
          if (jacobian_target) std::fill_n(jacobian_target + pose_cols * row, pose_cols, 0.0);
          if (jacobian_inverse_depth) jacobian_inverse_depth[row] = 0.0;
        }
        continue;
      }
      const Cell cell = CellAt(cam, Y, width, height);

      // Geometric part: d p / d [d_host (6), rho (1)].
      Eigen::Matrix<double, 2, 7> dp = Eigen::Matrix<double, 2, 7>::Zero();
      Eigen::Matrix<double, 2, 7> dp_host_amb, dp_target_amb;  // ambient, when asked
      if (need_jac) {
        dp = PixelJacobian(s, cam, Y, ray, inverse_depth);
        if (ambient && jacobian_host) dp_host_amb = dp.leftCols<6>() * minus_host;
        if (ambient && jacobian_target) dp_target_amb = -dp.leftCols<6>() * minus_target;
      }
      for (int c = 0; c < channels; ++c) {
        const Sample v = Interpolate(target->Channel(c), width, cell);
        const int row = c * kk + k;
        residuals[row] = host_patch[row] - v.value;
        if (!need_jac) continue;
        const double gx = v.gx, gy = v.gy;
        const Eigen::Matrix<double, 1, 7> row_jac = -(gx * dp.row(0) + gy * dp.row(1));
        if (ambient) {
          if (jacobian_host) {
            Eigen::Map<Eigen::Matrix<double, 1, 7>> out(jacobian_host + 7 * row);
            out = -(gx * dp_host_amb.row(0) + gy * dp_host_amb.row(1));
          }
          if (jacobian_target) {
            Eigen::Map<Eigen::Matrix<double, 1, 7>> out(jacobian_target + 7 * row);
            out = -(gx * dp_target_amb.row(0) + gy * dp_target_amb.row(1));
          }
        } else {
          if (jacobian_host) {
            Eigen::Map<Eigen::Matrix<double, 1, 6>> out(jacobian_host + 6 * row);
            out = row_jac.head<6>();
          }
          if (jacobian_target) {
            Eigen::Map<Eigen::Matrix<double, 1, 6>> out(jacobian_target + 6 * row);
            out = -row_jac.head<6>();
          }
        }
        if (jacobian_inverse_depth) jacobian_inverse_depth[row] = row_jac(6);
      }
    }
  }
  const int n = target->channels * patch_size * patch_size;
  for (int i = 0; i < n && finite; ++i) finite = std::isfinite(residuals[i]);
  return finite;
}

// The rows of [A c r] for the C channels of one patch pixel k share the pixel's geometric
// Jacobian: row = [-(gx d0 + gy d1); r] with d0, d1 the rows of dp = d p_k / d [d_host, rho]
// (7-vectors) and (gx, gy) the channel's interpolant gradient. So the pixel adds
//   G_77 += D W D^T,  G_7r -= D w,  G_rr += sum r^2,   D = [d0 d1] (7 x 2),
// with W = sum_c (gx, gy)^T (gx, gy) and w = sum_c (gx, gy)^T r: the per-channel work is six
// products instead of a 8 x 8 outer product per row.
bool FeatureMetricBlock::EvaluateGram(const double* host_pose, const double* target_pose,
                                      double inverse_depth, double* residuals,
                                      Eigen::Matrix<double, 8, 8>* gram) const {
  const WarpSetup s = MakeSetup(host_pose, target_pose);
  const int kk = patch_size * patch_size;
  const int channels = target->channels;
  const int width = target->width, height = target->height;
  const PinholeCamera& cam = target->camera;
  Eigen::Matrix<double, 7, 7> g77 = Eigen::Matrix<double, 7, 7>::Zero();
  Eigen::Matrix<double, 7, 1> g7r = Eigen::Matrix<double, 7, 1>::Zero();
  double grr = 0.0;
  for (int k = 0; k < kk; ++k) {
    const Eigen::Vector3d ray = Ray(k);
    const Eigen::Vector3d Y = s.target_R_host * ray + inverse_depth * s.b;
    if (!(Y.z() > 1e-9)) {
      FillBehindCamera(host_patch, k, kk, channels, residuals);
      for (int c = 0; c < channels; ++c) grr += residuals[c * kk + k] * residuals[c * kk + k];
      continue;
    }
    const Cell cell = CellAt(cam, Y, width, height);
    // D = [d0 d1] = dp^T (7 x 2).
    const Eigen::Matrix<double, 7, 2> d = PixelJacobian(s, cam, Y, ray, inverse_depth).transpose();
    double wxx = 0.0, wxy = 0.0, wyy = 0.0, wxr = 0.0, wyr = 0.0, wrr = 0.0;
    for (int c = 0; c < channels; ++c) {
      const Sample v = Interpolate(target->Channel(c), width, cell);
      const int row = c * kk + k;
      const double r = host_patch[row] - v.value;
      residuals[row] = r;
      const double gx = v.gx, gy = v.gy;
      wxx += gx * gx;
      wxy += gx * gy;
      wyy += gy * gy;
      wxr += gx * r;
      wyr += gy * r;
      wrr += r * r;
    }
    Eigen::Matrix2d w;
    w << wxx, wxy, wxy, wyy;
    const Eigen::Matrix<double, 7, 2> dw = d * w;
    g77.noalias() += dw * d.transpose();
    g7r.noalias() -= d * Eigen::Vector2d(wxr, wyr);
    grr += wrr;
  }
  gram->topLeftCorner<7, 7>() = g77;
  gram->col(7).head<7>() = g7r;
  gram->row(7).head<7>() = g7r.transpose();
  (*gram)(7, 7) = grr;
  bool finite = gram->allFinite();
  const int n = target->channels * patch_size * patch_size;
  for (int i = 0; i < n && finite; ++i) finite = std::isfinite(residuals[i]);
  return finite;
}

bool FeatureMetricCost::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  return block_.Evaluate(parameters[0], parameters[1], parameters[2][0], residuals,
                         jacobians ? jacobians[0] : nullptr, jacobians ? jacobians[1] : nullptr,
                         jacobians ? jacobians[2] : nullptr, /*ambient=*/true);
}

CompressedFeatureMetricCost::CompressedFeatureMetricCost(const FeatureMetricCost* cost) {
  DFO_CHECK(cost != nullptr);
  block_ = cost->block();
  num_full_residuals_ = cost->num_residuals();
}

namespace {

// Whether the 15 parameters x are host_pose, target_pose, inverse_depth: bitwise equality (as
// Ceres hands back the values it evaluated at); NaN never matches.
bool SameParameters(const double* x, const double* host_pose, const double* target_pose,
                    double inverse_depth) {
  for (int i = 0; i < kPoseAmbientSize; ++i) {
    if (x[i] != host_pose[i] || x[kPoseAmbientSize + i] != target_pose[i]) return false;
  }
  return x[2 * kPoseAmbientSize] == inverse_depth;
}

void StoreParameters(const double* host_pose, const double* target_pose, double inverse_depth,
                     double* x) {
  std::copy(host_pose, host_pose + kPoseAmbientSize, x);
  std::copy(target_pose, target_pose + kPoseAmbientSize, x + kPoseAmbientSize);
  x[2 * kPoseAmbientSize] = inverse_depth;
}

}  // namespace

bool CompressedFeatureMetricCost::Hit(const double* host_pose, const double* target_pose,
                                      double inverse_depth) const {
  return cache_.valid && SameParameters(cache_.parameters, host_pose, target_pose, inverse_depth);
}

bool CompressedFeatureMetricCost::NormHit(const double* host_pose, const double* target_pose,
                                          double inverse_depth) const {
  return norm_cache_.valid &&
         SameParameters(norm_cache_.parameters, host_pose, target_pose, inverse_depth);
}

bool CompressedFeatureMetricCost::CachedSquaredNorm(const double* host_pose,
                                                    const double* target_pose, double inverse_depth,
                                                    double* squared_norm) const {
  if (!Hit(host_pose, target_pose, inverse_depth)) return false;
  *squared_norm = cache_.squared_norm;
  return true;
}

namespace {

// Scratch for a block's full residual vector; per thread (Ceres evaluates blocks in parallel).
std::vector<double>& FullResidualScratch(int size) {
  thread_local std::vector<double> full;
  full.resize(static_cast<size_t>(size));
  return full;
}

double SquaredNorm(const std::vector<double>& values) {
  double sq = 0.0;
  for (double v : values) sq += v * v;
  return sq;
}

}  // namespace

// Pivoted outer-product Cholesky of the Gram matrix over its 7 parameter columns, the residual
// column (7) last and never a pivot, stopped after 6 pivots (see the header).
bool CompressedFeatureMetricCost::Factorize(const double* host_pose, const double* target_pose,
                                            double inverse_depth) const {
  cache_.valid = false;
  std::vector<double>& full = FullResidualScratch(num_full_residuals_);
  Eigen::Matrix<double, 8, 8> s;  // the Gram matrix, then the running Schur complement
  if (!block_.EvaluateGram(host_pose, target_pose, inverse_depth, full.data(), &s)) return false;
  const double sq = SquaredNorm(full);
  // R: row i = the i-th row of L6^T in the original column order (zero rows past the rank).
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> r_factor(cache_.factor);
  Eigen::Map<Eigen::Matrix<double, kNumResiduals, 1>> r_c(cache_.residuals);
  r_factor.setZero();
  r_c.setZero();
  const double max_diagonal = s.diagonal().head<7>().maxCoeff();
  const double floor = 1e-15 * max_diagonal;
  bool done[7] = {false, false, false, false, false, false, false};
  double l_sq = 0.0;
  for (int i = 0; i < 6; ++i) {
    int p = -1;
    for (int j = 0; j < 7; ++j) {
      if (!done[j] && (p < 0 || s(j, j) > s(p, p))) p = j;
    }
    if (!(s(p, p) > floor) || !(max_diagonal > 0.0)) break;
    done[p] = true;
    const double pivot = std::sqrt(s(p, p));
    Eigen::Matrix<double, 8, 1> column = s.col(p) / pivot;
    for (int j = 0; j < 7; ++j) {
      if (done[j] && j != p) column(j) = 0.0;
    }
    column(p) = pivot;
    r_factor.row(i) = column.head<7>().transpose();
    r_c(i) = column(7);
    l_sq += column(7) * column(7);
    s.noalias() -= column * column.transpose();
  }
  r_c(6) = std::sqrt(std::max(sq - l_sq, 0.0));
  if (!r_c.allFinite()) return false;
  StoreParameters(host_pose, target_pose, inverse_depth, cache_.parameters);
  cache_.squared_norm = sq;
  cache_.valid = true;
  return true;
}

bool CompressedFeatureMetricCost::FullSquaredNorm(const double* host_pose,
                                                  const double* target_pose, double inverse_depth,
                                                  double* squared_norm) const {
  std::vector<double>& full = FullResidualScratch(num_full_residuals_);
  if (!block_.Evaluate(host_pose, target_pose, inverse_depth, full.data(), nullptr, nullptr,
                       nullptr, /*ambient=*/false)) {
    return false;
  }
  *squared_norm = SquaredNorm(full);
  return true;
}

void CompressedFeatureMetricCost::Prefetch(const double* host_pose, const double* target_pose,
                                           double inverse_depth, bool with_jacobians) const {
  if (Hit(host_pose, target_pose, inverse_depth)) return;
  if (with_jacobians) {
    Factorize(host_pose, target_pose, inverse_depth);  // on failure Evaluate fails as before
    return;
  }
  if (NormHit(host_pose, target_pose, inverse_depth)) return;
  norm_cache_.valid = false;
  double sq = 0.0;
  if (!FullSquaredNorm(host_pose, target_pose, inverse_depth, &sq)) return;
  StoreParameters(host_pose, target_pose, inverse_depth, norm_cache_.parameters);
  norm_cache_.squared_norm = sq;
  norm_cache_.valid = true;
}

bool CompressedFeatureMetricCost::Evaluate(double const* const* parameters, double* residuals,
                                           double** jacobians) const {
  const double* host_pose = parameters[0];
  const double* target_pose = parameters[1];
  const double inverse_depth = parameters[2][0];
  const bool any_jacobian = jacobians != nullptr && (jacobians[0] || jacobians[1] || jacobians[2]);
  const bool hit = Hit(host_pose, target_pose, inverse_depth);
  if (!any_jacobian) {
    double sq = 0.0;
    if (hit) {
      sq = cache_.squared_norm;
    } else if (NormHit(host_pose, target_pose, inverse_depth)) {
      sq = norm_cache_.squared_norm;
    } else if (!FullSquaredNorm(host_pose, target_pose, inverse_depth, &sq)) {
      return false;
    }
    std::fill_n(residuals, kNumResiduals, 0.0);
    residuals[0] = std::sqrt(sq);
    return std::isfinite(residuals[0]);
  }
  if (!hit && !Factorize(host_pose, target_pose, inverse_depth)) return false;
  const Eigen::Map<const Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> r_factor(cache_.factor);
  std::copy(cache_.residuals, cache_.residuals + kNumResiduals, residuals);
  using Jacobian = Eigen::Matrix<double, kNumResiduals, 7, Eigen::RowMajor>;
  if (jacobians[0]) {
    Eigen::Map<Jacobian> out(jacobians[0]);
    out.topRows<6>() = r_factor.leftCols<6>() * PoseMinusJacobian(host_pose);
    out.row(6).setZero();
  }
  if (jacobians[1]) {
    Eigen::Map<Jacobian> out(jacobians[1]);
    out.topRows<6>() = -r_factor.leftCols<6>() * PoseMinusJacobian(target_pose);
    out.row(6).setZero();
  }
  if (jacobians[2]) {
    Eigen::Map<Eigen::Matrix<double, kNumResiduals, 1>> out(jacobians[2]);
    out.head<6>() = r_factor.col(6);
    out(6) = 0.0;
  }
  return true;
}

}  // namespace dfo
