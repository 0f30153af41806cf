#include "dfo_backend/marginalization.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <cmath>
#include <set>
#include <sstream>

#include "dfo_backend/pose_manifold.h"
#include "dfo_core/error.h"
#include "dfo_core/lie.h"

namespace dfo {

void ApplyLossCorrection(const ceres::LossFunction* loss, LinearizedFactor* factor) {
  if (loss == nullptr) return;
  const double sq_norm = factor->residual.squaredNorm();
  double rho[3];
  loss->Evaluate(sq_norm, rho);
  const double sqrt_rho1 = std::sqrt(std::max(rho[1], 0.0));
  double residual_scaling = sqrt_rho1, alpha_sq_norm = 0.0;
  if (sq_norm > 0.0 && rho[2] > 0.0 && rho[1] > 0.0) {
    // Same branch structure as ceres::internal::Corrector (corrector.cc).
    const double d = 1.0 + 2.0 * sq_norm * rho[2] / rho[1];
    const double alpha = 1.0 - std::sqrt(d);
    residual_scaling = sqrt_rho1 / (1.0 - alpha);
    alpha_sq_norm = alpha / sq_norm;
  }
  for (Eigen::MatrixXd& jac : factor->jacobians) {
    if (alpha_sq_norm != 0.0) {
      jac = sqrt_rho1 *
            (jac - alpha_sq_norm * factor->residual * (factor->residual.transpose() * jac));
    } else {
      jac *= sqrt_rho1;
    }
  }
  factor->residual *= residual_scaling;
}

void MarginalizationOptions::Check() const {
  if (!(relative_eigenvalue_floor > 0.0 && relative_eigenvalue_floor < 1.0)) {
    std::ostringstream msg;
    msg << "marginalization.relative_eigenvalue_floor = " << relative_eigenvalue_floor
        << " violates in (0, 1)";
    throw ConfigError(msg.str());
  }
  if (!(max_negative_eigenvalue_ratio > 0.0)) {
    std::ostringstream msg;
    msg << "marginalization.max_negative_eigenvalue_ratio = " << max_negative_eigenvalue_ratio
        << " violates > 0";
    throw ConfigError(msg.str());
  }
}

namespace {

// Pseudo-inverse of a small symmetric positive semi-definite matrix through its eigenvalues
// (values below floor * max treated as zero), as VINS-Mono inverts A_mm.
Eigen::MatrixXd PseudoInverse(const Eigen::MatrixXd& a, double floor) {
  if (a.rows() == 1) {
    return Eigen::MatrixXd::Constant(1, 1, a(0, 0) > 1e-300 ? 1.0 / a(0, 0) : 0.0);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (a + a.transpose()));
  const Eigen::VectorXd& l = eig.eigenvalues();
  const double threshold = floor * std::max(l.maxCoeff(), 0.0);
  Eigen::VectorXd l_inv(l.size());
  for (int i = 0; i < l.size(); ++i) l_inv(i) = l(i) > threshold && l(i) > 0.0 ? 1.0 / l(i) : 0.0;
  return eig.eigenvectors() * l_inv.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

bool Marginalize(const std::vector<MarginalizationVariable>& variables,
                 const std::vector<LinearizedFactor>& factors,
                 const MarginalizationOptions& options, LinearPrior* prior, std::string* why) {
  options.Check();
  DFO_CHECK(prior != nullptr);
  const int num_vars = static_cast<int>(variables.size());
  auto fail = [why](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };

  // Which variables take part, and which marginalised ones share a factor.
  std::vector<char> involved(num_vars, 0);
  std::vector<std::set<int>> neighbours(num_vars);
  for (const LinearizedFactor& f : factors) {
    DFO_CHECK(f.variables.size() == f.jacobians.size());
    for (size_t a = 0; a < f.variables.size(); ++a) {
      const int v = f.variables[a];
      DFO_CHECK(v >= 0 && v < num_vars) << "variable " << v;
      DFO_CHECK(f.jacobians[a].rows() == f.residual.size() &&
                f.jacobians[a].cols() == variables[v].tangent_size)
          << "factor Jacobian " << f.jacobians[a].rows() << "x" << f.jacobians[a].cols()
          << " for residual " << f.residual.size() << ", tangent " << variables[v].tangent_size;
      if (!f.residual.allFinite() || !f.jacobians[a].allFinite()) {
        return fail("a linearised factor is not finite");
      }
      involved[v] = 1;
      for (int w : f.variables) {
        if (w != v) neighbours[v].insert(w);
      }
    }
  }
  // Stage-1 set P: marginalised variables pairwise without a common factor (smallest first, so
  // that points go here and poses, which touch many points, stay for the dense stage).
  std::vector<int> order;
  for (int v = 0; v < num_vars; ++v) {
    if (involved[v] && variables[v].marginalize) order.push_back(v);
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return variables[a].tangent_size < variables[b].tangent_size;
  });
  std::vector<char> in_p(num_vars, 0);
  for (int v : order) {
    bool free = true;
    for (int w : neighbours[v]) free = free && !in_p[w];
    if (free) in_p[v] = 1;
  }
  // Dense indices of the rest R: marginalised-but-coupled first, kept after.
  std::vector<int> r_offset(num_vars, -1), p_index(num_vars, -1);
  std::vector<int> r_marg, r_kept, p_vars;
  for (int v = 0; v < num_vars; ++v) {
    if (!involved[v]) continue;
    if (in_p[v]) {
      p_index[v] = static_cast<int>(p_vars.size());
      p_vars.push_back(v);
    } else if (variables[v].marginalize) {
      r_marg.push_back(v);
    } else {
      r_kept.push_back(v);
    }
  }
  int n_r = 0, n_rm = 0;
  for (int v : r_marg) {
    r_offset[v] = n_r;
    n_r += variables[v].tangent_size;
  }
  n_rm = n_r;
  for (int v : r_kept) {
    r_offset[v] = n_r;
    n_r += variables[v].tangent_size;
  }
  if (n_r == n_rm) return fail("no kept variable is connected to the marginalised ones");

  Eigen::MatrixXd h_rr = Eigen::MatrixXd::Zero(n_r, n_r);
  Eigen::VectorXd b_r = Eigen::VectorXd::Zero(n_r);
  std::vector<Eigen::MatrixXd> h_pp(p_vars.size()), h_rp(p_vars.size());
  std::vector<Eigen::VectorXd> b_p(p_vars.size());
  for (size_t i = 0; i < p_vars.size(); ++i) {
    const int d = variables[p_vars[i]].tangent_size;
    h_pp[i] = Eigen::MatrixXd::Zero(d, d);
    h_rp[i] = Eigen::MatrixXd::Zero(n_r, d);
    b_p[i] = Eigen::VectorXd::Zero(d);
  }
  for (const LinearizedFactor& f : factors) {
    for (size_t a = 0; a < f.variables.size(); ++a) {
      const int va = f.variables[a];
      const Eigen::MatrixXd jat = f.jacobians[a].transpose();
      if (in_p[va]) {
        b_p[p_index[va]] += jat * f.residual;
      } else {
        b_r.segment(r_offset[va], variables[va].tangent_size) += jat * f.residual;
      }
      for (size_t c = 0; c < f.variables.size(); ++c) {
        const int vc = f.variables[c];
        const Eigen::MatrixXd block = jat * f.jacobians[c];
        if (in_p[va] && in_p[vc]) {
          h_pp[p_index[va]] += block;  // va == vc by construction of P
        } else if (!in_p[va] && in_p[vc]) {
          h_rp[p_index[vc]].middleRows(r_offset[va], variables[va].tangent_size) += block;
        } else if (!in_p[va] && !in_p[vc]) {
          h_rr.block(r_offset[va], r_offset[vc], block.rows(), block.cols()) += block;
        }
      }
    }
  }
  // Stage 1: eliminate P one variable at a time (H_pp block-diagonal).
  for (size_t i = 0; i < p_vars.size(); ++i) {
    const Eigen::MatrixXd inv = PseudoInverse(h_pp[i], options.relative_eigenvalue_floor);
    const Eigen::MatrixXd h_rp_inv = h_rp[i] * inv;
    h_rr.noalias() -= h_rp_inv * h_rp[i].transpose();
    b_r.noalias() -= h_rp_inv * b_p[i];
  }
  // Stage 2: Jacobi scaling, then eliminate the coupled marginalised block densely.
  Eigen::VectorXd scale(n_r);
  for (int i = 0; i < n_r; ++i) {
    scale(i) = h_rr(i, i) > 1e-300 ? 1.0 / std::sqrt(h_rr(i, i)) : 1.0;
  }
  Eigen::MatrixXd hs = scale.asDiagonal() * h_rr * scale.asDiagonal();
  hs = 0.5 * (hs + hs.transpose()).eval();
  const Eigen::VectorXd bs = scale.cwiseProduct(b_r);
  const int n_k = n_r - n_rm;
  Eigen::MatrixXd h_star = hs.bottomRightCorner(n_k, n_k);
  Eigen::VectorXd b_star = bs.tail(n_k);
  if (n_rm > 0) {
    const Eigen::MatrixXd inv =
        PseudoInverse(hs.topLeftCorner(n_rm, n_rm), options.relative_eigenvalue_floor);
    const Eigen::MatrixXd h_km_inv = hs.bottomLeftCorner(n_k, n_rm) * inv;
    h_star.noalias() -= h_km_inv * hs.topRightCorner(n_rm, n_k);
    b_star.noalias() -= h_km_inv * bs.head(n_rm);
  }
  h_star = 0.5 * (h_star + h_star.transpose()).eval();
  if (!h_star.allFinite() || !b_star.allFinite()) return fail("the prior Hessian is not finite");

  // Kept variables with information left (non-zero diagonal).
  std::vector<int> kept_cols;
  LinearPrior out;
  int cols = 0;
  for (int v : r_kept) {
    const int off = r_offset[v] - n_rm, d = variables[v].tangent_size;
    if (h_rr.diagonal().segment(r_offset[v], d).maxCoeff() <= 0.0) continue;
    out.variables.push_back(v);
    out.offsets.push_back(cols);
    for (int j = 0; j < d; ++j) kept_cols.push_back(off + j);
    cols += d;
  }
  if (cols == 0) return fail("no information left on the kept variables");
  Eigen::MatrixXd h_kept(cols, cols);
  Eigen::VectorXd b_kept(cols), scale_kept(cols);
  for (int i = 0; i < cols; ++i) {
    b_kept(i) = b_star(kept_cols[i]);
    scale_kept(i) = scale(n_rm + kept_cols[i]);
    for (int j = 0; j < cols; ++j) h_kept(i, j) = h_star(kept_cols[i], kept_cols[j]);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(h_kept);
  if (eig.info() != Eigen::Success) return fail("the eigen-decomposition of the prior failed");
  const Eigen::VectorXd& l = eig.eigenvalues();
  const double l_max = l.maxCoeff();
  if (!std::isfinite(l_max) || l_max <= 0.0) return fail("the prior Hessian has no information");
  if (l.minCoeff() < -options.max_negative_eigenvalue_ratio * l_max) {
    std::ostringstream msg;
    msg << "the prior Hessian is indefinite (eigenvalues " << l.minCoeff() << " .. " << l_max
        << ")";
    return fail(msg.str());
  }
  const double threshold = options.relative_eigenvalue_floor * l_max;
  std::vector<int> keep;
  for (int i = 0; i < l.size(); ++i) {
    if (l(i) > threshold) keep.push_back(i);
  }
  const int rank = static_cast<int>(keep.size());
  out.jacobian.resize(rank, cols);
  out.residual.resize(rank);
  for (int r = 0; r < rank; ++r) {
    const Eigen::VectorXd v = eig.eigenvectors().col(keep[r]);
    const double sqrt_l = std::sqrt(l(keep[r]));
    // J0 = L^1/2 V^T D^-1 (undo the Jacobi scaling), r0 = L^-1/2 V^T (D b*).
    out.jacobian.row(r) = sqrt_l * v.cwiseQuotient(scale_kept).transpose();
    out.residual(r) = v.dot(b_kept) / sqrt_l;
  }
  if (!out.jacobian.allFinite() || !out.residual.allFinite()) {
    return fail("the prior factor is not finite");
  }
  *prior = std::move(out);
  return true;
}

bool ProjectOutNullspace(const Eigen::MatrixXd& nullspace, double relative_eigenvalue_floor,
                         LinearPrior* prior, double last_column_kept) {
  const int n = static_cast<int>(prior->jacobian.cols());
  DFO_CHECK(nullspace.rows() == n) << nullspace.rows() << " vs " << n;
  // Orthonormal basis Q of the null space; P = I - Q Q^T.
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(nullspace);
  const Eigen::MatrixXd q =
      qr.householderQ() * Eigen::MatrixXd::Identity(n, std::min<int>(n, nullspace.cols()));
  DFO_CHECK(last_column_kept >= 0.0 && last_column_kept <= 1.0) << last_column_kept;
  Eigen::MatrixXd p = Eigen::MatrixXd::Identity(n, n) - q * q.transpose();
  if (last_column_kept > 0.0 && q.cols() > 0) {
    // Q's last column spans the last nullspace column orthogonalised against the earlier ones.
    const Eigen::VectorXd u = q.col(q.cols() - 1);
    p += last_column_kept * u * u.transpose();
  }
  const Eigen::MatrixXd j = prior->jacobian * p;
  Eigen::MatrixXd h = j.transpose() * j;
  h = 0.5 * (h + h.transpose()).eval();
  const Eigen::VectorXd b = j.transpose() * prior->residual;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(h);
  if (eig.info() != Eigen::Success) return false;
  const Eigen::VectorXd& l = eig.eigenvalues();
  const double l_max = l.maxCoeff();
  if (!(l_max > 0.0) || !std::isfinite(l_max)) return false;
  std::vector<int> keep;
  for (int i = 0; i < n; ++i) {
    if (l(i) > relative_eigenvalue_floor * l_max) keep.push_back(i);
  }
  Eigen::MatrixXd jacobian(keep.size(), n);
  Eigen::VectorXd residual(keep.size());
  for (size_t r = 0; r < keep.size(); ++r) {
    const Eigen::VectorXd v = eig.eigenvectors().col(keep[r]);
    const double sqrt_l = std::sqrt(l(keep[r]));
    jacobian.row(r) = sqrt_l * v.transpose();
    residual(r) = v.dot(b) / sqrt_l;
  }
  prior->jacobian = std::move(jacobian);
  prior->residual = std::move(residual);
  return prior->rank() > 0;
}

LinearPriorCost::LinearPriorCost(LinearPrior prior, std::vector<PriorBlockKind> kinds,
                                 std::vector<std::vector<double>> x0, bool first_estimate_jacobians)
    : prior_(std::move(prior)),
      kinds_(std::move(kinds)),
      x0_(std::move(x0)),
      first_estimate_jacobians_(first_estimate_jacobians) {
  DFO_CHECK(kinds_.size() == prior_.variables.size() && x0_.size() == kinds_.size());
  set_num_residuals(prior_.rank());
  for (size_t i = 0; i < kinds_.size(); ++i) {
    const int tangent =
        (i + 1 < kinds_.size() ? prior_.offsets[i + 1] : static_cast<int>(prior_.jacobian.cols())) -
        prior_.offsets[i];
    const int ambient = kinds_[i] == PriorBlockKind::kPose ? kPoseAmbientSize : tangent;
    DFO_CHECK(kinds_[i] != PriorBlockKind::kPose || tangent == kPoseTangentSize);
    DFO_CHECK(static_cast<int>(x0_[i].size()) == ambient);
    mutable_parameter_block_sizes()->push_back(ambient);
  }
}

Eigen::VectorXd LinearPriorCost::TangentDifference(double const* const* parameters) const {
  Eigen::VectorXd dx(prior_.jacobian.cols());
  for (size_t i = 0; i < kinds_.size(); ++i) {
    const int off = prior_.offsets[i];
    if (kinds_[i] == PriorBlockKind::kPose) {
      dx.segment<6>(off) =
          (PoseFromParameters(parameters[i]) * PoseFromParameters(x0_[i].data()).Inverse()).Log();
    } else {
      const int d = parameter_block_sizes()[i];
      for (int j = 0; j < d; ++j) dx(off + j) = parameters[i][j] - x0_[i][j];
    }
  }
  return dx;
}

Eigen::MatrixXd LinearPriorCost::TangentJacobian(int block, const double* x) const {
  if (kinds_[block] != PriorBlockKind::kPose) {
    const int d = parameter_block_sizes()[block];
    return Eigen::MatrixXd::Identity(d, d);
  }
  if (first_estimate_jacobians_) return Eigen::MatrixXd::Identity(6, 6);
  // d Log(Exp(d) T T0^-1) / d d = J_l^-1(Log(T T0^-1)) (lie.h: Exp(xi + J_l^-1 d) ~ Exp(d)
  // Exp(xi)).
  const Vector6d xi =
      (PoseFromParameters(x) * PoseFromParameters(x0_[block].data()).Inverse()).Log();
  return SE3d::LeftJacobianInverse(xi);
}

bool LinearPriorCost::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const Eigen::VectorXd dx = TangentDifference(parameters);
  Eigen::Map<Eigen::VectorXd> r(residuals, prior_.rank());
  r = prior_.residual + prior_.jacobian * dx;
  if (jacobians == nullptr) return r.allFinite();
  for (size_t i = 0; i < kinds_.size(); ++i) {
    if (jacobians[i] == nullptr) continue;
    const int off = prior_.offsets[i];
    const int ambient = parameter_block_sizes()[i];
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    Eigen::Map<RowMajor> jac(jacobians[i], prior_.rank(), ambient);
    if (kinds_[i] == PriorBlockKind::kPose) {
      jac = prior_.jacobian.middleCols<6>(off) *
            TangentJacobian(static_cast<int>(i), parameters[i]) * PoseMinusJacobian(parameters[i]);
    } else {
      jac = prior_.jacobian.middleCols(off, ambient);
    }
  }
  return r.allFinite();
}

LinearizedFactor LinearPriorCost::Linearize(double const* const* parameters) const {
  LinearizedFactor f;
  f.residual = prior_.residual + prior_.jacobian * TangentDifference(parameters);
  for (size_t i = 0; i < kinds_.size(); ++i) {
    const int off = prior_.offsets[i];
    const int d = kinds_[i] == PriorBlockKind::kPose ? 6 : parameter_block_sizes()[i];
    f.variables.push_back(static_cast<int>(i));  // caller remaps to its own variable indices
    f.jacobians.push_back(prior_.jacobian.middleCols(off, d) *
                          TangentJacobian(static_cast<int>(i), parameters[i]));
  }
  return f;
}

}  // namespace dfo
