// Pose parameter blocks of the sliding window and their ceres::Manifold.
//
// A keyframe pose world_from_cam is stored in a parameter block of 7 doubles,
//   [qx, qy, qz, qw, tx, ty, tz]  (Eigen's quaternion coefficient order, then the translation),
// and perturbed on the LEFT in the world frame, as the rest of dfo (dfo_core/lie.h):
//   Plus(T, d)  = Exp(d) * T,          d = [upsilon; omega] in R^6,
//   Minus(Y, T) = Log(Y * T^-1).
// A global change of the world frame G (the gauge of monocular odometry) moves every pose by the
// same left factor, so it is the same tangent vector d for every keyframe; feature-metric
// residuals, which depend only on relative poses, are exactly invariant to it.
//
// Cost functions in dfo_backend compute their Jacobians in this tangent space (that is where the
// maths is simple) and hand Ceres ambient 7-column Jacobians J_ambient = J_tangent * M(T), with
// M(T) = MinusJacobian(T) (6x7), a left inverse of PlusJacobian(T) (7x6): Ceres multiplies by
// PlusJacobian and recovers J_tangent exactly (M P = I, tested).
#ifndef DFO_BACKEND_POSE_MANIFOLD_H_
#define DFO_BACKEND_POSE_MANIFOLD_H_

#include <ceres/manifold.h>

#include <Eigen/Core>

#include "dfo_core/lie.h"

namespace dfo {

// Size of a pose parameter block (ambient) and of its tangent space.
constexpr int kPoseAmbientSize = 7;
constexpr int kPoseTangentSize = 6;

using Matrix6x7d = Eigen::Matrix<double, 6, 7, Eigen::RowMajor>;
using Matrix7x6d = Eigen::Matrix<double, 7, 6, Eigen::RowMajor>;

// Writes pose into a 7-double block [qx, qy, qz, qw, tx, ty, tz].
void PoseToParameters(const SE3d& pose, double* parameters);
// Reads a 7-double block (the quaternion is normalised).
SE3d PoseFromParameters(const double* parameters);

// d Plus(T, d) / d d at d = 0, 7x6 (row-major), for the block x = T.
Matrix7x6d PosePlusJacobian(const double* x);
// d Minus(Y, T) / d Y at Y = T, 6x7 (row-major); PoseMinusJacobian(x) * PosePlusJacobian(x) = I.
Matrix6x7d PoseMinusJacobian(const double* x);

// The SE(3) manifold above for ceres::Problem::SetManifold / AddParameterBlock.
class SE3Manifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseAmbientSize; }
  int TangentSize() const override { return kPoseTangentSize; }
  // x_plus_delta = Exp(delta) * x.
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // 7x6 row-major, at delta = 0.
  bool PlusJacobian(const double* x, double* jacobian) const override;
  // y_minus_x = Log(y * x^-1).
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // 6x7 row-major, at y = x.
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

}  // namespace dfo

#endif  // DFO_BACKEND_POSE_MANIFOLD_H_
