#include "dfo_backend/pose_manifold.h"

#include <Eigen/Geometry>

namespace dfo {

void PoseToParameters(const SE3d& pose, double* parameters) {
  const Eigen::Quaterniond& q = pose.quaternion();
  parameters[0] = q.x();
  parameters[1] = q.y();
  parameters[2] = q.z();
  parameters[3] = q.w();
  const Eigen::Vector3d& t = pose.translation();
  parameters[4] = t.x();
  parameters[5] = t.y();
  parameters[6] = t.z();
}

SE3d PoseFromParameters(const double* parameters) {
  const Eigen::Quaterniond q(parameters[3], parameters[0], parameters[1], parameters[2]);
  return SE3d(q, Eigen::Vector3d(parameters[4], parameters[5], parameters[6]));
}

// Derivation (left perturbation, d = [upsilon; omega] -> 0):
//   Exp(d) * T has quaternion (1, omega / 2) (x) q and translation t + upsilon + omega x t, so
//   d qv / d omega = (qw I - hat(qv)) / 2,  d qw / d omega = -qv^T / 2,
//   d t / d upsilon = I,                    d t / d omega = -hat(t).
Matrix7x6d PosePlusJacobian(const double* x) {
  const Eigen::Vector3d qv(x[0], x[1], x[2]);
  const double qw = x[3];
  const Eigen::Vector3d t(x[4], x[5], x[6]);
  Matrix7x6d jac = Matrix7x6d::Zero();
  jac.block<3, 3>(0, 3) = 0.5 * (qw * Eigen::Matrix3d::Identity() - SO3d::Hat(qv));
  jac.block<1, 3>(3, 3) = -0.5 * qv.transpose();
  jac.block<3, 3>(4, 0) = Eigen::Matrix3d::Identity();
  jac.block<3, 3>(4, 3) = -SO3d::Hat(t);
  return jac;
}

// Minus(Y, T) = Log(Y T^-1): omega ~ 2 vec(qY (x) conj(qT)), upsilon ~ (tY - tT) + hat(tT) omega,
// differentiated w.r.t. the ambient coordinates of Y at Y = T:
//   d omega / d qYv = 2 (qw I + hat(qv)),  d omega / d qYw = -2 qv,
//   d upsilon / d tY = I,                 d upsilon / d qY = hat(t) d omega / d qY.
// For a unit quaternion this is a left inverse of PosePlusJacobian (tested).
Matrix6x7d PoseMinusJacobian(const double* x) {
  const Eigen::Vector3d qv(x[0], x[1], x[2]);
  const double qw = x[3];
  const Eigen::Vector3d t(x[4], x[5], x[6]);
  Eigen::Matrix<double, 3, 4> d_omega_d_q;
  d_omega_d_q.leftCols<3>() = 2.0 * (qw * Eigen::Matrix3d::Identity() + SO3d::Hat(qv));
  d_omega_d_q.col(3) = -2.0 * qv;
  Matrix6x7d jac = Matrix6x7d::Zero();
  jac.block<3, 4>(0, 0) = SO3d::Hat(t) * d_omega_d_q;
  jac.block<3, 3>(0, 4) = Eigen::Matrix3d::Identity();
  jac.block<3, 4>(3, 0) = d_omega_d_q;
  return jac;
}

bool SE3Manifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Vector6d d = Eigen::Map<const Vector6d>(delta);
  PoseToParameters(SE3d::Exp(d) * PoseFromParameters(x), x_plus_delta);
  return true;
}

bool SE3Manifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Matrix7x6d> jac(jacobian);
  jac = PosePlusJacobian(x);
  return true;
}

bool SE3Manifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const SE3d relative = PoseFromParameters(y) * PoseFromParameters(x).Inverse();
  Eigen::Map<Vector6d> out(y_minus_x);
  out = relative.Log();
  return true;
}

bool SE3Manifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Matrix6x7d> jac(jacobian);
  jac = PoseMinusJacobian(x);
  return true;
}

}  // namespace dfo
