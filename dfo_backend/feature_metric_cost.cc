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
                                     std::shared_ptr<const std::vector<double>> host_patch)
    : target_(target),
      host_camera_(host_camera),
      host_uv_(host_uv),
      patch_size_(patch_size),
      host_patch_(std::move(host_patch)) {
  DFO_CHECK(target_ != nullptr && host_patch_ != nullptr);
  DFO_CHECK(patch_size_ >= 1 && patch_size_ % 2 == 1) << "patch_size " << patch_size_;
  DFO_CHECK(target_->width >= 2 && target_->height >= 2)
      << target_->width << "x" << target_->height;
  DFO_CHECK(host_patch_->size() ==
            static_cast<size_t>(target_->channels) * patch_size_ * patch_size_)
      << "host patch has " << host_patch_->size() << " values for " << target_->channels
      << " channels and K = " << patch_size_;
  set_num_residuals(target_->channels * patch_size_ * patch_size_);
  mutable_parameter_block_sizes()->assign({kPoseAmbientSize, kPoseAmbientSize, 1});
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

}  // namespace

int FeatureMetricCost::NumVisible(const double* host_pose, const double* target_pose,
                                  double inverse_depth) const {
  const WarpSetup s = MakeSetup(host_pose, target_pose);
  const int radius = patch_size_ / 2;
  const PinholeCamera& cam = target_->camera;
  int visible = 0;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const Eigen::Vector3d ray =
          host_camera_.Ray(Eigen::Vector2d(host_uv_.x() + dx, host_uv_.y() + dy));
      const Eigen::Vector3d Y = s.target_R_host * ray + inverse_depth * s.b;
      if (!(Y.z() > 1e-9)) continue;
      const Eigen::Vector2d p = cam.Project(Y);
      if (p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= target_->width - 1.0 &&
          p.y() <= target_->height - 1.0) {
        ++visible;
      }
    }
  }
  return visible;
}

bool FeatureMetricCost::EvaluateTangent(const double* host_pose, const double* target_pose,
                                        double inverse_depth, double* residuals,
                                        double* jacobian_host, double* jacobian_target,
                                        double* jacobian_inverse_depth) const {
  return EvaluateImpl(host_pose, target_pose, inverse_depth, residuals, jacobian_host,
                      jacobian_target, jacobian_inverse_depth, /*ambient=*/false);
}

// Tangent (N x 6) or ambient (N x 7, J_tangent * PoseMinusJacobian) pose Jacobians. The ambient
// conversion is folded into the 2 x 6 geometric Jacobian of each patch pixel (2 x 7 per pose),
// so it costs O(K^2), not O(C K^2), per block.
bool FeatureMetricCost::EvaluateImpl(const double* host_pose, const double* target_pose,
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
  const int radius = patch_size_ / 2;
  const int kk = patch_size_ * patch_size_;
  const int channels = target_->channels;
  const int width = target_->width, height = target_->height;
  const size_t plane = static_cast<size_t>(width) * height;
  const PinholeCamera& cam = target_->camera;
  const bool need_pose = jacobian_host != nullptr || jacobian_target != nullptr;
  const bool need_jac = need_pose || jacobian_inverse_depth != nullptr;
  const std::vector<double>& host_patch = *host_patch_;
  bool finite = true;

  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const int k = (dy + radius) * patch_size_ + (dx + radius);
      const Eigen::Vector3d ray =
          host_camera_.Ray(Eigen::Vector2d(host_uv_.x() + dx, host_uv_.y() + dy));
      const Eigen::Vector3d Y = s.target_R_host * ray + inverse_depth * s.b;
      if (!(Y.z() > 1e-9)) {
        // Behind the target camera: compared against the z-scored mean (0), no derivative.
        for (int c = 0; c < channels; ++c) {
          const int row = c * kk + k;
          residuals[row] = host_patch[row];
          if (jacobian_host) std::fill_n(jacobian_host + pose_cols * row, pose_cols, 0.0);
          if (jacobian_target) std::fill_n(jacobian_target + pose_cols * row, pose_cols, 0.0);
          if (jacobian_inverse_depth) jacobian_inverse_depth[row] = 0.0;
        }
        continue;
      }
      // Outside the image the projection is clamped to the border (the derivative along a
      // clamped axis is 0). A zero residual there would reward moving points out of view, a
      // cost sink that converged windows fell into (measured: metres of drift on the synthetic
      // sequence).
      Eigen::Vector2d p = cam.Project(Y);
      const bool clamp_x = !(p.x() >= 0.0 && p.x() <= width - 1.0);
      const bool clamp_y = !(p.y() >= 0.0 && p.y() <= height - 1.0);
      if (clamp_x) p.x() = p.x() < 0.0 ? 0.0 : (p.x() > width - 1.0 ? width - 1.0 : 0.0);
      if (clamp_y) p.y() = p.y() < 0.0 ? 0.0 : (p.y() > height - 1.0 ? height - 1.0 : 0.0);
      // Bilinear cell: x0 in [0, width - 2] so that x0 + 1 is valid and ax in [0, 1].
      const int x0 = std::min(static_cast<int>(std::floor(p.x())), width - 2);
      const int y0 = std::min(static_cast<int>(std::floor(p.y())), height - 2);
      const double ax = p.x() - x0, ay = p.y() - y0;
      const size_t i00 = static_cast<size_t>(y0) * width + x0;

      // Geometric part: d p / d [d_host (6), rho (1)] = dpi/dY [dY/d d_host, dY/d rho].
      Eigen::Matrix<double, 2, 7> dp;
      Eigen::Matrix<double, 2, 7> dp_host_amb, dp_target_amb;  // ambient, when asked
      if (need_jac) {
        const Eigen::Matrix<double, 2, 3> dpi = cam.ProjectJacobian(Y);
        if (need_pose) {
          const Eigen::Vector3d Zw = s.Rh * ray + inverse_depth * s.th;
          Eigen::Matrix<double, 3, 6> dY;
          dY.leftCols<3>() = inverse_depth * s.Rt_T;
          dY.rightCols<3>() = -s.Rt_T * SO3d::Hat(Zw);
          dp.leftCols<6>() = dpi * dY;
        } else {
          dp.leftCols<6>().setZero();
        }
        dp.col(6) = dpi * s.b;
        if (ambient && jacobian_host) dp_host_amb = dp.leftCols<6>() * minus_host;
        if (ambient && jacobian_target) dp_target_amb = -dp.leftCols<6>() * minus_target;
      }
      for (int c = 0; c < channels; ++c) {
        const float* f = target_->data.data() + c * plane + i00;
        const double v00 = f[0], v10 = f[1], v01 = f[width], v11 = f[width + 1];
        const double value =
            (1.0 - ay) * ((1.0 - ax) * v00 + ax * v10) + ay * ((1.0 - ax) * v01 + ax * v11);
        const int row = c * kk + k;
        residuals[row] = host_patch[row] - value;
        if (!need_jac) continue;
        const double gx = clamp_x ? 0.0 : (1.0 - ay) * (v10 - v00) + ay * (v11 - v01);
        const double gy = clamp_y ? 0.0 : (1.0 - ax) * (v01 - v00) + ax * (v11 - v10);
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
  const int n = num_residuals();
  for (int i = 0; i < n && finite; ++i) finite = std::isfinite(residuals[i]);
  return finite;
}

bool FeatureMetricCost::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  return EvaluateImpl(parameters[0], parameters[1], parameters[2][0], residuals,
                      jacobians ? jacobians[0] : nullptr, jacobians ? jacobians[1] : nullptr,
                      jacobians ? jacobians[2] : nullptr, /*ambient=*/true);
}

}  // namespace dfo
