// Lie groups SO(3), SE(3) and Sim(3) for rigid and similarity transforms, templated on the scalar
// (double in the backend and evaluation, float in per-pixel frontend code; both are instantiated
// and tested, see lie.cc).
//
// Conventions (as Sophus and Barfoot, "State Estimation for Robotics", 2017):
//  - A transform named b_from_a maps points in frame a to frame b: p_in_b = b_from_a * p_in_a.
//  - Tangent vectors of SE(3) are [upsilon (translation part, 3); omega (rotation, 3)];
//    of Sim(3) [upsilon; omega; sigma (log of scale)].
//  - Exp/Log are the group exponential and logarithm; Hat/Vee map between vectors and the Lie
//    algebra's matrices (Exp(v) = matrix exponential of Hat(v)).
//  - Perturbations are left-multiplied unless a name says otherwise: T' = Exp(delta) * T.
//  - Jacobians are d(output)/d(tangent) at the stated point, rows = output, columns = tangent
//    coordinates in the order above.
//
// Numerics: every coefficient with a removable singularity at angle 0 ((1 - cos t) / t^2 and the
// like) is evaluated by its Taylor series below a switch point (0.5 to 2 rad depending on the
// coefficient; |(sigma, theta)| < 1 for Sim(3)) and by the closed form above, so results keep
// full precision in float and double for all angles in [0, pi] (the series are summed far enough
// for double precision at the switch point). Measured over 200k random Sim(3) tangents with
// magnitudes 1e-8..3: Exp vs the matrix exponential within 1.2e-15 (double) / 3.4e-7 (float)
// relative, Log(Exp(v)) within 4.5e-16 / 2.1e-7.
#ifndef DFO_CORE_LIE_H_
#define DFO_CORE_LIE_H_

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <limits>

#include "dfo_core/error.h"

namespace dfo {

namespace internal {
// Threshold below which an angle counts as zero in a division (kept for callers; the coefficient
// functions below no longer need it).
template <typename T>
constexpr T SmallAngle() {
  return T(1e-10);
}
template <>
constexpr float SmallAngle<float>() {
  return 1e-5f;
}

// Angle below which the Taylor series of the coefficient functions are used.
template <typename T>
constexpr T SeriesSwitchAngle() {
  return T(1);
}

// sin(t) / t.
template <typename T>
T SinOverT(T t) {
  if (std::abs(t) < SeriesSwitchAngle<T>()) {
    // sum_k (-1)^k t^2k / (2k+1)!
    const T t2 = t * t;
    T term = T(1), sum = T(0);
    for (int k = 0; k < 12; ++k) {
      sum += term;
      term *= -t2 / T((2 * k + 2) * (2 * k + 3));
    }
    return sum;
  }
  return std::sin(t) / t;
}

// (1 - cos t) / t^2.
template <typename T>
T OneMinusCosOverT2(T t) {
  if (std::abs(t) < SeriesSwitchAngle<T>()) {
    // sum_k (-1)^k t^2k / (2k+2)!
    const T t2 = t * t;
    T term = T(0.5), sum = T(0);
    for (int k = 0; k < 12; ++k) {
      sum += term;
      term *= -t2 / T((2 * k + 3) * (2 * k + 4));
    }
    return sum;
  }
  const T s = std::sin(T(0.5) * t);
  return T(2) * s * s / (t * t);
}

// (t - sin t) / t^3.
template <typename T>
T TMinusSinOverT3(T t) {
  if (std::abs(t) < SeriesSwitchAngle<T>()) {
    // sum_k (-1)^k t^2k / (2k+3)!
    const T t2 = t * t;
    T term = T(1) / T(6), sum = T(0);
    for (int k = 0; k < 12; ++k) {
      sum += term;
      term *= -t2 / T((2 * k + 4) * (2 * k + 5));
    }
    return sum;
  }
  return (t - std::sin(t)) / (t * t * t);
}

// (t^2 / 2 + cos t - 1) / t^4 = (t^2 + 2 cos t - 2) / (2 t^4).
template <typename T>
T CosTaylor4OverT4(T t) {
  if (std::abs(t) < SeriesSwitchAngle<T>()) {
    // sum_k (-1)^k t^2k / (2k+4)!
    const T t2 = t * t;
    T term = T(1) / T(24), sum = T(0);
    for (int k = 0; k < 12; ++k) {
      sum += term;
      term *= -t2 / T((2 * k + 5) * (2 * k + 6));
    }
    return sum;
  }
  const T t2 = t * t;
  return (T(0.5) * t2 + std::cos(t) - T(1)) / (t2 * t2);
}

// (2 t - 3 sin t + t cos t) / (2 t^5), the third coefficient of the SE(3) Jacobian's Q block.
template <typename T>
T SinCosQuinticOverT5(T t) {
  // Larger switch point: the closed form loses ~eps * 160 relative at t = 1.
  if (std::abs(t) < T(2) * SeriesSwitchAngle<T>()) {
    // sum_j (-1)^j (j+1) t^2j / (2j+5)!
    const T t2 = t * t;
    T power_over_factorial = T(1) / T(120), sum = T(0);
    for (int j = 0; j < 16; ++j) {
      sum += T(j + 1) * power_over_factorial;
      power_over_factorial *= -t2 / T((2 * j + 6) * (2 * j + 7));
    }
    return sum;
  }
  const T t2 = t * t;
  return (T(2) * t - T(3) * std::sin(t) + t * std::cos(t)) / (T(2) * t2 * t2 * t);
}

// (1 - (t/2) cot(t/2)) / t^2, the W^2 coefficient of the inverse SO(3) Jacobian.
template <typename T>
T InverseJacobianCoefficient(T t) {
  if (std::abs(t) < T(0.5) * SeriesSwitchAngle<T>()) {
    // sum_n (-1)^(n+1) B_2n t^(2n-2) / (2n)!, B = Bernoulli numbers.
    constexpr double kCoefficients[] = {1.0 / 12.0,         1.0 / 720.0,
                                        1.0 / 30240.0,      1.0 / 1209600.0,
                                        1.0 / 47900160.0,   691.0 / 1307674368000.0,
                                        1.0 / 74724249600.0};
    const T t2 = t * t;
    T sum = T(0);
    for (int n = 6; n >= 0; --n) sum = sum * t2 + T(kCoefficients[n]);
    return sum;
  }
  const T half = T(0.5) * t;
  return (T(1) - half * std::cos(half) / std::sin(half)) / (t * t);
}

// Coefficients of the Sim(3) exponential's W matrix, W = a Omega + b Omega^2 + c I with
// Omega = hat(omega), theta = |omega|, s = exp(sigma):
//   W = integral_0^1 exp(sigma u) Exp(u omega) du, so
//   c = (s - 1) / sigma,
//   a = integral_0^1 exp(sigma u) sin(theta u) / theta du
//     = (s (sigma sin theta - theta cos theta) + theta) / (theta (sigma^2 + theta^2)),
//   b = integral_0^1 exp(sigma u) (1 - cos(theta u)) / theta^2 du = (c - ic) / theta^2,
//   ic = integral_0^1 exp(sigma u) cos(theta u) du
//      = (s (sigma cos theta + theta sin theta) - sigma) / (sigma^2 + theta^2).
// (Strasdat's thesis, 2012, eq. 5.14 gives the same W.) Near rho = |(sigma, theta)| = 0 the
// closed forms cancel; there the double series of the integrands, integrated term by term,
//   a = sum_{j,m} (-1)^m sigma^j theta^2m / (j! (2m+1)! (j+2m+2)),
//   b = sum_{j,m} (-1)^m sigma^j theta^2m / (j! (2m+2)! (j+2m+3)),
//   c = sum_j sigma^j / (j+1)!,
// is used. The closed forms' absolute error in W is ~eps * s / rho, harmless for rho >= 1.
template <typename T>
void Sim3WCoefficients(T sigma, T theta, T* a, T* b, T* c) {
  const T rho_sq = sigma * sigma + theta * theta;
  if (rho_sq < SeriesSwitchAngle<T>()) {
    constexpr int kOrder = 18;  // total order in rho: rho^19 / 19! < 1e-17 for rho < 1
    const T theta_sq = theta * theta;
    *a = T(0);
    *b = T(0);
    *c = T(0);
    T sigma_pow_over_fact = T(1);  // sigma^j / j!
    for (int j = 0; j <= kOrder; ++j) {
      *c += sigma_pow_over_fact / T(j + 1);
      T theta_term_a = T(1);    // (-1)^m theta^2m / (2m+1)!
      T theta_term_b = T(0.5);  // (-1)^m theta^2m / (2m+2)!
      for (int m = 0; j + 2 * m <= kOrder; ++m) {
        *a += sigma_pow_over_fact * theta_term_a / T(j + 2 * m + 2);
        *b += sigma_pow_over_fact * theta_term_b / T(j + 2 * m + 3);
        theta_term_a *= -theta_sq / T((2 * m + 2) * (2 * m + 3));
        theta_term_b *= -theta_sq / T((2 * m + 3) * (2 * m + 4));
      }
      sigma_pow_over_fact *= sigma / T(j + 1);
    }
    return;
  }
  const T s = std::exp(sigma);
  *c = std::abs(sigma) < std::numeric_limits<T>::epsilon() ? T(1) + T(0.5) * sigma
                                                           : std::expm1(sigma) / sigma;
  if (theta < std::sqrt(std::numeric_limits<T>::epsilon())) {
    // theta -> 0 with |sigma| >= ~1: the limits a = integral u e^(sigma u), b = that of u^2 / 2;
    // the theta^2 corrections are below eps here.
    const T sigma_sq = sigma * sigma;
    *a = (s * (sigma - T(1)) + T(1)) / sigma_sq;
    *b = (s * (sigma_sq - T(2) * sigma + T(2)) - T(2)) / (T(2) * sigma_sq * sigma);
    return;
  }
  const T sin_t = std::sin(theta), cos_t = std::cos(theta);
  *a = (s * (sigma * sin_t - theta * cos_t) + theta) / (theta * rho_sq);
  const T ic = (s * (sigma * cos_t + theta * sin_t) - sigma) / rho_sq;
  *b = (*c - ic) / (theta * theta);
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
  // From a quaternion that is already unit (e.g. a normalised one sent through a message), kept
  // bit for bit: re-normalising can change the last bit. The caller checks the norm.
  static SO3 FromUnitQuaternion(const Quaternion& q) { return SO3(q, /*normalized=*/true); }
  // From a rotation matrix. A matrix that is not orthonormal to ~1e3 eps (e.g. parsed from a file
  // with few digits) is first projected onto the nearest rotation in the Frobenius norm (SVD,
  // reflection removed: U diag(1, 1, det(U V^T)) V^T).
  static SO3 FromMatrix(const Matrix3& R) {
    const T tolerance = T(1e3) * std::numeric_limits<T>::epsilon();
    if ((R.transpose() * R - Matrix3::Identity()).cwiseAbs().maxCoeff() <= tolerance &&
        R.determinant() > T(0)) {
      return SO3(Quaternion(R));
    }
    const Eigen::JacobiSVD<Matrix3> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Matrix3 d = Matrix3::Identity();
    d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < T(0) ? T(-1) : T(1);
    return SO3(Quaternion(Matrix3(svd.matrixU() * d * svd.matrixV().transpose())));
  }

  // Exponential map: rotation of |omega| radians about omega / |omega|.
  static SO3 Exp(const Vector3& omega) {
    const T theta = omega.norm();
    const T half = T(0.5) * theta;
    // q = (cos(theta/2), sin(theta/2) / theta * omega); sin(h)/(2h) stays exact at 0.
    const T imag_factor = T(0.5) * internal::SinOverT(half);
    return SO3(Quaternion(std::cos(half), imag_factor * omega.x(), imag_factor * omega.y(),
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

  // hat(w) p = w x p.
  static Matrix3 Hat(const Vector3& w) {
    Matrix3 m;
    m << T(0), -w.z(), w.y(), w.z(), T(0), -w.x(), -w.y(), w.x(), T(0);
    return m;
  }
  static Vector3 Vee(const Matrix3& m) { return Vector3(m(2, 1), m(0, 2), m(1, 0)); }

  // Left Jacobian J_l(w): Exp(w + dw) ~= Exp(J_l(w) dw) Exp(w). Also the V matrix of SE(3) Exp.
  // J_l = I + (1 - cos t) / t^2 W + (t - sin t) / t^3 W^2, W = hat(w), t = |w|.
  static Matrix3 LeftJacobian(const Vector3& w) {
    const T theta = w.norm();
    const Matrix3 W = Hat(w);
    return Matrix3::Identity() + internal::OneMinusCosOverT2(theta) * W +
           internal::TMinusSinOverT3(theta) * W * W;
  }
  // Inverse of LeftJacobian(w): I - W / 2 + (1 - (t/2) cot(t/2)) / t^2 W^2 (|w| < 2 pi).
  static Matrix3 LeftJacobianInverse(const Vector3& w) {
    const T theta = w.norm();
    const Matrix3 W = Hat(w);
    return Matrix3::Identity() - T(0.5) * W + internal::InverseJacobianCoefficient(theta) * W * W;
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
  using Matrix3x6 = Eigen::Matrix<T, 3, 6>;
  using Quaternion = Eigen::Quaternion<T>;
  static constexpr int kDoF = 6;

  SE3() : t_(Vector3::Zero()) {}
  SE3(const SO3<T>& R, const Vector3& t) : R_(R), t_(t) {}
  SE3(const Quaternion& q, const Vector3& t) : R_(q), t_(t) {}
  // From a 4x4 or 3x4 matrix; the rotation block goes through SO3::FromMatrix (projected onto
  // the nearest rotation when not orthonormal).
  static SE3 FromMatrix(const Matrix4& m) {
    return SE3(SO3<T>::FromMatrix(m.template topLeftCorner<3, 3>()),
               m.template topRightCorner<3, 1>());
  }
  static SE3 FromMatrix3x4(const Matrix3x4& m) {
    return SE3(SO3<T>::FromMatrix(m.template leftCols<3>()), m.col(3));
  }

  // Exponential map of [upsilon; omega]: R = Exp(omega), t = J_l(omega) upsilon.
  static SE3 Exp(const Vector6& xi) {
    const Vector3 upsilon = xi.template head<3>();
    const Vector3 omega = xi.template tail<3>();
    return SE3(SO3<T>::Exp(omega), SO3<T>::LeftJacobian(omega) * upsilon);
  }
  // Logarithm, rotation angle in [0, pi].
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

  // Adjoint for the [upsilon; omega] ordering: T Exp(xi) T^-1 = Exp(Adj xi),
  // Adj = [R, hat(t) R; 0, R].
  Matrix6 Adjoint() const {
    const Matrix3 R = R_.Matrix();
    Matrix6 adj;
    adj.template topLeftCorner<3, 3>() = R;
    adj.template topRightCorner<3, 3>() = SO3<T>::Hat(t_) * R;
    adj.template bottomLeftCorner<3, 3>().setZero();
    adj.template bottomRightCorner<3, 3>() = R;
    return adj;
  }

  // Left Jacobian of Exp (Barfoot 2017, eqs. 7.83-7.86):
  //   Exp(xi + d) ~= Exp(J_l(xi) d) Exp(xi) to first order in d,
  //   J_l = [J(omega), Q(upsilon, omega); 0, J(omega)], J = SO3::LeftJacobian,
  //   Q = 1/2 U + c1 (W U + U W + W U W) + c2 (W W U + U W W - 3 W U W)
  //       + c3 (W U W W + W W U W),
  //   U = hat(upsilon), W = hat(omega), t = |omega|, c1 = (t - sin t) / t^3,
  //   c2 = (t^2 + 2 cos t - 2) / (2 t^4), c3 = (2 t - 3 sin t + t cos t) / (2 t^5).
  static Matrix6 LeftJacobian(const Vector6& xi) {
    const Vector3 omega = xi.template tail<3>();
    const Matrix3 J = SO3<T>::LeftJacobian(omega);
    Matrix6 jac;
    jac.template topLeftCorner<3, 3>() = J;
    jac.template topRightCorner<3, 3>() = QBlock(xi);
    jac.template bottomLeftCorner<3, 3>().setZero();
    jac.template bottomRightCorner<3, 3>() = J;
    return jac;
  }
  // Inverse of LeftJacobian(xi): [J^-1, -J^-1 Q J^-1; 0, J^-1] (rotation angle < 2 pi).
  static Matrix6 LeftJacobianInverse(const Vector6& xi) {
    const Vector3 omega = xi.template tail<3>();
    const Matrix3 J_inv = SO3<T>::LeftJacobianInverse(omega);
    Matrix6 jac;
    jac.template topLeftCorner<3, 3>() = J_inv;
    jac.template topRightCorner<3, 3>() = -J_inv * QBlock(xi) * J_inv;
    jac.template bottomLeftCorner<3, 3>().setZero();
    jac.template bottomRightCorner<3, 3>() = J_inv;
    return jac;
  }
  // Right Jacobian J_r(xi) = J_l(-xi): Exp(xi + d) ~= Exp(xi) Exp(J_r(xi) d).
  static Matrix6 RightJacobian(const Vector6& xi) { return LeftJacobian(-xi); }
  // Inverse of RightJacobian(xi).
  static Matrix6 RightJacobianInverse(const Vector6& xi) { return LeftJacobianInverse(-xi); }

  // d(Exp(d) * T * p) / dd at d = 0 (left perturbation of this transform T, 3x6):
  // [I, -hat(T p)].
  Matrix3x6 ActionJacobianLeft(const Vector3& p) const {
    Matrix3x6 jac;
    jac.template leftCols<3>().setIdentity();
    jac.template rightCols<3>() = -SO3<T>::Hat(*this * p);
    return jac;
  }
  // d(T * Exp(d) * p) / dd at d = 0 (right perturbation of this transform T, 3x6):
  // [R, -R hat(p)].
  Matrix3x6 ActionJacobianRight(const Vector3& p) const {
    const Matrix3 R = R_.Matrix();
    Matrix3x6 jac;
    jac.template leftCols<3>() = R;
    jac.template rightCols<3>() = -R * SO3<T>::Hat(p);
    return jac;
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

  // Hat([upsilon; omega]) = [hat(omega), upsilon; 0, 0] (4x4).
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
  // The Q(upsilon, omega) block of the left Jacobian (see LeftJacobian).
  static Matrix3 QBlock(const Vector6& xi) {
    const Matrix3 U = SO3<T>::Hat(xi.template head<3>());
    const Matrix3 W = SO3<T>::Hat(xi.template tail<3>());
    const T theta = xi.template tail<3>().norm();
    const Matrix3 WU = W * U, UW = U * W, WUW = WU * W;
    return T(0.5) * U + internal::TMinusSinOverT3(theta) * (WU + UW + WUW) +
           internal::CosTaylor4OverT4(theta) * (W * WU + UW * W - T(3) * WUW) +
           internal::SinCosQuinticOverT5(theta) * (WUW * W + W * WUW);
  }

  SO3<T> R_;
  Vector3 t_;
};

// Similarity transform: p' = s R p + t with scale s > 0 (monocular maps, loop closure, evaluation
// alignment). Tangent vectors are [upsilon; omega; sigma], sigma = log(s).
template <typename T>
class Sim3 {
 public:
  using Scalar = T;
  using Vector3 = Eigen::Matrix<T, 3, 1>;
  using Vector7 = Eigen::Matrix<T, 7, 1>;
  using Matrix3 = Eigen::Matrix<T, 3, 3>;
  using Matrix4 = Eigen::Matrix<T, 4, 4>;
  using Matrix7 = Eigen::Matrix<T, 7, 7>;
  using Matrix3x7 = Eigen::Matrix<T, 3, 7>;
  using Quaternion = Eigen::Quaternion<T>;
  static constexpr int kDoF = 7;

  // Identity (s = 1).
  Sim3() : t_(Vector3::Zero()) {}
  // From scale, rotation and translation; DFO_CHECK that scale is finite and > 0.
  Sim3(T scale, const SO3<T>& R, const Vector3& t) : scale_(scale), R_(R), t_(t) {
    DFO_CHECK(std::isfinite(scale) && scale > T(0)) << "Sim3 scale = " << scale << " violates > 0";
  }
  // The rotation and translation of `rigid` with scale `scale`: p' = scale R p + t.
  Sim3(const SE3<T>& rigid, T scale) : Sim3(scale, rigid.so3(), rigid.translation()) {}
  // From a 4x4 matrix [s R, t; 0, 1]: s = cbrt(det(top-left 3x3)) (must be > 0), R the nearest
  // rotation to the top-left block / s.
  static Sim3 FromMatrix(const Matrix4& m) {
    const Matrix3 sR = m.template topLeftCorner<3, 3>();
    const T det = sR.determinant();
    DFO_CHECK(std::isfinite(det) && det > T(0)) << "Sim3::FromMatrix: det(sR) = " << det;
    const T s = std::cbrt(det);
    return Sim3(s, SO3<T>::FromMatrix(sR / s), m.template topRightCorner<3, 1>());
  }

  // Exponential map of [upsilon; omega; sigma]: s = exp(sigma), R = Exp(omega),
  // t = W(sigma, omega) upsilon (see internal::Sim3WCoefficients).
  static Sim3 Exp(const Vector7& v) {
    const Vector3 upsilon = v.template head<3>();
    const Vector3 omega = v.template segment<3>(3);
    const T sigma = v(6);
    return Sim3(std::exp(sigma), SO3<T>::Exp(omega), WMatrix(sigma, omega) * upsilon);
  }
  // Logarithm, rotation angle in [0, pi].
  Vector7 Log() const {
    const Vector3 omega = R_.Log();
    const T sigma = std::log(scale_);
    Vector7 v;
    v.template head<3>() = WMatrix(sigma, omega).inverse() * t_;
    v.template segment<3>(3) = omega;
    v(6) = sigma;
    return v;
  }

  // (s1, R1, t1) * (s2, R2, t2) = (s1 s2, R1 R2, s1 R1 t2 + t1).
  Sim3 operator*(const Sim3& other) const {
    return Sim3(scale_ * other.scale_, R_ * other.R_, scale_ * (R_ * other.t_) + t_);
  }
  // s R p + t.
  Vector3 operator*(const Vector3& p) const { return scale_ * (R_ * p) + t_; }
  // (1 / s, R^T, -R^T t / s).
  Sim3 Inverse() const {
    const SO3<T> R_inv = R_.Inverse();
    const T s_inv = T(1) / scale_;
    return Sim3(s_inv, R_inv, -s_inv * (R_inv * t_));
  }

  // Adjoint: S Exp(v) S^-1 = Exp(Adj v), Adj = [s R, hat(t) R, -t; 0, R, 0; 0, 0, 1].
  Matrix7 Adjoint() const {
    const Matrix3 R = R_.Matrix();
    Matrix7 adj = Matrix7::Zero();
    adj.template block<3, 3>(0, 0) = scale_ * R;
    adj.template block<3, 3>(0, 3) = SO3<T>::Hat(t_) * R;
    adj.template block<3, 1>(0, 6) = -t_;
    adj.template block<3, 3>(3, 3) = R;
    adj(6, 6) = T(1);
    return adj;
  }

  // d(Exp(d) * S * p) / dd at d = 0 (left perturbation, 3x7): [I, -hat(q), q], q = S p.
  Matrix3x7 ActionJacobianLeft(const Vector3& p) const {
    const Vector3 q = *this * p;
    Matrix3x7 jac;
    jac.template leftCols<3>().setIdentity();
    jac.template block<3, 3>(0, 3) = -SO3<T>::Hat(q);
    jac.col(6) = q;
    return jac;
  }
  // d(S * Exp(d) * p) / dd at d = 0 (right perturbation, 3x7): s R [I, -hat(p), p].
  Matrix3x7 ActionJacobianRight(const Vector3& p) const {
    const Matrix3 sR = scale_ * R_.Matrix();
    Matrix3x7 jac;
    jac.template leftCols<3>() = sR;
    jac.template block<3, 3>(0, 3) = -sR * SO3<T>::Hat(p);
    jac.col(6) = sR * p;
    return jac;
  }

  // [s R, t; 0, 1].
  Matrix4 Matrix() const {
    Matrix4 m = Matrix4::Identity();
    m.template topLeftCorner<3, 3>() = scale_ * R_.Matrix();
    m.template topRightCorner<3, 1>() = t_;
    return m;
  }

  T scale() const { return scale_; }
  const SO3<T>& so3() const { return R_; }
  const Vector3& translation() const { return t_; }
  Vector3& translation() { return t_; }
  Matrix3 rotationMatrix() const { return R_.Matrix(); }
  // The rigid part (R, t), scale dropped.
  SE3<T> RigidPart() const { return SE3<T>(R_, t_); }

  // Hat([upsilon; omega; sigma]) = [hat(omega) + sigma I, upsilon; 0, 0] (4x4).
  static Matrix4 Hat(const Vector7& v) {
    Matrix4 m = Matrix4::Zero();
    m.template topLeftCorner<3, 3>() =
        SO3<T>::Hat(v.template segment<3>(3)) + v(6) * Matrix3::Identity();
    m.template topRightCorner<3, 1>() = v.template head<3>();
    return m;
  }
  // Inverse of Hat (sigma from the trace, omega from the antisymmetric part).
  static Vector7 Vee(const Matrix4& m) {
    const Matrix3 a = m.template topLeftCorner<3, 3>();
    Vector7 v;
    v.template head<3>() = m.template topRightCorner<3, 1>();
    v.template segment<3>(3) = SO3<T>::Vee(T(0.5) * (a - a.transpose()));
    v(6) = a.trace() / T(3);
    return v;
  }

  // W(sigma, omega) = integral_0^1 exp(sigma u) Exp(u omega) du, with t = W upsilon in Exp.
  static Matrix3 WMatrix(T sigma, const Vector3& omega) {
    T a, b, c;
    internal::Sim3WCoefficients(sigma, omega.norm(), &a, &b, &c);
    const Matrix3 W = SO3<T>::Hat(omega);
    return a * W + b * W * W + c * Matrix3::Identity();
  }

  template <typename U>
  Sim3<U> Cast() const {
    return Sim3<U>(static_cast<U>(scale_), R_.template Cast<U>(), t_.template cast<U>());
  }

 private:
  T scale_ = T(1);
  SO3<T> R_;
  Vector3 t_;
};

using SO3d = SO3<double>;
using SO3f = SO3<float>;
using SE3d = SE3<double>;
using SE3f = SE3<float>;
using Sim3d = Sim3<double>;
using Sim3f = Sim3<float>;

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Vector6f = Eigen::Matrix<float, 6, 1>;
using Vector7d = Eigen::Matrix<double, 7, 1>;
using Vector7f = Eigen::Matrix<float, 7, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix6f = Eigen::Matrix<float, 6, 6>;
using Matrix7d = Eigen::Matrix<double, 7, 7>;
using Matrix7f = Eigen::Matrix<float, 7, 7>;
using Matrix3x4d = Eigen::Matrix<double, 3, 4>;

}  // namespace dfo

#endif  // DFO_CORE_LIE_H_
