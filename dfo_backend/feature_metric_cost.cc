#include "dfo_backend/feature_metric_cost.h"

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
  DFO_CHECK(target_->width >= 2 && target_->height >= 2) << target_->width << "x"
                                                         << target_->height;
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
      const Eigen::Vector3d ray = host_camera_.Ray(Eigen::Vector2d(host_uv_.x() + dx,
                                                                   host_uv_.y() + dy));
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
  const WarpSetup s = MakeSetup(host_pose, target_pose);
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
      bool inside = Y.z() > 1e-9;
      Eigen::Vector2d p(0.0, 0.0);
      if (inside) {
        p = cam.Project(Y);
        inside = p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= width - 1.0 && p.y() <= height - 1.0;
      }
      if (!inside) {
        // Out of view: no information from this pixel (zero residual, zero Jacobian rows).
        for (int c = 0; c < channels; ++c) {
          const int row = c * kk + k;
          residuals[row] = 0.0;
          if (jacobian_host) std::fill_n(jacobian_host + 6 * row, 6, 0.0);
          if (jacobian_target) std::fill_n(jacobian_target + 6 * row, 6, 0.0);
          if (jacobian_inverse_depth) jacobian_inverse_depth[row] = 0.0;
        }
        continue;
      }
      // Bilinear cell: x0 in [0, width - 2] so that x0 + 1 is valid and ax in [0, 1].
      const int x0 = std::min(static_cast<int>(std::floor(p.x())), width - 2);
      const int y0 = std::min(static_cast<int>(std::floor(p.y())), height - 2);
      const double ax = p.x() - x0, ay = p.y() - y0;
      const size_t i00 = static_cast<size_t>(y0) * width + x0;

      // Geometric part: d p / d [d_host (6), rho (1)] = dpi/dY [dY/d d_host, dY/d rho].
      Eigen::Matrix<double, 2, 7> dp;
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
      }
      for (int c = 0; c < channels; ++c) {
        const float* f = target_->data.data() + c * plane + i00;
        const double v00 = f[0], v10 = f[1], v01 = f[width], v11 = f[width + 1];
        const double value =
            (1.0 - ay) * ((1.0 - ax) * v00 + ax * v10) + ay * ((1.0 - ax) * v01 + ax * v11);
        const int row = c * kk + k;
        residuals[row] = host_patch[row] - value;
        if (!need_jac) continue;
        const double gx = (1.0 - ay) * (v10 - v00) + ay * (v11 - v01);
        const double gy = (1.0 - ax) * (v01 - v00) + ax * (v11 - v10);
        const Eigen::Matrix<double, 1, 7> row_jac = -(gx * dp.row(0) + gy * dp.row(1));
        if (jacobian_host) {
          Eigen::Map<Eigen::Matrix<double, 1, 6>>(jacobian_host + 6 * row) = row_jac.head<6>();
        }
        if (jacobian_target) {
          Eigen::Map<Eigen::Matrix<double, 1, 6>>(jacobian_target + 6 * row) = -row_jac.head<6>();
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
  const int n = num_residuals();
  if (jacobians == nullptr) {
    return EvaluateTangent(parameters[0], parameters[1], parameters[2][0], residuals, nullptr,
                           nullptr, nullptr);
  }
  RowMajorMatrixXd j_host, j_target;
  if (jacobians[0]) j_host.resize(n, 6);
  if (jacobians[1]) j_target.resize(n, 6);
  const bool ok = EvaluateTangent(parameters[0], parameters[1], parameters[2][0], residuals,
                                  jacobians[0] ? j_host.data() : nullptr,
                                  jacobians[1] ? j_target.data() : nullptr, jacobians[2]);
  if (!ok) return false;
  using AmbientJacobian = Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor>;
  if (jacobians[0]) {
    Eigen::Map<AmbientJacobian>(jacobians[0], n, 7) = j_host * PoseMinusJacobian(parameters[0]);
  }
  if (jacobians[1]) {
    Eigen::Map<AmbientJacobian>(jacobians[1], n, 7) = j_target * PoseMinusJacobian(parameters[1]);
  }
  return true;
}

}  // namespace dfo
