#include "dfo_core/lie.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

namespace dfo {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Deterministic uniform numbers in [-1, 1) (mt19937 is specified by the standard; the
// std:: distributions are not, so they are not used).
class Rng {
 public:
  explicit Rng(uint32_t seed) : engine_(seed) {}
  double Uniform() { return engine_() / 4294967296.0 * 2.0 - 1.0; }
  template <int N>
  Eigen::Matrix<double, N, 1> Vector(double scale = 1.0) {
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v(i) = scale * Uniform();
    return v;
  }
  // A rotation vector with angle in [0, max_angle].
  Eigen::Vector3d RotationVector(double max_angle) {
    Eigen::Vector3d axis = Vector<3>();
    while (axis.norm() < 1e-3) axis = Vector<3>();
    return axis.normalized() * (0.5 * (Uniform() + 1.0) * max_angle);
  }

 private:
  std::mt19937 engine_;
};

// Tolerances per scalar type: round trips and comparisons against double references.
template <typename T>
struct Tol;
template <>
struct Tol<double> {
  static constexpr double kRoundTrip = 1e-10;
  static constexpr double kVsDouble = 0.0;
};
template <>
struct Tol<float> {
  static constexpr double kRoundTrip = 2e-5;
  static constexpr double kVsDouble = 2e-5;
};

// Interesting rotation vectors: random, tiny, zero, around the series switch, close to pi.
std::vector<Eigen::Vector3d> TestRotationVectors(Rng* rng) {
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < 20; ++i) out.push_back(rng->RotationVector(kPi));
  out.push_back(Eigen::Vector3d::Zero());
  for (double angle : {1e-12, 1e-8, 1e-5, 1e-3, 0.3, 0.999, 1.0, 1.001, 1.999, 2.0, 2.001,
                       kPi - 1e-2, kPi - 1e-4}) {
    out.push_back(rng->RotationVector(1.0).normalized() * angle);
  }
  return out;
}

template <typename T>
class LieTyped : public ::testing::Test {};
using ScalarTypes = ::testing::Types<double, float>;
TYPED_TEST_SUITE(LieTyped, ScalarTypes);

TYPED_TEST(LieTyped, SO3ExpLogRoundTrip) {
  using T = TypeParam;
  Rng rng(1);
  for (const Eigen::Vector3d& w : TestRotationVectors(&rng)) {
    const Eigen::Matrix<T, 3, 1> wt = w.cast<T>();
    const SO3<T> R = SO3<T>::Exp(wt);
    EXPECT_LT((R.Log() - wt).norm(), Tol<T>::kRoundTrip * (1.0 + w.norm())) << w.transpose();
    // Exp of the log reproduces the matrix.
    EXPECT_LT((SO3<T>::Exp(R.Log()).Matrix() - R.Matrix()).norm(), Tol<T>::kRoundTrip);
    // Against the exact double rotation matrix (Eigen's AngleAxis).
    const Eigen::Matrix3d expected =
        w.norm() > 0 ? Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix()
                     : Eigen::Matrix3d::Identity();
    EXPECT_LT((R.Matrix().template cast<double>() - expected).norm(), Tol<T>::kRoundTrip);
  }
}

TYPED_TEST(LieTyped, SE3ExpLogRoundTrip) {
  using T = TypeParam;
  Rng rng(2);
  for (const Eigen::Vector3d& w : TestRotationVectors(&rng)) {
    Vector6d xi;
    xi << rng.Vector<3>(5.0), w;
    const SE3<T> X = SE3<T>::Exp(xi.cast<T>());
    const Vector6d back = X.Log().template cast<double>();
    EXPECT_LT((back - xi).norm(), 10 * Tol<T>::kRoundTrip * (1.0 + xi.norm())) << xi.transpose();
    // Exp agrees with the matrix exponential of the hat matrix (double reference).
    const Eigen::Matrix4d expected = SE3d::Hat(xi).exp();
    EXPECT_LT((X.Matrix().template cast<double>() - expected).norm(),
              10 * Tol<T>::kRoundTrip * (1.0 + xi.norm()));
  }
}

TYPED_TEST(LieTyped, Sim3ExpLogRoundTripAndMatrixExponential) {
  using T = TypeParam;
  Rng rng(3);
  const std::vector<double> sigmas = {0.0,    1e-12, -1e-9, 1e-6, 0.01, -0.2,         0.5,
                                      -0.999, 1.0,   1.5,   -2.0, 3.0,  rng.Uniform()};
  for (const Eigen::Vector3d& w : TestRotationVectors(&rng)) {
    for (double sigma : sigmas) {
      Vector7d v;
      v << rng.Vector<3>(3.0), w, sigma;
      const Sim3<T> S = Sim3<T>::Exp(v.cast<T>());
      const double tol = 10 * Tol<T>::kRoundTrip * (1.0 + v.norm()) * std::exp(std::abs(sigma));
      const Vector7d back = S.Log().template cast<double>();
      EXPECT_LT((back - v).norm(), tol) << v.transpose();
      const Eigen::Matrix4d expected = Sim3d::Hat(v).exp();
      EXPECT_LT((S.Matrix().template cast<double>() - expected).norm(), tol) << v.transpose();
      EXPECT_NEAR(S.scale(), std::exp(sigma), tol);
    }
  }
}

TYPED_TEST(LieTyped, Sim3ExpOfPureScaleAndScaledTranslation) {
  using T = TypeParam;
  for (double sigma : {-1.5, -0.3, 1e-7, 0.0, 0.7, 2.0}) {
    Vector7d v = Vector7d::Zero();
    v(6) = sigma;
    const Sim3<T> S = Sim3<T>::Exp(v.cast<T>());
    EXPECT_NEAR(S.scale(), std::exp(sigma), 1e-6 * std::exp(sigma));
    EXPECT_LT(S.so3().Angle(), 1e-6);
    EXPECT_LT(S.translation().norm(), 1e-12);
    // p -> e^sigma p.
    const Eigen::Matrix<T, 3, 1> p(T(1), T(-2), T(3));
    EXPECT_LT(((S * p) - T(std::exp(sigma)) * p).norm(), 1e-5 * std::exp(sigma));
    // With a translation and no rotation: t = (e^sigma - 1) / sigma * upsilon.
    v.head<3>() = Eigen::Vector3d(0.4, -1.0, 2.0);
    const Sim3<T> S2 = Sim3<T>::Exp(v.cast<T>());
    const double c = sigma == 0.0 ? 1.0 : std::expm1(sigma) / sigma;
    EXPECT_LT((S2.translation().template cast<double>() - c * v.head<3>()).norm(),
              10 * Tol<T>::kRoundTrip * 5);
  }
}

TYPED_TEST(LieTyped, GroupAxioms) {
  using T = TypeParam;
  using Vec3 = Eigen::Matrix<T, 3, 1>;
  Rng rng(4);
  const double tol = 20 * Tol<T>::kRoundTrip;
  for (int i = 0; i < 20; ++i) {
    Vector7d va, vb, vc;
    va << rng.Vector<3>(2.0), rng.RotationVector(kPi), 0.5 * rng.Uniform();
    vb << rng.Vector<3>(2.0), rng.RotationVector(kPi), 0.5 * rng.Uniform();
    vc << rng.Vector<3>(2.0), rng.RotationVector(kPi), 0.5 * rng.Uniform();
    const Vec3 p = rng.Vector<3>(3.0).cast<T>();
    {  // SE3
      const SE3<T> a = SE3<T>::Exp(va.head<6>().cast<T>());
      const SE3<T> b = SE3<T>::Exp(vb.head<6>().cast<T>());
      const SE3<T> c = SE3<T>::Exp(vc.head<6>().cast<T>());
      EXPECT_LT((((a * b) * c).Matrix() - (a * (b * c)).Matrix()).norm(), tol);
      EXPECT_LT(((a * a.Inverse()).Matrix() - SE3<T>().Matrix()).norm(), tol);
      EXPECT_LT(((a.Inverse() * a).Matrix() - SE3<T>().Matrix()).norm(), tol);
      EXPECT_LT(((a * SE3<T>()).Matrix() - a.Matrix()).norm(), tol);
      EXPECT_LT(((a * b).Matrix() - a.Matrix() * b.Matrix()).norm(), tol);
      EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 10 * tol);
      EXPECT_LT((a.Inverse() * (a * p) - p).norm(), 10 * tol);
      EXPECT_LT((SE3<T>::FromMatrix(a.Matrix()).Matrix() - a.Matrix()).norm(), tol);
      EXPECT_LT((SE3<T>::FromMatrix3x4(a.Matrix3x4Form()).Matrix() - a.Matrix()).norm(), tol);
    }
    {  // Sim3
      const Sim3<T> a = Sim3<T>::Exp(va.cast<T>());
      const Sim3<T> b = Sim3<T>::Exp(vb.cast<T>());
      const Sim3<T> c = Sim3<T>::Exp(vc.cast<T>());
      EXPECT_LT((((a * b) * c).Matrix() - (a * (b * c)).Matrix()).norm(), 10 * tol);
      EXPECT_LT(((a * a.Inverse()).Matrix() - Sim3<T>().Matrix()).norm(), tol);
      EXPECT_LT(((a.Inverse() * a).Matrix() - Sim3<T>().Matrix()).norm(), tol);
      EXPECT_LT(((a * b).Matrix() - a.Matrix() * b.Matrix()).norm(), 10 * tol);
      EXPECT_LT(((a * b) * p - a * (b * p)).norm(), 10 * tol);
      EXPECT_LT((a.Inverse() * (a * p) - p).norm(), 10 * tol);
      EXPECT_LT((Sim3<T>::FromMatrix(a.Matrix()).Matrix() - a.Matrix()).norm(), 10 * tol);
      EXPECT_NEAR((a * b).scale(), a.scale() * b.scale(), tol);
      // Hat/Vee are inverse to each other.
      EXPECT_LT((Sim3<T>::Vee(Sim3<T>::Hat(va.cast<T>())) - va.cast<T>()).norm(), tol);
      // From an SE3 and a scale.
      const Sim3<T> from_rigid(a.RigidPart(), a.scale());
      EXPECT_LT((from_rigid.Matrix() - a.Matrix()).norm(), tol);
      // Cast round trip.
      EXPECT_LT((a.template Cast<double>().template Cast<T>().Matrix() - a.Matrix()).norm(), tol);
    }
  }
}

TYPED_TEST(LieTyped, AdjointConjugatesExp) {
  using T = TypeParam;
  Rng rng(5);
  const double tol = 50 * Tol<T>::kRoundTrip;
  for (int i = 0; i < 20; ++i) {
    Vector7d vx, vv;
    vx << rng.Vector<3>(2.0), rng.RotationVector(kPi), 0.8 * rng.Uniform();
    vv << rng.Vector<3>(0.5), rng.RotationVector(1.0), 0.3 * rng.Uniform();
    {
      const SE3<T> X = SE3<T>::Exp(vx.head<6>().cast<T>());
      const Eigen::Matrix<T, 6, 1> v = vv.head<6>().cast<T>();
      const SE3<T> lhs = X * SE3<T>::Exp(v) * X.Inverse();
      const SE3<T> rhs = SE3<T>::Exp(X.Adjoint() * v);
      EXPECT_LT((lhs.Matrix() - rhs.Matrix()).norm(), tol);
    }
    {
      const Sim3<T> X = Sim3<T>::Exp(vx.cast<T>());
      const Eigen::Matrix<T, 7, 1> v = vv.cast<T>();
      const Sim3<T> lhs = X * Sim3<T>::Exp(v) * X.Inverse();
      const Sim3<T> rhs = Sim3<T>::Exp(X.Adjoint() * v);
      EXPECT_LT((lhs.Matrix() - rhs.Matrix()).norm(), tol);
    }
    {
      const SO3<T> R = SO3<T>::Exp(vx.segment<3>(3).cast<T>());
      const Eigen::Matrix<T, 3, 1> w = vv.segment<3>(3).cast<T>();
      EXPECT_LT(
          ((R * SO3<T>::Exp(w) * R.Inverse()).Matrix() - SO3<T>::Exp(R.Adjoint() * w).Matrix())
              .norm(),
          tol);
    }
  }
}

// Central finite-difference Jacobian of f: R^N -> R^M at x (double).
template <int M, int N, typename F>
Eigen::Matrix<double, M, N> NumericJacobian(const F& f, const Eigen::Matrix<double, N, 1>& x,
                                            double h = 1e-6) {
  Eigen::Matrix<double, M, N> jac;
  for (int i = 0; i < N; ++i) {
    Eigen::Matrix<double, N, 1> dx = Eigen::Matrix<double, N, 1>::Zero();
    dx(i) = h;
    jac.col(i) = (f(x + dx) - f(x - dx)) / (2 * h);
  }
  return jac;
}

// Rotation/transform vectors for the Jacobian checks, including tiny and near-pi angles.
std::vector<Vector6d> JacobianTestTangents() {
  Rng rng(6);
  std::vector<Vector6d> out;
  for (const Eigen::Vector3d& w : TestRotationVectors(&rng)) {
    if (w.norm() > kPi - 0.05) continue;  // FD steps would cross the Log's branch cut at pi
    Vector6d xi;
    xi << rng.Vector<3>(2.0), w;
    out.push_back(xi);
  }
  return out;
}

TEST(LieJacobians, SO3LeftRightJacobiansMatchFiniteDifferences) {
  for (const Vector6d& xi : JacobianTestTangents()) {
    const Eigen::Vector3d w = xi.tail<3>();
    const SO3d R = SO3d::Exp(w);
    const auto left = [&](const Eigen::Vector3d& x) {
      return Eigen::Vector3d((SO3d::Exp(x) * R.Inverse()).Log());
    };
    const auto right = [&](const Eigen::Vector3d& x) {
      return Eigen::Vector3d((R.Inverse() * SO3d::Exp(x)).Log());
    };
    EXPECT_LT((NumericJacobian<3, 3>(left, w) - SO3d::LeftJacobian(w)).norm(), 1e-8) << w;
    EXPECT_LT((NumericJacobian<3, 3>(right, w) - SO3d::RightJacobian(w)).norm(), 1e-8) << w;
    EXPECT_LT(
        (SO3d::LeftJacobian(w) * SO3d::LeftJacobianInverse(w) - Eigen::Matrix3d::Identity()).norm(),
        1e-12);
    EXPECT_LT((SO3d::RightJacobian(w) * SO3d::RightJacobianInverse(w) - Eigen::Matrix3d::Identity())
                  .norm(),
              1e-12);
  }
}

TEST(LieJacobians, SE3LeftRightJacobiansMatchFiniteDifferences) {
  for (const Vector6d& xi : JacobianTestTangents()) {
    const SE3d X = SE3d::Exp(xi);
    // Exp(xi + d) = Exp(J_l d) Exp(xi)  =>  J_l = d Log(Exp(xi + d) Exp(xi)^-1) / dd.
    const auto left = [&](const Vector6d& x) {
      return Vector6d((SE3d::Exp(x) * X.Inverse()).Log());
    };
    const auto right = [&](const Vector6d& x) {
      return Vector6d((X.Inverse() * SE3d::Exp(x)).Log());
    };
    const Matrix6d jl = SE3d::LeftJacobian(xi);
    const Matrix6d jr = SE3d::RightJacobian(xi);
    EXPECT_LT((NumericJacobian<6, 6>(left, xi) - jl).norm(), 1e-7) << xi.transpose();
    EXPECT_LT((NumericJacobian<6, 6>(right, xi) - jr).norm(), 1e-7) << xi.transpose();
    EXPECT_LT((jl * SE3d::LeftJacobianInverse(xi) - Matrix6d::Identity()).norm(), 1e-11);
    EXPECT_LT((jr * SE3d::RightJacobianInverse(xi) - Matrix6d::Identity()).norm(), 1e-11);
    // The right Jacobian is the left one seen through the adjoint: J_l = Adj(Exp(xi)) J_r.
    EXPECT_LT((X.Adjoint() * jr - jl).norm(), 1e-11);
  }
}

TEST(LieJacobians, SE3JacobiansInFloatAgreeWithDouble) {
  for (const Vector6d& xi : JacobianTestTangents()) {
    const Vector6f xf = xi.cast<float>();
    // Relative to the double result of the float-rounded input.
    const Vector6d xr = xf.cast<double>();
    const double scale = 1.0 + xi.norm() * xi.norm();
    EXPECT_LT((SE3f::LeftJacobian(xf).cast<double>() - SE3d::LeftJacobian(xr)).norm(), 1e-5 * scale)
        << xi.transpose();
    EXPECT_LT((SE3f::LeftJacobianInverse(xf).cast<double>() - SE3d::LeftJacobianInverse(xr)).norm(),
              1e-5 * scale)
        << xi.transpose();
    EXPECT_LT((SE3f::RightJacobian(xf).cast<double>() - SE3d::RightJacobian(xr)).norm(),
              1e-5 * scale)
        << xi.transpose();
    EXPECT_LT((SO3f::LeftJacobianInverse(xf.tail<3>()).cast<double>() -
               SO3d::LeftJacobianInverse(xr.tail<3>()))
                  .norm(),
              1e-5 * scale);
  }
}

TEST(LieJacobians, ActionJacobiansMatchFiniteDifferences) {
  Rng rng(7);
  for (int i = 0; i < 20; ++i) {
    Vector7d v;
    v << rng.Vector<3>(2.0), rng.RotationVector(kPi), 0.7 * rng.Uniform();
    const Eigen::Vector3d p = rng.Vector<3>(4.0);
    {
      const SE3d X = SE3d::Exp(v.head<6>());
      const auto left = [&](const Vector6d& d) { return Eigen::Vector3d(SE3d::Exp(d) * X * p); };
      const auto right = [&](const Vector6d& d) { return Eigen::Vector3d(X * SE3d::Exp(d) * p); };
      EXPECT_LT((NumericJacobian<3, 6>(left, Vector6d::Zero()) - X.ActionJacobianLeft(p)).norm(),
                1e-8);
      EXPECT_LT((NumericJacobian<3, 6>(right, Vector6d::Zero()) - X.ActionJacobianRight(p)).norm(),
                1e-8);
      // Float versions agree.
      EXPECT_LT((X.Cast<float>().ActionJacobianLeft(p.cast<float>()).cast<double>() -
                 X.ActionJacobianLeft(p))
                    .norm(),
                1e-4);
      EXPECT_LT((X.Cast<float>().ActionJacobianRight(p.cast<float>()).cast<double>() -
                 X.ActionJacobianRight(p))
                    .norm(),
                1e-4);
    }
    {
      const Sim3d S = Sim3d::Exp(v);
      const auto left = [&](const Vector7d& d) { return Eigen::Vector3d(Sim3d::Exp(d) * S * p); };
      const auto right = [&](const Vector7d& d) { return Eigen::Vector3d(S * Sim3d::Exp(d) * p); };
      EXPECT_LT((NumericJacobian<3, 7>(left, Vector7d::Zero()) - S.ActionJacobianLeft(p)).norm(),
                1e-7);
      EXPECT_LT((NumericJacobian<3, 7>(right, Vector7d::Zero()) - S.ActionJacobianRight(p)).norm(),
                1e-7);
    }
  }
}

TEST(LieJacobians, Sim3ExpNearZeroIsContinuousAcrossTheSeriesSwitch) {
  // W coefficients just inside and outside |(sigma, theta)| = 1 must agree to ~eps (same
  // function, two formulas).
  for (double angle : {0.0, 0.3, 0.7}) {
    const double sigma_sq = 1.0 - angle * angle;
    for (double sign : {-1.0, 1.0}) {
      const double sigma = sign * std::sqrt(sigma_sq);
      const Eigen::Vector3d w = Eigen::Vector3d(0.6, 0.0, 0.8) * angle;
      const Eigen::Matrix3d inside = Sim3d::WMatrix(sigma * (1 - 1e-12), w * (1 - 1e-12));
      const Eigen::Matrix3d outside = Sim3d::WMatrix(sigma * (1 + 1e-12), w * (1 + 1e-12));
      EXPECT_LT((inside - outside).norm(), 1e-11) << sigma << " " << angle;
    }
  }
}

TEST(Lie, SO3FromMatrixProjectsOntoNearestRotation) {
  Rng rng(8);
  const SO3d R = SO3d::Exp(rng.RotationVector(2.0));
  // A rotation printed with 6 digits: not orthonormal, projected back within that precision.
  Eigen::Matrix3d noisy = R.Matrix();
  for (int i = 0; i < 9; ++i) noisy(i / 3, i % 3) += 1e-6 * rng.Uniform();
  const SO3d projected = SO3d::FromMatrix(noisy);
  EXPECT_LT((projected.Matrix() - R.Matrix()).norm(), 1e-5);
  EXPECT_LT(
      (projected.Matrix().transpose() * projected.Matrix() - Eigen::Matrix3d::Identity()).norm(),
      1e-12);
  // The projection is the SVD one: the result is closer to the input than the original rotation.
  EXPECT_LE((projected.Matrix() - noisy).norm(), (R.Matrix() - noisy).norm() + 1e-15);
  // A scaled rotation gives the rotation back.
  EXPECT_LT((SO3d::FromMatrix(2.5 * R.Matrix()).Matrix() - R.Matrix()).norm(), 1e-12);
  // A reflection yields a proper rotation (det +1).
  Eigen::Matrix3d reflection = R.Matrix();
  reflection.col(2) *= -1;
  EXPECT_NEAR(SO3d::FromMatrix(reflection).Matrix().determinant(), 1.0, 1e-12);
}

TEST(Lie, Sim3RejectsNonPositiveScale) {
  EXPECT_THROW(Sim3d(0.0, SO3d(), Eigen::Vector3d::Zero()), InternalError);
  EXPECT_THROW(Sim3d(-1.0, SO3d(), Eigen::Vector3d::Zero()), InternalError);
  EXPECT_THROW(Sim3d(std::nan(""), SO3d(), Eigen::Vector3d::Zero()), InternalError);
  Eigen::Matrix4d reflect = Eigen::Matrix4d::Identity();
  reflect(0, 0) = -1;
  EXPECT_THROW(Sim3d::FromMatrix(reflect), InternalError);
}

TEST(Lie, LogAtPiHasAnglePi) {
  for (const Eigen::Vector3d& axis : {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0),
                                      Eigen::Vector3d(1, 1, 1).normalized()}) {
    const SO3d R = SO3d::Exp(kPi * axis);
    EXPECT_NEAR(R.Angle(), kPi, 1e-9);
    // Log at pi is +-pi axis; both give the same rotation.
    EXPECT_LT((SO3d::Exp(R.Log()).Matrix() - R.Matrix()).norm(), 1e-9);
    const SO3f Rf = SO3f::Exp(float(kPi) * axis.cast<float>());
    EXPECT_NEAR(Rf.Angle(), kPi, 1e-3);
  }
}

}  // namespace
}  // namespace dfo
