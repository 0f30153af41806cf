// The feature-metric residual of the sliding window (DESIGN.md, backend; PixSfM's feature-metric
// BA, DSO's photometric residual with learned features in place of intensities).
//
// A point is hosted in keyframe h at the integer pixel u of the BA pyramid level, with one
// parameter, its inverse depth rho (1/m). For every K x K patch offset o_k (spacing 1 px) the
// pixel u_k = u + o_k is back-projected with the SAME inverse depth, moved into the target
// keyframe t and projected (each patch pixel is warped exactly, DSO's pattern):
//   X_h   = ray(u_k) / rho,                   ray(u) = ((u - c) / f, 1)
// (with a depth shape, ray(u_k) is multiplied by the fixed factor d_k / d_0 of the host depth
// map; the formulas below hold with that scaled ray)
//   p_k   = pi(T_t^-1 T_h X_h),               T = world_from_cam of the keyframe
//   r_ck  = F_h(c, u_k) - F_t(c, p_k)         c = 0..C-1, F_t bilinearly interpolated
// giving C x K x K residuals, index c * K * K + k, k = (dy + K/2) * K + (dx + K/2).
//
// Jacobians (hand-written; the autodiff twin in tests/backend checks them). Projection is
// invariant to scaling its argument, so use Y = rho T_t^-1 T_h X_h = R_t^T (Z_w - rho t_t) with
// Z_w = R_h ray + rho t_h (finite for rho -> 0, points at infinity). With left perturbations
// T <- Exp(d) T of world_from_cam (dfo_backend/pose_manifold.h):
//   dY / d d_host   = R_t^T [rho I, -hat(Z_w)],
//   dY / d d_target = -dY / d d_host            (a common left factor cancels: gauge freedom),
//   dY / d rho      = R_t^T (t_h - t_t),
//   d r_ck / d .    = -grad F_t(c, p_k)^T  dpi/dY(Y)  dY / d .
// with grad F_t the gradient of the bilinear interpolant itself (so the derivative is exact
// wherever the interpolant is differentiable, i.e. off the integer grid lines).
//
// A patch pixel whose projection falls outside the target image is sampled at the projection
// clamped to the image border (derivative 0 along the clamped axis); one behind the camera is
// compared against 0 (the z-scored mean) with zero Jacobian rows. Neither gives a zero residual,
// so a solve is never rewarded for moving points out of view. The window only creates a block
// when the whole patch is visible.
#ifndef DFO_BACKEND_FEATURE_METRIC_COST_H_
#define DFO_BACKEND_FEATURE_METRIC_COST_H_

#include <ceres/cost_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/feature_map.h"

namespace dfo {

using RowMajorMatrixXd = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// The C x K x K host patch of `level` centred on the integer pixel (x, y), in the residual order
// above (channel-major). The patch must lie inside the level (checked, InternalError).
std::vector<double> SampleHostPatch(const FeatureLevel& level, int x, int y, int patch_size);

// The same patch centred on a continuous pixel (u, v), bilinearly interpolated (the host patch of
// a point on a coarser level than the one it was selected on). Returns false, leaving *patch
// untouched, when a patch pixel falls outside [0, width - 1] x [0, height - 1].
bool SampleHostPatchBilinear(const FeatureLevel& level, const Eigen::Vector2d& uv, int patch_size,
                             std::vector<double>* patch);

// `patch` (C x K x K, channel-major, as SampleHostPatch) with every channel of derivative order
// n (FeatureLevel::derivative_order; missing entries count as 0) scaled by zoom^-n: the patch as
// a view that sees it `zoom` times larger sees its gradients
// (WindowOptions::zoom_scaled_gradients). Null when no channel has a derivative order.
std::shared_ptr<const std::vector<double>> ZoomScaledPatch(const std::vector<double>& patch,
                                                           const std::vector<int>& orders,
                                                           int patch_size, double zoom);

// Everything one residual block needs to evaluate, by value. FeatureMetricCost and
// CompressedFeatureMetricCost each hold a copy, so that evaluating a block reads one small object
// and the images rather than a chain of heap objects: the window's solves are bound by memory
// latency (about 10^4 blocks over 7 keyframes' feature maps do not fit in the caches).
struct FeatureMetricBlock {
  const FeatureLevel* target = nullptr;  // not owned
  // C * K * K host values, channel-major; host_patch points into host_patch_owner.
  const double* host_patch = nullptr;
  std::shared_ptr<const std::vector<double>> host_patch_owner;
  Eigen::Vector3d center_ray = Eigen::Vector3d::Zero();  // host ray through the patch centre
  double ray_step_x = 0.0, ray_step_y = 0.0;  // ray change per pixel step: 1 / fx, 1 / fy
  int patch_size = 1;
  // Optional K * K factors d_k / d_0 of the patch pixels' depths over the centre's (the host
  // depth map's local shape); null: one depth for the whole patch (fronto-parallel).
  const double* depth_shape = nullptr;
  std::shared_ptr<const std::vector<double>> depth_shape_owner;

  // Host ray of patch pixel k = (dy + K/2) K + (dx + K/2), scaled by its depth factor: the
  // pixel's point is Ray(k) / inverse_depth.
  Eigen::Vector3d Ray(int k) const {
    const int radius = patch_size / 2;
    const Eigen::Vector3d ray =
        center_ray + Eigen::Vector3d((k % patch_size - radius) * ray_step_x,
                                     (k / patch_size - radius) * ray_step_y, 0.0);
    return depth_shape ? Eigen::Vector3d(ray * depth_shape[k]) : ray;
  }
  // See FeatureMetricCost: residuals and tangent (ambient = false) or ambient Jacobians.
  bool Evaluate(const double* host_pose, const double* target_pose, double inverse_depth,
                double* residuals, double* jacobian_host, double* jacobian_target,
                double* jacobian_inverse_depth, bool ambient) const;
  bool EvaluateGram(const double* host_pose, const double* target_pose, double inverse_depth,
                    double* residuals, Eigen::Matrix<double, 8, 8>* gram) const;
  int NumVisible(const double* host_pose, const double* target_pose, double inverse_depth) const;
  // How the warp stretches the patch: the singular values (largest first) of the 2 x 2
  // derivative of the target pixel with respect to the host pixel at the patch centre (1, 1 when
  // the target sees the patch at the host's scale; 2, 2 when it is twice as close). {0, 0} when
  // the centre is behind the target camera.
  Eigen::Vector2d WarpStretch(const double* host_pose, const double* target_pose,
                              double inverse_depth) const;
};

// Residual block of one point (hosted in h) into one target keyframe t. Parameter blocks:
// host pose (7, dfo_backend/pose_manifold.h), target pose (7), inverse depth (1). Residuals:
// C * K * K. Does not own the target level: it must outlive the cost (the window keeps it).
class FeatureMetricCost : public ceres::CostFunction {
 public:
  // target: the target keyframe's BA level (its camera is used to project);
  // host_camera: intrinsics of the host's BA level (to back-project); host_uv: integer pixel
  // of the patch centre in the host; patch_size: K (odd, >= 1); host_patch: SampleHostPatch of
  // the host at host_uv (shared by all blocks of the point), size target.channels * K * K.
  // depth_shape: null, or K * K factors d_k / d_0 (> 0) of each patch pixel's depth over the
  // centre's: pixel k is back-projected at depth d_k / d_0 / rho instead of 1 / rho, so that a
  // patch on a slanted surface (the road, a wall seen at a grazing angle) is warped as that
  // surface rather than as a fronto-parallel one (WindowOptions::patch_depth_shape).
  FeatureMetricCost(const FeatureLevel* target, const PinholeCamera& host_camera,
                    const Eigen::Vector2d& host_uv, int patch_size,
                    std::shared_ptr<const std::vector<double>> host_patch,
                    std::shared_ptr<const std::vector<double>> depth_shape = nullptr);

  // ceres::CostFunction: ambient Jacobians (J_tangent * PoseMinusJacobian for the poses).
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // Residuals and tangent-space Jacobians (row-major N x 6, N x 6, N x 1; any may be null).
  // Returns false when a value is not finite (e.g. NaN features or poses).
  bool EvaluateTangent(const double* host_pose, const double* target_pose, double inverse_depth,
                       double* residuals, double* jacobian_host, double* jacobian_target,
                       double* jacobian_inverse_depth) const;

  // Number of patch pixels whose projection lies inside the target at these parameters.
  int NumVisible(const double* host_pose, const double* target_pose, double inverse_depth) const {
    return block_.NumVisible(host_pose, target_pose, inverse_depth);
  }
  Eigen::Vector2d WarpStretch(const double* host_pose, const double* target_pose,
                              double inverse_depth) const {
    return block_.WarpStretch(host_pose, target_pose, inverse_depth);
  }

  // The 8 x 8 Gram matrix of the block's N x 8 matrix [A c r] (A: tangent host Jacobian N x 6,
  // c: inverse-depth Jacobian, r: residuals; the target Jacobian is -A) and the residuals
  // (size N). Returns false when a value is not finite. CompressedFeatureMetricCost uses it.
  bool EvaluateGram(const double* host_pose, const double* target_pose, double inverse_depth,
                    double* residuals, Eigen::Matrix<double, 8, 8>* gram) const {
    return block_.EvaluateGram(host_pose, target_pose, inverse_depth, residuals, gram);
  }

  int patch_size() const { return block_.patch_size; }
  int channels() const { return block_.target->channels; }
  const FeatureMetricBlock& block() const { return block_; }

 private:
  FeatureMetricBlock block_;
};

// The same block as a FeatureMetricCost, with its C x K x K residuals compressed to 7 without
// changing anything Ceres's trust-region solvers compute from it (used by the window's solves).
//
// The tangent Jacobian of a block is J = [A, -A, c] (host, target, inverse depth; N = C K^2
// rows). Levenberg-Marquardt uses a block only through its cost 1/2 rho(|r|^2), gradient
// rho' J^T r, Gauss-Newton matrix J^T J (and Jacobi scaling diag(J^T J)), model cost change
// (from J^T J, J^T r, |r|^2) and the robust-loss correction of Ceres's Corrector (which, for the
// normal equations, again only involves |r|^2, J^T r and J^T J). Any (r_c, J_c) with
//   |r_c|^2 = |r|^2,   J_c^T r_c = J^T r,   J_c^T J_c = J^T J
// is therefore the same block to the solver. [A c] has rank <= 6: for rho != 0, c is a
// combination of A's translation columns (each row's dp/drho = dp/dt_host . (t_h - t_t) / rho),
// and for rho = 0 those columns are zero. With G = [A c r]^T [A c r] (8 x 8) and its pivoted
// Cholesky factor over the 7 parameter columns, stopped after 6 pivots, G = L L^T with
// L = [L6 0; l^T e] (L6 7 x 6, l 6 values), take r_c = [l; e] and J_c = [R_A, -R_A, R_c; 0] with
// [R_A R_c] = L6^T (6 x 7) and a zero last row:
//   J_c^T J_c = lift of [A c]^T [A c] = J^T J,  J_c^T r_c = lift of L6 l = [A c]^T r = J^T r,
//   |r_c|^2 = |l|^2 + e^2 = r^T r
// (up to the round-off left in the seventh pivot, which the rank bound makes zero). A 27-row
// block (3 channels, K = 3) becomes 7 rows: Ceres's Jacobian, Schur elimination and scaling work
// shrink by 27/7. The pivots are taken largest remaining diagonal first, and the factorisation
// stops early where the remaining diagonal is below 1e-15 of the largest (rank-deficient
// blocks, e.g. rho = 0 or clamped pixels); with the pivot order P, [R_A R_c] = L6^T P^T. e is
// sqrt(|r|^2 - |l|^2), so |r_c|^2 = |r|^2 holds exactly. Its Jacobian is not
// the derivative of its residual (the implied orthogonal basis of [A c] moves with the
// parameters), so ceres::GradientChecker does not apply: the tests check the identities
// above against FeatureMetricCost. A residual-only evaluation returns [|r|, 0, ..., 0].
// Copies the block of `cost` (cost need not outlive it; its target level must).
//
// The last evaluation with Jacobians is kept (its parameters, |r|^2, the compressed residual and
// the factor): an evaluation at bitwise the same parameters copies it instead of recomputing.
// The window's second solve (after the outlier gate) starts where the first ended, and the gate
// needs every block's |r|^2 there, so the window keeps one such cost per block across both
// solves. The kept evaluation makes Evaluate write to the object: one cost must therefore not be
// shared by two residual blocks (Ceres evaluates a residual block from one thread at a time).
class CompressedFeatureMetricCost : public ceres::SizedCostFunction<7, 7, 7, 1> {
 public:
  explicit CompressedFeatureMetricCost(const FeatureMetricCost* cost);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // |r|^2 of the full residual (= |compressed residual|^2) from the last evaluation with
  // Jacobians, if that was at bitwise these parameters; false otherwise (*squared_norm
  // untouched).
  bool CachedSquaredNorm(const double* host_pose, const double* target_pose, double inverse_depth,
                         double* squared_norm) const;

  // Evaluates ahead of Ceres (WindowOptions::evaluation_threads: the window calls it for every
  // block from its own threads before each of Ceres's evaluations, one block on one thread at a
  // time): with_jacobians, the factor as an evaluation with Jacobians would; otherwise |r|^2
  // alone, as a residual-only evaluation would, kept apart from the factor. A later Evaluate at
  // bitwise these parameters copies the result, so the values Ceres sees are the same whether or
  // not (and from which thread) a block was prefetched.
  void Prefetch(const double* host_pose, const double* target_pose, double inverse_depth,
                bool with_jacobians) const;

  // Rows of the compressed residual.
  static constexpr int kNumResiduals = 7;

 private:
  struct Cache {
    bool valid = false;
    double parameters[15];  // host pose (7), target pose (7), inverse depth
    double squared_norm;    // |r|^2 of the full residual
    double residuals[7];    // the compressed residual
    double factor[6 * 7];   // [R_A R_c], row-major (see above)
  };
  // The last prefetched residual-only evaluation.
  struct NormCache {
    bool valid = false;
    double parameters[15];
    double squared_norm;
  };
  bool Hit(const double* host_pose, const double* target_pose, double inverse_depth) const;
  bool NormHit(const double* host_pose, const double* target_pose, double inverse_depth) const;
  // |r|^2 of the full residual; false when a value is not finite.
  bool FullSquaredNorm(const double* host_pose, const double* target_pose, double inverse_depth,
                       double* squared_norm) const;
  // Evaluates the Gram matrix, factorises it into cache_ and marks it valid; false (cache_
  // invalid) when a value is not finite.
  bool Factorize(const double* host_pose, const double* target_pose, double inverse_depth) const;

  FeatureMetricBlock block_;
  int num_full_residuals_;
  mutable Cache cache_;
  mutable NormCache norm_cache_;
};

}  // namespace dfo

#endif  // DFO_BACKEND_FEATURE_METRIC_COST_H_
