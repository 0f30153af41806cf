// Lie groups SO(3), SE(3) and Sim(3) for rigid and similarity transforms, templated on the scalar
// (double in the backend and evaluation, float in per-pixel frontend code).
//
// Conventions (as Sophus):
//  - A transform named b_from_a maps points in frame a to frame b: p_in_b = b_from_a * p_in_a.
//  - Tangent vectors of SE(3) are [upsilon (translation part, 3); omega (rotation, 3)];
//    of Sim(3) [upsilon; omega; sigma (log of scale)].
//  - Exp/Log are the group exponential and logarithm; Hat/Vee map between vectors and the Lie
//    algebra's matrices. Perturbations are left-multiplied unless a name says otherwise:
//    T' = Exp(delta) * T.
#ifndef DFO_CORE_LIE_H_
#define DFO_CORE_LIE_H_

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace dfo {

namespace internal {
// Threshold below which series expansions replace closed forms.
template <typename T>
constexpr T SmallAngle() {
  return T(1e-10);
}
template <>
constexpr float SmallAngle<float>() {
  return 1e-5f;
}
}  // namespace internal

// Rotation in 3D stored as a unit quaternion.
template <typename T>
class SO3 {
 public:
  using Scalar = T;
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Matrix3 = Eigen::Matrix<T, 3, 3>;
  using Quaternion = Eigen::Quaternion<T>;
  static constexpr int kDoF = 3;

  // Identity rotation.
  SO3() : q_(Quaternion::Identity()) {}
  // From a quaternion; normalised here.
  explicit SO3(const Quaternion& q) : q_(q.normalized()) {}
  // From a rotation matrix; the matrix is projected onto the nearest rotation (via quaternion).
  static SO3 FromMatrix(const Matrix3& R) { return SO3(Quaternion(R)); }

  // Exponential map: rotation of |omega| radians about omega / |omega|.
  static SO3 Exp(const Vector3& omega) {
    const T theta_sq = omega.squaredNorm();
    const T theta = std::sqrt(theta_sq);
    const T half = T(0.5) * theta;
    T real, imag_factor;
    if (theta < internal::SmallAngle<T>()) {
      real = T(1) - theta_sq / T(8);
      imag_factor = T(0.5) - theta_sq / T(48);
    } else {
      real = std::cos(half);
      imag_factor = std::sin(half) / theta;
    }
    return SO3(Quaternion(real, imag_factor * omega.x(), imag_factor * omega.y(),
                          imag_factor * omega.z()));
  }

  // Logarithm: the rotation vector, with angle in [0, pi].
  Vector3 Log() const {
    Quaternion q = q_;
    if (q.w() < T(0)) q.coeffs() = -q.coeffs();  // shortest path
    const Vector3 v = q.vec();
    const T n = v.norm();
    const T w = q.w();
    T factor;
    if (n < internal::SmallAngle<T>()) {
      factor = T(2) / w - T(2) / T(3) * n * n / (w * w * w);
    } else {
      factor = T(2) * std::atan2(n, w) / n;
    }
    return factor * v;
  }

  // Angle of rotation in radians, in [0, pi].
  T Angle() const { return Log().norm(); }

  SO3 Inverse() const { return SO3(q_.conjugate(), /*normalized=*/true); }
  SO3 operator*(const SO3& other) const { return SO3(q_ * other.q_); }
  Vector3 operator*(const Vector3& p) const { return q_ * p; }
  Matrix3 Matrix() const { return q_.toRotationMatrix(); }
  const Quaternion& quaternion() const { return q_; }
  // Adjoint: Exp(Adj * w) = R Exp(w) R^-1.
  Matrix3 Adjoint() const { return Matrix(); }

  static Matrix3 Hat(const Vector3& w) {
    Matrix3 m;
    m << T(0), -w.z(), w.y(), w.z(), T(0), -w.x(), -w.y(), w.x(), T(0);
    return m;
  }
  static Vector3 Vee(const Matrix3& m) { return Vector3(m(2, 1), m(0, 2), m(1, 0)); }

  // Left Jacobian J_l(w): Exp(w + dw) ~= Exp(J_l(w) dw) Exp(w). Also the V matrix of SE(3) Exp.
  static Matrix3 LeftJacobian(const Vector3& w) {
    const T theta_sq = w.squaredNorm();
    const Matrix3 W = Hat(w);
    if (theta_sq < internal::SmallAngle<T>()) {
      return Matrix3::Identity() + T(0.5) * W + W * W / T(6);
    }
    const T theta = std::sqrt(theta_sq);
    return Matrix3::Identity() + (T(1) - std::cos(theta)) / theta_sq * W +
           (theta - std::sin(theta)) / (theta_sq * theta) * W * W;
  }
  // Inverse of LeftJacobian(w).
  static Matrix3 LeftJacobianInverse(const Vector3& w) {
    const T theta_sq = w.squaredNorm();
    const Matrix3 W = Hat(w);
    if (theta_sq < internal::SmallAngle<T>()) {
      return Matrix3::Identity() - T(0.5) * W + W * W / T(12);
    }
    const T theta = std::sqrt(theta_sq);
    const T half = T(0.5) * theta;
    const T cot_half = std::cos(half) / std::sin(half);
    return Matrix3::Identity() - T(0.5) * W +
           (T(1) - half * cot_half) / theta_sq * W * W;
  }
  // Right Jacobian J_r(w) = J_l(-w): Exp(w + dw) ~= Exp(w) Exp(J_r(w) dw).
  static Matrix3 RightJacobian(const Vector3& w) { return LeftJacobian(-w); }
  static Matrix3 RightJacobianInverse(const Vector3& w) { return LeftJacobianInverse(-w); }

  template <typename U>
  SO3<U> Cast() const {
    return SO3<U>(q_.template cast<U>());
  }

 private:
  SO3(const Quaternion& q, bool /*normalized*/) : q_(q) {}
  Quaternion q_;
};

// Rigid transform: rotation then translation, p' = R p + t.
template <typename T>
class SE3 {
 public:
  using Scalar = T;
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Vector6 = Eigen::Matrix<T, 6, 1>;
  using Matrix3 = Eigen::Matrix<T, 3, 3>;
  using Matrix4 = Eigen::Matrix<T, 4, 4>;
  using Matrix6 = Eigen::Matrix<T, 6, 6>;
  using Matrix3x4 = Eigen::Matrix<T, 3, 4>;
  using Quaternion = Eigen::Quaternion<T>;
  static constexpr int kDoF = 6;

  SE3() : t_(Vector3::Zero()) {}
  SE3(const SO3<T>& R, const Vector3& t) : R_(R), t_(t) {}
  SE3(const Quaternion& q, const Vector3& t) : R_(q), t_(t) {}
  // From a 4x4 or 3x4 matrix; the rotation block is projected onto the nearest rotation.
  static SE3 FromMatrix(const Matrix4& m) {
    return SE3(SO3<T>::FromMatrix(m.template topLeftCorner<3, 3>()), m.template topRightCorner<3, 1>());
  }
  static SE3 FromMatrix3x4(const Matrix3x4& m) {
    return SE3(SO3<T>::FromMatrix(m.template leftCols<3>()), m.col(3));
  }

  // Exponential map of [upsilon; omega].
  static SE3 Exp(const Vector6& xi) {
    const Vector3 upsilon = xi.template head<3>();
    const Vector3 omega = xi.template tail<3>();
    return SE3(SO3<T>::Exp(omega), SO3<T>::LeftJacobian(omega) * upsilon);
  }
  Vector6 Log() const {
    const Vector3 omega = R_.Log();
    Vector6 xi;
    xi.template head<3>() = SO3<T>::LeftJacobianInverse(omega) * t_;
    xi.template tail<3>() = omega;
    return xi;
  }

  SE3 Inverse() const {
    const SO3<T> R_inv = R_.Inverse();
    return SE3(R_inv, -(R_inv * t_));
  }
  SE3 operator*(const SE3& other) const { return SE3(R_ * other.R_, R_ * other.t_ + t_); }
  Vector3 operator*(const Vector3& p) const { return R_ * p + t_; }

  // Adjoint for the [upsilon; omega] ordering: T Exp(xi) T^-1 = Exp(Adj xi).
  Matrix6 Adjoint() const {
    const Matrix3 R = R_.Matrix();
    Matrix6 adj;
    adj.template topLeftCorner<3, 3>() = R;
    adj.template topRightCorner<3, 3>() = SO3<T>::Hat(t_) * R;
    adj.template bottomLeftCorner<3, 3>().setZero();
    adj.template bottomRightCorner<3, 3>() = R;
    return adj;
  }

  Matrix4 Matrix() const {
    Matrix4 m = Matrix4::Identity();
    m.template topLeftCorner<3, 3>() = R_.Matrix();
    m.template topRightCorner<3, 1>() = t_;
    return m;
  }
  Matrix3x4 Matrix3x4Form() const {
    Matrix3x4 m;
    m.template leftCols<3>() = R_.Matrix();
    m.col(3) = t_;
    return m;
  }

  const SO3<T>& so3() const { return R_; }
  SO3<T>& so3() { return R_; }
  const Vector3& translation() const { return t_; }
  Vector3& translation() { return t_; }
  Matrix3 rotationMatrix() const { return R_.Matrix(); }
  const Quaternion& quaternion() const { return R_.quaternion(); }

  static Matrix4 Hat(const Vector6& xi) {
    Matrix4 m = Matrix4::Zero();
    m.template topLeftCorner<3, 3>() = SO3<T>::Hat(xi.template tail<3>());
    m.template topRightCorner<3, 1>() = xi.template head<3>();
    return m;
  }
  static Vector6 Vee(const Matrix4& m) {
    Vector6 xi;
    xi.template head<3>() = m.template topRightCorner<3, 1>();
    xi.template tail<3>() = SO3<T>::Vee(m.template topLeftCorner<3, 3>());
    return xi;
  }

  template <typename U>
  SE3<U> Cast() const {
    return SE3<U>(R_.template Cast<U>(), t_.template cast<U>());
  }

 private:
  SO3<T> R_;
  Vector3 t_;
};

using SO3d = SO3<double>;
using SO3f = SO3<float>;
using SE3d = SE3<double>;
using SE3f = SE3<float>;

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Vector6f = Eigen::Matrix<float, 6, 1>;
using Vector7d = Eigen::Matrix<double, 7, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix3x4d = Eigen::Matrix<double, 3, 4>;

}  // namespace dfo

#endif  // DFO_CORE_LIE_H_
