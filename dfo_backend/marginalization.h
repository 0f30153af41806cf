// Marginalisation for the sliding window: VINS-Mono's recipe (Schur complement, eigen-
// decomposition, the prior as a Ceres cost) with DSO's choices (DESIGN.md, backend).
//
// Given factors linearised at the current estimate x0 (residual r_f and tangent-space Jacobians
// J_f,i per variable i, robust loss already folded in by ApplyLossCorrection), the quadratic
// model of the energy is
//   E(x0 [+] dx) ~= sum_f |r_f + J_f dx|^2 = const + 2 b^T dx + dx^T H dx,
//   H = sum_f J_f^T J_f,  b = sum_f J_f^T r_f.
// Marginalising the variables m (points, the leaving pose) keeps the Schur complement on the rest
// k:  H* = H_kk - H_km H_mm^+ H_mk,  b* = b_k - H_km H_mm^+ b_m.
// Elimination runs in two stages: marginalised variables that share no factor with each other
// (the points: H_mm is block-diagonal there) one by one, then the rest (the leaving pose) densely
// after Jacobi scaling D = diag(H)^-1/2 (symmetrised, pseudo-inverse through eigenvalues). Then
//   D H* D = V L V^T (eigenvalues below relative_eigenvalue_floor * max dropped),
//   J0 = L^1/2 V^T D^-1,   r0 = L^-1/2 V^T D b*,
// so that |r0 + J0 dx|^2 = const + 2 b*^T dx + dx^T H* dx. The prior enters the next solve as the
// Ceres cost r0 + J0 (x [-] x0) with [-] the manifold's Minus (LinearPriorCost).
#ifndef DFO_BACKEND_MARGINALIZATION_H_
#define DFO_BACKEND_MARGINALIZATION_H_

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace dfo {

// One variable of a marginalisation problem, identified by its index in the vector passed to
// Marginalize.
struct MarginalizationVariable {
  int tangent_size = 0;      // dimension of its tangent space (6 for a pose, 1 for a point)
  bool marginalize = false;  // true: eliminated; false: kept (gets a column block in the prior)
};

// A residual block linearised at x0: residual r (N) and, per variable it involves, the N x d
// Jacobian in that variable's tangent space.
struct LinearizedFactor {
  Eigen::VectorXd residual;
  std::vector<int> variables;              // indices into the variable vector
  std::vector<Eigen::MatrixXd> jacobians;  // same order as variables, N x tangent_size each
};

// Folds a robust loss into a linearised factor as Ceres does inside its solver (Triggs et al.,
// "Bundle adjustment: a modern synthesis", sec. 4.3; ceres::internal::Corrector): with
// s = |r|^2 and rho = loss(s), r <- sqrt(rho') / (1 - alpha) r and
// J <- sqrt(rho') (I - alpha r r^T / |r|^2) J, alpha the root of alpha^2/2 - alpha =
// rho'' s / rho' (alpha = 0 when rho'' <= 0, as for Huber and Cauchy). loss == nullptr: no-op.
void ApplyLossCorrection(const ceres::LossFunction* loss, LinearizedFactor* factor);

// Numerical settings of Marginalize.
struct MarginalizationOptions {
  // Eigenvalues of the (Jacobi-scaled) prior Hessian below this fraction of the largest are
  // treated as zero (unobservable directions, e.g. the gauge); in (0, 1).
  double relative_eigenvalue_floor = 1e-8;
  // A negative eigenvalue below -this * largest means an indefinite Hessian beyond round-off:
  // the prior is rejected; > 0.
  double max_negative_eigenvalue_ratio = 1e-6;
  // Throws ConfigError naming the field.
  void Check() const;
};

// The prior on the kept variables: E(dx) = |residual + jacobian dx|^2 with dx the stacked tangent
// differences of `variables` (column blocks in that order, offsets in `offsets`).
struct LinearPrior {
  std::vector<int> variables;  // kept variable indices, connected to at least one factor
  std::vector<int> offsets;    // column offset of each variable's block in `jacobian`
  Eigen::MatrixXd jacobian;    // J0, rank x sum of tangent sizes
  Eigen::VectorXd residual;    // r0, rank
  int rank() const { return static_cast<int>(residual.size()); }
  // Quadratic energy at the stacked tangent difference dx.
  double Energy(const Eigen::VectorXd& dx) const {
    return (residual + jacobian * dx).squaredNorm();
  }
};

// Builds the prior of marginalising the variables flagged `marginalize`. Returns false (and
// says why in *why: non-finite values, an indefinite Hessian, no information left) when no usable
// prior results; the caller then drops the factors instead (DESIGN.md: reject, warn, continue).
bool Marginalize(const std::vector<MarginalizationVariable>& variables,
                 const std::vector<LinearizedFactor>& factors,
                 const MarginalizationOptions& options, LinearPrior* prior, std::string* why);

// Removes the directions spanned by the columns of `nullspace` (tangent coordinates of the
// prior's variables, stacked as in prior->jacobian) from the prior: with P the orthogonal
// projector onto their complement, H = P J0^T J0 P and b = P J0^T r0 are factored again
// (eigenvalues below relative_eigenvalue_floor * max dropped). DSO does the same with its 7
// gauge directions (EnergyFunctional::orthogonalize): relinearising the factors of kept poses at
// different points otherwise gives the prior spurious information along the gauge (measured: a
// merged prior of rank 26 on 5 poses, whose minimum rotated every pose by 0.7 rad). Returns
// false when nothing is left.
// last_column_kept in [0, 1]: the direction of the last column (orthogonalised against the others)
// is not removed but scaled by it: the prior's information along it is multiplied by its square
// (0: removed as the others; 1: kept whole).
bool ProjectOutNullspace(const Eigen::MatrixXd& nullspace, double relative_eigenvalue_floor,
                         LinearPrior* prior, double last_column_kept = 0.0);

// How a prior block's tangent difference x [-] x0 is formed.
enum class PriorBlockKind {
  kEuclidean,  // x - x0, ambient size = tangent size
  kPose,       // Log(T T0^-1), 7-double pose blocks (dfo_backend/pose_manifold.h)
};

// The prior as a Ceres cost: r = r0 + J0 (x [-] x0), one parameter block per kept variable.
// Jacobian per pose block: J0_i J_l^-1(Log(T T0^-1)) (exact derivative of the left-perturbed
// Minus), or J0_i alone with first_estimate_jacobians (the Jacobian stays the one computed at x0,
// the first-estimate-Jacobian idea of Huang et al. applied to the prior).
class LinearPriorCost : public ceres::CostFunction {
 public:
  // kinds[i] and x0[i] (ambient values at linearisation) for prior.variables[i].
  LinearPriorCost(LinearPrior prior, std::vector<PriorBlockKind> kinds,
                  std::vector<std::vector<double>> x0, bool first_estimate_jacobians);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;
  // The same residual with tangent-space Jacobians, for marginalising this prior again.
  LinearizedFactor Linearize(double const* const* parameters) const;
  // Stacked tangent difference x [-] x0.
  Eigen::VectorXd TangentDifference(double const* const* parameters) const;

  const LinearPrior& prior() const { return prior_; }
  const std::vector<std::vector<double>>& x0() const { return x0_; }
  const std::vector<PriorBlockKind>& kinds() const { return kinds_; }

 private:
  // d (x_i [-] x0_i) / d (tangent perturbation of x_i), tangent x tangent.
  Eigen::MatrixXd TangentJacobian(int block, const double* x) const;

  LinearPrior prior_;
  std::vector<PriorBlockKind> kinds_;
  std::vector<std::vector<double>> x0_;
  bool first_estimate_jacobians_;
};

}  // namespace dfo

#endif  // DFO_BACKEND_MARGINALIZATION_H_
