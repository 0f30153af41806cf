#include "dfo_backend/window_optimizer.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "dfo_backend/feature_metric_cost.h"
#include "dfo_backend/marginalization.h"
#include "dfo_backend/pose_manifold.h"
#include "dfo_core/error.h"
#include "dfo_core/parallel.h"
#include "dfo_core/timing.h"

namespace dfo {

namespace {

template <typename T>
void Require(bool ok, const std::string& key, const T& value, const std::string& rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << key << " = " << value << " violates " << rule;
  throw ConfigError(msg.str());
}

// Evaluates the compressed blocks of a solve before each of Ceres's evaluations, on up to
// `threads` threads taking chunks of blocks in turn (a thread that the frontend or the backend
// thread delays takes fewer), and each block is evaluated alone into its own cache
// (CompressedFeatureMetricCost::Prefetch), so what Ceres then reads does not depend on the
// number of threads or on who evaluated what. Ceres hands the callback the parameters in the
// solve's own buffers, the ones the blocks were added with.
class BlockPrefetch : public ceres::EvaluationCallback {
 public:
  struct Block {
    const CompressedFeatureMetricCost* cost;
    const double* host_pose;
    const double* target_pose;
    const double* inverse_depth;
  };

  explicit BlockPrefetch(int threads) : threads_(threads) {}
  void Add(const Block& block) { blocks_.push_back(block); }

  void PrepareForEvaluation(bool evaluate_jacobians, bool /*new_evaluation_point*/) override {
    const size_t n = blocks_.size();
    std::atomic<size_t> next{0};
    const auto run = [this, evaluate_jacobians, n, &next]() {
      // A block that fails here (or throws) is evaluated again by Ceres, which reports it.
      try {
        for (size_t begin = next.fetch_add(kChunk); begin < n; begin = next.fetch_add(kChunk)) {
          for (size_t i = begin; i < std::min(begin + kChunk, n); ++i) {
            const Block& b = blocks_[i];
            b.cost->Prefetch(b.host_pose, b.target_pose, *b.inverse_depth, evaluate_jacobians);
          }
        }
      } catch (...) {
      }
    };
    // Below a few hundred blocks a thread costs more than it saves.
    const size_t threads = std::min<size_t>(threads_, std::max<size_t>(n / kMinBlocksPerThread, 1));
    RunOnThreads(static_cast<int>(threads), [&run](int) { run(); });
  }

 private:
  static constexpr size_t kMinBlocksPerThread = 256;
  static constexpr size_t kChunk = 64;
  int threads_;
  std::vector<Block> blocks_;
};

// Index in WindowZoomLadder of the largest zoom not above `zoom`; -1 below the first.
int ZoomIndex(const std::vector<double>& zooms, double zoom) {
  int index = -1;
  for (size_t i = 0; i < zooms.size(); ++i) {
    if (zooms[i] <= zoom + 1e-9) index = static_cast<int>(i);
  }
  return index;
}

// The K x K factors d(x + dx, y + dy) / d(x, y) of a patch's depths over its centre's
// (FeatureMetricCost's depth shape), clamped to [1/2, 2]; 1 where a depth is not valid.
std::vector<double> PatchDepthShape(const ImageF& depth, int x, int y, int patch_size) {
  const int radius = patch_size / 2;
  std::vector<double> shape(static_cast<size_t>(patch_size) * patch_size, 1.0);
  const double d0 = depth(x, y);
  if (!(d0 > 0.0) || !std::isfinite(d0)) return shape;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const double d = depth(x + dx, y + dy);
      if (d > 0.0 && std::isfinite(d)) {
        shape[(dy + radius) * patch_size + (dx + radius)] = std::clamp(d / d0, 0.5, 2.0);
      }
    }
  }
  return shape;
}

// Prior r = sqrt(w) (rho - rho0) / rho0 on one inverse depth (D3VO-style depth prior, relative so
// that its weight does not depend on the scene's scale).
class InverseDepthPriorCost : public ceres::SizedCostFunction<1, 1> {
 public:
  InverseDepthPriorCost(double rho0, double weight)
      : rho0_(rho0), sqrt_w_over_rho0_(std::sqrt(weight) / rho0) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    residuals[0] = sqrt_w_over_rho0_ * (parameters[0][0] - rho0_);
    if (jacobians && jacobians[0]) jacobians[0][0] = sqrt_w_over_rho0_;
    return true;
  }

 private:
  double rho0_, sqrt_w_over_rho0_;
};

// The prior of a keyframe's point with the keyframe's log scale s free
// (WindowOptions::depth_prior_scale_fraction): r = sqrt(w) (log(rho / rho0) - s) on (rho, s). In
// logarithms, so that scaling the whole window (depths, translations, s) leaves it unchanged: in
// the relative form (rho - rho0 exp(s)) / rho0 the cost would shrink as the window grows.
class ScaledInverseDepthPriorCost : public ceres::SizedCostFunction<1, 1, 1> {
 public:
  ScaledInverseDepthPriorCost(double rho0, double weight)
      : log_rho0_(std::log(rho0)), sqrt_w_(std::sqrt(weight)) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double rho = parameters[0][0];
    if (!(rho > 0.0)) return false;
    residuals[0] = sqrt_w_ * (std::log(rho) - log_rho0_ - parameters[1][0]);
    if (jacobians && jacobians[0]) jacobians[0][0] = sqrt_w_ / rho;
    if (jacobians && jacobians[1]) jacobians[1][0] = -sqrt_w_;
    return true;
  }

 private:
  double log_rho0_, sqrt_w_;
};

// r = sqrt(W) s on a keyframe's log scale s.
class LogScalePriorCost : public ceres::SizedCostFunction<1, 1> {
 public:
  explicit LogScalePriorCost(double weight) : sqrt_w_(std::sqrt(weight)) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    residuals[0] = sqrt_w_ * parameters[0][0];
    if (jacobians && jacobians[0]) jacobians[0][0] = sqrt_w_;
    return true;
  }

 private:
  double sqrt_w_;
};

// Prior on the relative pose of two keyframes toward the frontend's measurement a_from_b:
// E = meas^-1 (T_a^-1 T_b), r = sqrt(w) [2 vec(q_E); t_E] (as Ceres's pose_graph_3d example).
struct RelativePosePrior {
  RelativePosePrior(const SE3d& a_from_b, double weight)
      : q_meas_inv(a_from_b.quaternion().conjugate()),
        t_meas(a_from_b.translation()),
        sqrt_w(std::sqrt(weight)) {}
  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* residuals) const {
    const Eigen::Quaternion<T> qa(pose_a[3], pose_a[0], pose_a[1], pose_a[2]);
    const Eigen::Quaternion<T> qb(pose_b[3], pose_b[0], pose_b[1], pose_b[2]);
    const Eigen::Matrix<T, 3, 1> ta(pose_a[4], pose_a[5], pose_a[6]);
    const Eigen::Matrix<T, 3, 1> tb(pose_b[4], pose_b[5], pose_b[6]);
    const Eigen::Quaternion<T> qa_inv = qa.conjugate();
    const Eigen::Quaternion<T> q_ab = qa_inv * qb;
    const Eigen::Matrix<T, 3, 1> t_ab = qa_inv * (tb - ta);
    const Eigen::Quaternion<T> q_err = q_meas_inv.template cast<T>() * q_ab;
    const Eigen::Matrix<T, 3, 1> t_err =
        q_meas_inv.template cast<T>() * (t_ab - t_meas.template cast<T>());
    const T s = T(sqrt_w);
    const T sign = q_err.w() < T(0) ? T(-1) : T(1);
    residuals[0] = s * T(2) * sign * q_err.x();
    residuals[1] = s * T(2) * sign * q_err.y();
    residuals[2] = s * T(2) * sign * q_err.z();
    residuals[3] = s * t_err.x();
    residuals[4] = s * t_err.y();
    residuals[5] = s * t_err.z();
    return true;
  }
  Eigen::Quaterniond q_meas_inv;
  Eigen::Vector3d t_meas;
  double sqrt_w;
};

// q-quantile (0 < q <= 1) of values (copied), nearest rank.
double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const size_t k = std::min(values.size() - 1,
                            static_cast<size_t>(std::ceil(q * values.size())) - (q > 0 ? 1 : 0));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

// WindowOptions::stop_step_px: ends a solve when its last accepted step moved the free
// keyframes' poses by less than the threshold in the image. Reads the parameter blocks, so the
// solver must run with update_state_every_iteration.
class SmallStepStop : public ceres::IterationCallback {
 public:
  SmallStepStop(const double* poses, size_t num_poses, const std::vector<double>& inverse_depths,
                double focal_px, double threshold_px)
      : poses_(poses),
        num_poses_(num_poses),
        inverse_depths_(inverse_depths),
        focal_px_(focal_px),
        threshold_px_(threshold_px),
        previous_(poses, poses + num_poses * kPoseAmbientSize) {}

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (summary.iteration == 0 || !summary.step_is_successful || num_poses_ == 0) {
      return ceres::SOLVER_CONTINUE;  // a rejected step left the state where it was
    }
    double mean_inverse_depth = 0.0;
    for (double d : inverse_depths_) mean_inverse_depth += d;
    if (!inverse_depths_.empty()) mean_inverse_depth /= static_cast<double>(inverse_depths_.size());
    double sum_squared = 0.0;
    for (size_t i = 0; i < num_poses_; ++i) {
      const double* now = poses_ + i * kPoseAmbientSize;
      const double* before = previous_.data() + i * kPoseAmbientSize;
      const SE3d step = PoseFromParameters(before).Inverse() * PoseFromParameters(now);
      const double px =
          focal_px_ * (step.so3().Angle() + step.translation().norm() * mean_inverse_depth);
      sum_squared += px * px;
    }
    last_step_px_ = std::sqrt(sum_squared / static_cast<double>(num_poses_));
    std::copy(poses_, poses_ + num_poses_ * kPoseAmbientSize, previous_.begin());
    return last_step_px_ < threshold_px_ ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
                                         : ceres::SOLVER_CONTINUE;
  }

  double last_step_px() const { return last_step_px_; }

 private:
  const double* poses_;
  size_t num_poses_;
  const std::vector<double>& inverse_depths_;
  double focal_px_;
  double threshold_px_;
  std::vector<double> previous_;
  double last_step_px_ = 0.0;
};

}  // namespace

std::vector<double> WindowZoomLadder(double max_stretch) {
  std::vector<double> zooms;
  for (int i = 1; 1.0 + 0.1 * i <= max_stretch + 1e-9 && i <= 30; ++i) {
    zooms.push_back(1.0 + 0.1 * i);
  }
  return zooms;
}

void WindowOptions::Check() const {
  Require(max_keyframes >= 5, "window.max_keyframes", max_keyframes, ">= 5");
  Require(pyramid_level >= 0, "window.pyramid_level", pyramid_level, ">= 0");
  Require(patch_size >= 1 && patch_size <= 9 && patch_size % 2 == 1, "window.patch_size",
          patch_size, "odd and in [1, 9]");
  Require(std::isfinite(max_patch_stretch) && max_patch_stretch > 1.0, "window.max_patch_stretch",
          max_patch_stretch, "> 1");
  Require(std::isfinite(max_depth_edge_slope) && max_depth_edge_slope >= 0.0,
          "window.max_depth_edge_slope", max_depth_edge_slope, ">= 0");
  Require(points_per_keyframe >= 1 && points_per_keyframe <= 100000, "window.points_per_keyframe",
          points_per_keyframe, "in [1, 100000]");
  Require(loss == "huber" || loss == "cauchy", "window.loss", loss, "one of {huber, cauchy}");
  Require(coarse_iterations >= 0, "window.coarse_iterations", coarse_iterations, ">= 0");
  Require(std::isfinite(loss_scale) && loss_scale > 0.0, "window.loss_scale", loss_scale, "> 0");
  Require(linear_solver == "sparse_schur" || linear_solver == "dense_schur", "window.linear_solver",
          linear_solver, "one of {sparse_schur, dense_schur}");
  Require(max_iterations >= 1, "window.max_iterations", max_iterations, ">= 1");
  Require(std::isfinite(stop_step_px) && stop_step_px >= 0.0, "window.stop_step_px", stop_step_px,
          ">= 0");
  Require(std::isfinite(max_solver_time_s) && max_solver_time_s > 0.0, "window.max_solver_time_s",
          max_solver_time_s, "> 0");
  Require(num_threads >= 1, "window.num_threads", num_threads, ">= 1");
  Require(evaluation_threads >= 1 && evaluation_threads <= 1024, "window.evaluation_threads",
          evaluation_threads, "in [1, 1024]");
  Require(std::isfinite(min_inverse_depth) && min_inverse_depth >= 0.0, "window.min_inverse_depth",
          min_inverse_depth, ">= 0");
  Require(std::isfinite(depth_prior_weight) && depth_prior_weight >= 0.0,
          "window.depth_prior_weight", depth_prior_weight, ">= 0");
  Require(std::isfinite(pose_prior_weight) && pose_prior_weight >= 0.0, "window.pose_prior_weight",
          pose_prior_weight, ">= 0");
  Require(outlier_gate_percentile > 0.0 && outlier_gate_percentile <= 1.0,
          "window.outlier_gate_percentile", outlier_gate_percentile, "in (0, 1]");
  Require(std::isfinite(outlier_gate_factor) && outlier_gate_factor >= 1.0,
          "window.outlier_gate_factor", outlier_gate_factor, ">= 1");
  Require(min_point_fraction >= 0.0 && min_point_fraction <= 1.0, "window.min_point_fraction",
          min_point_fraction, "in [0, 1]");
  Require(min_marginalized_observations >= 1, "window.min_marginalized_observations",
          min_marginalized_observations, ">= 1");
  Require(
      std::isfinite(depth_search_range) && depth_search_range >= 1.0 && depth_search_range <= 10.0,
      "window.depth_search_range", depth_search_range, "in [1, 10]");
  Require(std::isfinite(depth_search_uniqueness) && depth_search_uniqueness >= 1.0,
          "window.depth_search_uniqueness", depth_search_uniqueness, ">= 1");
  Require(!searched_points_only || depth_search_range > 1.0, "window.searched_points_only",
          std::string("true"), "false when window.depth_search_range is 1 (no search)");
  Require(prior_weight > 0.0 && prior_weight <= 1.0, "backend.prior_weight", prior_weight,
          "in (0, 1]");
  Require(relative_eigenvalue_floor > 0.0 && relative_eigenvalue_floor < 1.0,
          "backend.relative_eigenvalue_floor", relative_eigenvalue_floor, "in (0, 1)");
  Require(
      std::isfinite(zoom_blur_sigma_px) && zoom_blur_sigma_px >= 0.0 && zoom_blur_sigma_px <= 10.0,
      "window.zoom_blur_sigma_px", zoom_blur_sigma_px, "in [0, 10]");
  Require(depth_prior_scale_fraction >= 0.0 && depth_prior_scale_fraction <= 1.0,
          "window.depth_prior_scale_fraction", depth_prior_scale_fraction, "in [0, 1]");
  Require(prior_scale_memory >= 0.0 && prior_scale_memory <= 1.0, "backend.prior_scale_memory",
          prior_scale_memory, "in [0, 1]");
}

struct WindowOptimizer::KeyframeState {
  int id = 0;
  int frame_index = 0;
  int64_t timestamp_ns = 0;
  double pose[kPoseAmbientSize];     // world_from_cam, pose_manifold.h layout
  SE3d frontend_pose;                // chained frontend measurement (relative pose prior)
  FeatureLevel level;                // features at the BA level
  FeatureLevel coarse;               // features at the BA level + 1 (coarse_iterations > 0)
  ImageF depth;                      // depth at the BA level (m, 0 invalid)
  double initial_depth_scale = 1.0;  // KeyframeData::initial_depth_scale
  double prior_depth_scale = 1.0;    // KeyframeData::prior_depth_scale
  int num_selected = 0;              // points selected when it entered
  // s_k of WindowOptions::depth_prior_scale_fraction: its points' prior inverse depths are
  // prior_inverse_depth * exp(log_prior_scale) (0 when the fraction is 1).
  double log_prior_scale = 0.0;
  // WindowOptions::zoom_blur_sigma_px: `level` blurred for the zooms of zoom_ladder_ (the same
  // index); empty when off.
  std::vector<FeatureLevel> zoom_blurred;
};

// One residual block: the cost (marginalisation, the gate's fallback, tests) and, for blocks of
// more than 7 rows, the compressed form the solves use. The compressed cost lives as long as the
// block, so that what it kept from the first solve's last evaluation serves the outlier gate and
// the second solve's first evaluation (feature_metric_cost.h).
struct WindowOptimizer::Block {
  std::unique_ptr<FeatureMetricCost> cost;
  std::unique_ptr<CompressedFeatureMetricCost> compressed;  // null: the cost has <= 7 rows
};

struct WindowOptimizer::PointState {
  int host_id = 0;
  int x = 0, y = 0;  // pixel at the BA level
  double inverse_depth = 0.0;
  double prior_inverse_depth = 0.0;  // from the keyframe's depth
  double start_inverse_depth = 0.0;  // where it entered the window
  // The depth search's (WindowOptions::depth_search_range) inverse-depth interval: rho0 / range
  // .. rho0 * range at first; a candidate's (WindowOptions::searched_points_only) is narrowed by
  // each search that found it ambiguous.
  double search_lo = 0.0, search_hi = 0.0;
  std::shared_ptr<const std::vector<double>> patch;
  // FeatureMetricCost's depth shape (WindowOptions::patch_depth_shape); null: fronto-parallel.
  std::shared_ptr<const std::vector<double>> depth_shape;
  // Host patch on the coarse level, centred where (x, y) lands there; null when coarse solves are
  // off or the patch leaves the coarse level (the point then sits the warm-up out).
  std::shared_ptr<const std::vector<double>> coarse_patch;
  // The blocks of the point, by target keyframe id.
  std::map<int, Block> residuals;
};

WindowOptimizer::WindowOptimizer(const WindowOptions& options) : options_(options) {
  options_.Check();
  manifold_ = std::make_unique<SE3Manifold>();
  scaled_depth_prior_ =
      options_.depth_prior_weight > 0.0 && options_.depth_prior_scale_fraction < 1.0;
  if (options_.zoom_blur_sigma_px > 0.0)
    zoom_ladder_ = WindowZoomLadder(options_.max_patch_stretch);
}

WindowOptimizer::~WindowOptimizer() = default;

int WindowOptimizer::num_keyframes() const { return static_cast<int>(keyframes_.size()); }
int WindowOptimizer::num_points() const { return static_cast<int>(points_.size()); }
int WindowOptimizer::num_residual_blocks() const {
  int n = 0;
  for (const auto& p : points_) n += static_cast<int>(p->residuals.size());
  return n;
}

std::vector<std::pair<int, SE3d>> WindowOptimizer::KeyframePoses() const {
  std::vector<std::pair<int, SE3d>> out;
  for (const auto& kf : keyframes_) out.emplace_back(kf->frame_index, PoseFromParameters(kf->pose));
  return out;
}

const LinearPriorCost* WindowOptimizer::prior() const { return prior_.get(); }

std::vector<int> WindowOptimizer::PriorFrameIndices() const {
  std::vector<int> out;
  for (int id : prior_keyframe_ids_) out.push_back(FindKeyframe(id)->frame_index);
  return out;
}

std::vector<WindowOptimizer::PointInfo> WindowOptimizer::Points() const {
  std::vector<PointInfo> out;
  for (const auto& p : points_) {
    out.push_back({FindKeyframe(p->host_id)->frame_index, p->x, p->y, p->inverse_depth});
  }
  return out;
}

std::vector<SettledPoint> WindowOptimizer::HostedPoints(int frame_index) const {
  std::vector<SettledPoint> out;
  const KeyframeState* host = nullptr;
  for (const auto& kf : keyframes_) {
    if (kf->frame_index == frame_index) host = kf.get();
  }
  if (host == nullptr) return out;
  const double to_level0 = std::ldexp(1.0, options_.pyramid_level);
  std::vector<double> scratch;
  for (const auto& p : points_) {
    if (p->host_id != host->id || p->residuals.empty()) continue;
    if (!(p->inverse_depth > 0.0) || !std::isfinite(p->inverse_depth)) continue;
    SettledPoint s;
    s.u = (p->x + 0.5) * to_level0 - 0.5;
    s.v = (p->y + 0.5) * to_level0 - 0.5;
    s.depth_m = 1.0 / p->inverse_depth;
    s.start_depth_m = 1.0 / p->start_inverse_depth;
    s.observations = static_cast<int>(p->residuals.size());
    double sq = 0.0;
    size_t rows = 0;
    for (const auto& [target_id, block] : p->residuals) {
      sq += BlockSquaredNorm(*p, target_id, block, &scratch);
      rows += static_cast<size_t>(block.cost->num_residuals());
    }
    s.rms_residual = rows > 0 ? std::sqrt(sq / static_cast<double>(rows)) : 0.0;
    out.push_back(s);
  }
  return out;
}

std::vector<Eigen::Vector3d> WindowOptimizer::PointsInKeyframe(int frame_index) const {
  for (const auto& kf : keyframes_) {
    if (kf->frame_index == frame_index) return PointsInCamera(PoseFromParameters(kf->pose));
  }
  return {};
}

std::vector<Eigen::Vector3d> WindowOptimizer::PointsInCamera(const SE3d& world_from_cam) const {
  std::vector<Eigen::Vector3d> out;
  const SE3d cam_from_world = world_from_cam.Inverse();
  out.reserve(points_.size());
  for (const auto& p : points_) {
    if (p->residuals.empty() && keyframes_.size() > 1) continue;
    if (!(p->inverse_depth > 0.0) || !std::isfinite(p->inverse_depth)) continue;
    const KeyframeState* host = FindKeyframe(p->host_id);
    const Eigen::Vector3d in_host =
        host->level.camera.Unproject(Eigen::Vector2d(p->x, p->y), 1.0 / p->inverse_depth);
    const Eigen::Vector3d in_cam = cam_from_world * (PoseFromParameters(host->pose) * in_host);
    if (in_cam.z() > 0.0 && in_cam.allFinite()) out.push_back(in_cam);
  }
  return out;
}

WindowOptimizer::KeyframeState* WindowOptimizer::FindKeyframe(int id) const {
  for (const auto& kf : keyframes_) {
    if (kf->id == id) return kf.get();
  }
  DFO_CHECK(false) << "keyframe id " << id << " not in the window";
  return nullptr;
}

// Point selection: the level is divided into square cells (about two per wanted point); in each
// cell the pixel with the largest squared feature gradient (summed over channels, central
// differences) among the allowed ones (mask, valid depth, patch inside) is a candidate; the
// strongest candidates are kept. Spreads points over the image as DSO's block-wise selection.
namespace {

// Where pixel (x, y) of a level lands on the next coarser one (2 x 2 averaging: DESIGN of
// PinholeCamera::PyramidLevel).
Eigen::Vector2d CoarsePixel(int x, int y) { return {(x + 0.5) * 0.5 - 0.5, (y + 0.5) * 0.5 - 0.5}; }

}  // namespace

double WindowOptimizer::SelectPoints(KeyframeState* kf) {
  const FeatureLevel& f = kf->level;
  const int w = f.width, h = f.height;
  const int border = options_.patch_size / 2 + 1;
  const double edge_ratio = options_.max_depth_edge_slope > 0.0
                                ? 1.0 + options_.max_depth_edge_slope * 2.0 / f.camera.fx
                                : 0.0;
  int num_with_depth = 0, num_on_edge = 0;
  const double cell =
      std::max(2.0, std::sqrt(static_cast<double>(w) * h / (2.0 * options_.points_per_keyframe)));
  const int cells_x = std::max(1, static_cast<int>(std::ceil(w / cell)));
  const int cells_y = std::max(1, static_cast<int>(std::ceil(h / cell)));
  struct Candidate {
    double score;
    int x, y;
  };
  std::vector<Candidate> best(static_cast<size_t>(cells_x) * cells_y, Candidate{-1.0, 0, 0});
  const size_t plane = static_cast<size_t>(w) * h;
  for (int y = border; y < h - border; ++y) {
    for (int x = border; x < w - border; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (f.has_mask() && f.mask[i] == 0) continue;
      const float d = kf->depth(x, y);
      if (!(std::isfinite(d) && d > 0.0f)) continue;
      ++num_with_depth;
      // Next to a hole counts as an edge too (DepthSpread is then infinite).
      if (edge_ratio > 0.0 && DepthSpread(kf->depth, x, y, 1) > edge_ratio) {
        ++num_on_edge;
        continue;
      }
      double score = 0.0;
      for (int c = 0; c < f.channels; ++c) {
        const float* v = f.data.data() + c * plane;
        const double gx = 0.5 * (v[i + 1] - v[i - 1]);
        const double gy = 0.5 * (v[i + w] - v[i - w]);
        score += gx * gx + gy * gy;
      }
      if (!std::isfinite(score)) continue;
      const int cx = std::min(cells_x - 1, static_cast<int>(x / cell));
      const int cy = std::min(cells_y - 1, static_cast<int>(y / cell));
      Candidate& b = best[static_cast<size_t>(cy) * cells_x + cx];
      if (score > b.score) b = Candidate{score, x, y};
    }
  }
  std::vector<Candidate> chosen;
  for (const Candidate& c : best) {
    if (c.score > 0.0) chosen.push_back(c);
  }
  std::sort(chosen.begin(), chosen.end(), [](const Candidate& a, const Candidate& b) {
    return a.score != b.score ? a.score > b.score : (a.y != b.y ? a.y < b.y : a.x < b.x);
  });
  if (static_cast<int>(chosen.size()) > options_.points_per_keyframe) {
    chosen.resize(options_.points_per_keyframe);
  }
  for (const Candidate& c : chosen) {
    auto p = std::make_unique<PointState>();
    p->host_id = kf->id;
    p->x = c.x;
    p->y = c.y;
    p->prior_inverse_depth =
        std::max(1.0 / (kf->depth(c.x, c.y) * kf->prior_depth_scale), options_.min_inverse_depth);
    p->inverse_depth =
        std::max(1.0 / (kf->depth(c.x, c.y) * kf->initial_depth_scale), options_.min_inverse_depth);
    p->start_inverse_depth = p->inverse_depth;
    p->search_lo =
        std::max(p->inverse_depth / options_.depth_search_range, options_.min_inverse_depth);
    p->search_hi = p->inverse_depth * options_.depth_search_range;
    p->patch = std::make_shared<const std::vector<double>>(
        SampleHostPatch(f, c.x, c.y, options_.patch_size));
    if (options_.patch_depth_shape) {
      p->depth_shape = std::make_shared<const std::vector<double>>(
          PatchDepthShape(kf->depth, c.x, c.y, options_.patch_size));
    }
    if (options_.coarse_iterations > 0) {
      std::vector<double> coarse_patch;
      if (SampleHostPatchBilinear(kf->coarse, CoarsePixel(c.x, c.y), options_.patch_size,
                                  &coarse_patch)) {
        p->coarse_patch = std::make_shared<const std::vector<double>>(std::move(coarse_patch));
      }
    }
    (options_.searched_points_only ? candidates_ : points_).push_back(std::move(p));
  }
  kf->num_selected = static_cast<int>(chosen.size());
  return num_with_depth > 0 ? static_cast<double>(num_on_edge) / num_with_depth : 0.0;
}

// A block from point p into `target` when its patch is visible there, at p's current inverse
// depth, at a similar scale (max_patch_stretch).
void WindowOptimizer::ConnectPoint(PointState* p, KeyframeState* target) {
  const int full = options_.patch_size * options_.patch_size;
  const double max_stretch = options_.max_patch_stretch;
  KeyframeState* host = FindKeyframe(p->host_id);
  const Eigen::Vector2d uv(p->x, p->y);
  auto cost = std::make_unique<FeatureMetricCost>(&target->level, host->level.camera, uv,
                                                  options_.patch_size, p->patch, p->depth_shape);
  const Eigen::Vector2d stretch = cost->WarpStretch(host->pose, target->pose, p->inverse_depth);
  if (!(stretch(0) <= max_stretch && stretch(1) >= 1.0 / max_stretch)) return;
  // How much larger the target sees the patch than the host.
  const double zoom = std::sqrt(stretch(0) * stretch(1));
  const FeatureLevel* target_level = &target->level;
  std::shared_ptr<const std::vector<double>> patch = p->patch;
  if (!zoom_ladder_.empty()) {
    // The same surface blur on both sides: the zoomed-in side's features blurred more.
    const int t = ZoomIndex(zoom_ladder_, zoom), h = ZoomIndex(zoom_ladder_, 1.0 / zoom);
    if (t >= 0) target_level = &target->zoom_blurred[t];
    if (h >= 0) {
      patch = std::make_shared<const std::vector<double>>(
          SampleHostPatch(host->zoom_blurred[h], p->x, p->y, options_.patch_size));
    }
  }
  if (options_.zoom_scaled_gradients) {
    // The same gradient steepness on the surface: the target sees gradients 1 / zoom as steep.
    if (auto scaled =
            ZoomScaledPatch(*patch, host->level.derivative_order, options_.patch_size, zoom)) {
      patch = std::move(scaled);
    }
  }
  if (target_level != &target->level || patch != p->patch) {
    cost = std::make_unique<FeatureMetricCost>(target_level, host->level.camera, uv,
                                               options_.patch_size, patch, p->depth_shape);
  }
  if (cost->NumVisible(host->pose, target->pose, p->inverse_depth) == full) {
    Block& block = p->residuals[target->id];
    if (cost->num_residuals() > CompressedFeatureMetricCost::kNumResiduals) {
      block.compressed = std::make_unique<CompressedFeatureMetricCost>(cost.get());
    }
    block.cost = std::move(cost);
  }
}

void WindowOptimizer::ConnectToOtherKeyframes(PointState* p) {
  for (auto& target : keyframes_) {
    if (target->id != p->host_id) ConnectPoint(p, target.get());
  }
}

// Blocks for every (point, target) pair that involves the new keyframe and is visible.
void WindowOptimizer::ConnectNewKeyframe(KeyframeState* new_kf) {
  for (auto& p : points_) {
    if (p->host_id == new_kf->id) {
      ConnectToOtherKeyframes(p.get());
    } else {
      ConnectPoint(p.get(), new_kf);
    }
  }
  RemovePointsWithoutResiduals();
}

void WindowOptimizer::ActivateCandidates(WindowResult* result) {
  std::vector<std::unique_ptr<PointState>> waiting;
  for (auto& c : candidates_) {
    // Blocks into every other keyframe at the candidate's starting depth; the search then moves
    // along the epipolar lines of those targets.
    c->residuals.clear();
    c->inverse_depth = 0.5 * (c->search_lo + c->search_hi);
    ConnectToOtherKeyframes(c.get());
    if (!c->residuals.empty() && SearchPointDepth(c.get(), result)) {
      c->start_inverse_depth = c->inverse_depth;
      points_.push_back(std::move(c));
      ++result->num_depth_found;
    } else {
      c->residuals.clear();
      waiting.push_back(std::move(c));
    }
  }
  candidates_ = std::move(waiting);
}

void WindowOptimizer::SearchNewPointDepths(const KeyframeState* new_kf, WindowResult* result) {
  for (auto& p : points_) {
    if (p->host_id != new_kf->id || p->residuals.empty()) continue;
    if (SearchPointDepth(p.get(), result)) ++result->num_depth_found;
  }
}

bool WindowOptimizer::SearchPointDepth(PointState* p, WindowResult* result) {
  constexpr int kMaxSteps = 200;
  const KeyframeState* host = FindKeyframe(p->host_id);
  std::vector<double> residuals;
  const double lo = p->search_lo, hi = p->search_hi;
  if (!(hi > lo)) return false;
  // Length in pixels of the epipolar segment [lo, hi] in the target where it is longest.
  const Eigen::Vector3d ray = host->level.camera.Unproject(Eigen::Vector2d(p->x, p->y), 1.0);
  const SE3d world_from_host = PoseFromParameters(host->pose);
  double length = 0.0;
  for (const auto& [target_id, block] : p->residuals) {
    const KeyframeState* target = FindKeyframe(target_id);
    const SE3d target_from_host = PoseFromParameters(target->pose).Inverse() * world_from_host;
    const Eigen::Vector3d a = target_from_host * Eigen::Vector3d(ray / lo);
    const Eigen::Vector3d b = target_from_host * Eigen::Vector3d(ray / hi);
    if (!(a.z() > 0.0) || !(b.z() > 0.0)) continue;
    length = std::max(length,
                      (target->level.camera.Project(a) - target->level.camera.Project(b)).norm());
  }
  if (!(length >= 2.0)) return false;  // too little parallax to tell depths apart
  ++result->num_depth_searched;
  const int steps = std::min(kMaxSteps, static_cast<int>(std::ceil(length)) + 1);
  std::vector<double> energy(steps, 0.0);
  bool finite = true;
  for (int i = 0; i < steps && finite; ++i) {
    const double rho = lo + (hi - lo) * i / (steps - 1);
    for (const auto& [target_id, block] : p->residuals) {
      const FeatureMetricCost& cost = *block.cost;
      residuals.resize(cost.num_residuals());
      if (!cost.EvaluateTangent(host->pose, FindKeyframe(target_id)->pose, rho, residuals.data(),
                                nullptr, nullptr, nullptr)) {
        finite = false;
        break;
      }
      double squared = 0.0;
      for (double r : residuals) squared += r * r;
      double robust[3];
      loss_->Evaluate(squared, robust);
      energy[i] += robust[0];
    }
  }
  if (!finite) return false;
  const int best =
      static_cast<int>(std::min_element(energy.begin(), energy.end()) - energy.begin());
  double second = std::numeric_limits<double>::infinity();
  for (int i = 0; i < steps; ++i) {
    if (std::abs(i - best) <= 2) continue;
    const bool local_min =
        (i == 0 || energy[i] <= energy[i - 1]) && (i == steps - 1 || energy[i] <= energy[i + 1]);
    if (local_min) second = std::min(second, energy[i]);
  }
  if (!(second >= options_.depth_search_uniqueness * energy[best])) {
    // Ambiguous: the interval shrinks to the span of the local minima that compete with the best
    // (one step of margin), so that a later keyframe, with another baseline, decides among them.
    int first = best, last = best;
    for (int i = 0; i < steps; ++i) {
      const bool local_min =
          (i == 0 || energy[i] <= energy[i - 1]) && (i == steps - 1 || energy[i] <= energy[i + 1]);
      if (local_min && energy[i] < options_.depth_search_uniqueness * energy[best]) {
        first = std::min(first, i);
        last = std::max(last, i);
      }
    }
    p->search_lo = lo + (hi - lo) * std::max(0, first - 1) / (steps - 1);
    p->search_hi = lo + (hi - lo) * std::min(steps - 1, last + 1) / (steps - 1);
    return false;
  }
  // Sub-step minimum of the parabola through the best sample and its neighbours.
  double offset = 0.0;
  if (best > 0 && best < steps - 1) {
    const double a = energy[best - 1], b = energy[best], c = energy[best + 1];
    const double curvature = a - 2.0 * b + c;
    if (curvature > 0.0) offset = std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5);
  }
  p->inverse_depth = lo + (hi - lo) * (best + offset) / (steps - 1);
  return true;
}

void WindowOptimizer::RemovePointsWithoutResiduals() {
  // The newest keyframe's points may wait for later keyframes only if the window has just one
  // keyframe; otherwise a point without blocks carries no information.
  if (keyframes_.size() < 2) return;
  points_.erase(
      std::remove_if(points_.begin(), points_.end(),
                     [](const std::unique_ptr<PointState>& p) { return p->residuals.empty(); }),
      points_.end());
}

bool WindowOptimizer::Solve(int max_iterations, double* initial_cost, double* final_cost,
                            std::string* why, bool coarse, WindowResult* result) {
  // Ceres solves on copies laid out contiguously in window order (poses oldest first, then the
  // inverse depths in point order), copied back only when the solve succeeded. Ceres's
  // ParameterBlockOrdering keeps each elimination group as a set of addresses, so the order in
  // which the Schur complement is accumulated follows the blocks' addresses; with the state in
  // heap-allocated KeyframeState/PointState objects that order changed with the allocator's
  // history and a second run in the same process gave different trajectories. Here address
  // order is insertion order.
  const size_t num_kf = keyframes_.size();
  std::vector<double> pose_buffer(num_kf * kPoseAmbientSize);
  std::map<int, double*> pose_of;  // keyframe id -> its block in pose_buffer
  for (size_t i = 0; i < num_kf; ++i) {
    double* block = pose_buffer.data() + i * kPoseAmbientSize;
    std::copy(keyframes_[i]->pose, keyframes_[i]->pose + kPoseAmbientSize, block);
    pose_of[keyframes_[i]->id] = block;
  }
  std::vector<double> depth_buffer(points_.size());
  for (size_t i = 0; i < points_.size(); ++i) depth_buffer[i] = points_[i]->inverse_depth;
  // Keyframe log scales of the depth prior (depth_prior_scale_fraction < 1), added to the
  // problem with the first point that uses them.
  std::vector<double> scale_buffer(num_kf);
  std::map<int, size_t> position_of;  // keyframe id -> position in the window
  for (size_t i = 0; i < num_kf; ++i) {
    scale_buffer[i] = keyframes_[i]->log_prior_scale;
    position_of[keyframes_[i]->id] = i;
  }
  std::vector<int> prior_points(num_kf, 0);

  std::vector<std::unique_ptr<ceres::CostFunction>> owned_costs;
  std::unique_ptr<ceres::LossFunction> prior_loss;
  BlockPrefetch prefetch(options_.evaluation_threads);
  ceres::Problem::Options problem_options;
  if (options_.evaluation_threads > 1) problem_options.evaluation_callback = &prefetch;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  for (size_t i = 0; i < num_kf; ++i) {
    double* block = pose_buffer.data() + i * kPoseAmbientSize;
    problem.AddParameterBlock(block, kPoseAmbientSize, manifold_.get());
    ordering->AddElementToGroup(block, 1);
  }
  problem.SetParameterBlockConstant(pose_buffer.data());  // gauge: the oldest keyframe
  // The coarse warm-up only brings the newest keyframe (and the points it hosts) into the basin
  // of the fine solve: the rest of the window is converged already, and letting the coarse
  // level's biased optimum move it every keyframe makes the window drift (measured).
  if (coarse) {
    for (size_t i = 1; i + 1 < num_kf; ++i) {
      problem.SetParameterBlockConstant(pose_buffer.data() + i * kPoseAmbientSize);
    }
  }
  int num_blocks = 0;
  for (size_t i = 0; i < points_.size(); ++i) {
    PointState* p = points_[i].get();
    if (p->residuals.empty() || (coarse && p->coarse_patch == nullptr)) continue;
    double* depth = &depth_buffer[i];
    for (auto& [target_id, block] : p->residuals) {
      FeatureMetricCost* full_cost = block.cost.get();
      // The solver sees each block through its 7-row compression (feature_metric_cost.h: the
      // same cost, gradient and normal equations, 27/7 less work for a 27-row block).
      ceres::CostFunction* block_cost =
          block.compressed ? static_cast<ceres::CostFunction*>(block.compressed.get()) : full_cost;
      if (coarse) {
        const KeyframeState* host = FindKeyframe(p->host_id);
        auto coarse_cost = std::make_unique<FeatureMetricCost>(
            &FindKeyframe(target_id)->coarse, host->coarse.camera, CoarsePixel(p->x, p->y),
            options_.patch_size, p->coarse_patch);
        block_cost = coarse_cost.get();
        if (coarse_cost->num_residuals() > CompressedFeatureMetricCost::kNumResiduals) {
          owned_costs.push_back(std::make_unique<CompressedFeatureMetricCost>(coarse_cost.get()));
          block_cost = owned_costs.back().get();
        }
        owned_costs.push_back(std::move(coarse_cost));
      }
      problem.AddResidualBlock(block_cost, loss_.get(), pose_of.at(p->host_id),
                               pose_of.at(target_id), depth);
      if (const auto* compressed = dynamic_cast<const CompressedFeatureMetricCost*>(block_cost)) {
        prefetch.Add({compressed, pose_of.at(p->host_id), pose_of.at(target_id), depth});
      }
      ++num_blocks;
    }
    ordering->AddElementToGroup(depth, 0);
    if (coarse && p->host_id != keyframes_.back()->id) problem.SetParameterBlockConstant(depth);
    if (scaled_depth_prior_) {
      const size_t k = position_of.at(p->host_id);
      owned_costs.push_back(std::make_unique<ScaledInverseDepthPriorCost>(
          p->prior_inverse_depth, options_.depth_prior_weight));
      problem.AddResidualBlock(owned_costs.back().get(), nullptr, depth, &scale_buffer[k]);
      if (prior_points[k]++ == 0) {
        ordering->AddElementToGroup(&scale_buffer[k], 1);
        if (coarse && k + 1 < num_kf) problem.SetParameterBlockConstant(&scale_buffer[k]);
      }
    } else if (options_.depth_prior_weight > 0.0) {
      owned_costs.push_back(std::make_unique<InverseDepthPriorCost>(p->prior_inverse_depth,
                                                                    options_.depth_prior_weight));
      problem.AddResidualBlock(owned_costs.back().get(), nullptr, depth);
    }
  }
  if (scaled_depth_prior_ && options_.depth_prior_scale_fraction > 0.0) {
    const double f = options_.depth_prior_scale_fraction;
    for (size_t k = 0; k < num_kf; ++k) {
      if (prior_points[k] == 0) continue;
      owned_costs.push_back(std::make_unique<LogScalePriorCost>(
          f / (1.0 - f) * options_.depth_prior_weight * prior_points[k]));
      problem.AddResidualBlock(owned_costs.back().get(), nullptr, &scale_buffer[k]);
    }
  }
  if (num_blocks == 0) {
    *why = "no residual blocks (no points visible in two keyframes)";
    return false;
  }
  if (options_.pose_prior_weight > 0.0) {
    for (size_t i = 1; i < keyframes_.size(); ++i) {
      const SE3d a_from_b =
          keyframes_[i - 1]->frontend_pose.Inverse() * keyframes_[i]->frontend_pose;
      owned_costs.push_back(
          std::make_unique<ceres::AutoDiffCostFunction<RelativePosePrior, 6, 7, 7>>(
              new RelativePosePrior(a_from_b, options_.pose_prior_weight)));
      problem.AddResidualBlock(owned_costs.back().get(), nullptr, pose_of.at(keyframes_[i - 1]->id),
                               pose_of.at(keyframes_[i]->id));
    }
  }
  if (prior_) {
    prior_loss = std::make_unique<ceres::ScaledLoss>(nullptr, options_.prior_weight,
                                                     ceres::DO_NOT_TAKE_OWNERSHIP);
    std::vector<double*> blocks;
    for (int id : prior_keyframe_ids_) blocks.push_back(pose_of.at(id));
    problem.AddResidualBlock(prior_.get(), prior_loss.get(), blocks);
  }

  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type =
      options_.linear_solver == "dense_schur" ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver_options.linear_solver_ordering = ordering;
  solver_options.max_num_iterations = max_iterations;
  solver_options.max_solver_time_in_seconds = options_.max_solver_time_s;
  solver_options.num_threads = options_.num_threads;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  // The oldest keyframe is the gauge; in the coarse warm-up only the newest one moves.
  const size_t first_free = coarse ? std::max<size_t>(1, num_kf - 1) : 1;
  const double focal_px =
      coarse ? keyframes_.back()->coarse.camera.fx : keyframes_.back()->level.camera.fx;
  SmallStepStop small_step(pose_buffer.data() + first_free * kPoseAmbientSize,
                           num_kf - std::min(num_kf, first_free), depth_buffer, focal_px,
                           options_.stop_step_px);
  if (options_.stop_step_px > 0.0) {
    solver_options.update_state_every_iteration = true;  // the callback reads the state
    solver_options.callbacks.push_back(&small_step);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  *initial_cost = summary.initial_cost;
  *final_cost = summary.final_cost;
  if (result != nullptr) {
    // Ceres counts the evaluation at the start as iteration 0.
    result->num_iterations += std::max(0, static_cast<int>(summary.iterations.size()) - 1);
    if (summary.termination_type != ceres::CONVERGENCE &&
        summary.termination_type != ceres::USER_SUCCESS) {
      result->converged = false;
    }
    // Ceres ends a solve with NO_CONVERGENCE at its iteration cap or at its time limit; short of
    // the cap it was the time.
    if (summary.termination_type == ceres::NO_CONVERGENCE &&
        static_cast<int>(summary.iterations.size()) - 1 < solver_options.max_num_iterations) {
      result->time_limited = true;
    }
    result->last_step_px = small_step.last_step_px();
  }
  // The inverse-depth lower bound is enforced by projection after the solve (as DSO clamps its
  // inverse depths), not by Ceres's bound constraints: with bounds, every LM step becomes a
  // projected line search with extra Jacobian evaluations (measured: 5 evaluations for 2
  // iterations instead of 2-3), which doubles the cost of a window solve.
  for (double& d : depth_buffer) d = std::max(d, options_.min_inverse_depth);
  bool state_finite = true;
  for (double v : pose_buffer) state_finite = state_finite && std::isfinite(v);
  for (double v : depth_buffer) state_finite = state_finite && std::isfinite(v);
  for (double v : scale_buffer) state_finite = state_finite && std::isfinite(v);
  if (summary.termination_type == ceres::FAILURE || !summary.IsSolutionUsable() ||
      !std::isfinite(summary.final_cost) || !std::isfinite(summary.initial_cost) || !state_finite) {
    std::ostringstream msg;
    msg << "bundle adjustment failed (" << ceres::TerminationTypeToString(summary.termination_type)
        << ", cost " << summary.initial_cost << " -> " << summary.final_cost
        << "): " << summary.message << "; the window keeps its previous state";
    *why = msg.str();
    return false;  // the window's state was not touched
  }
  for (size_t i = 0; i < num_kf; ++i) {
    const double* block = pose_buffer.data() + i * kPoseAmbientSize;
    std::copy(block, block + kPoseAmbientSize, keyframes_[i]->pose);
  }
  for (size_t i = 0; i < points_.size(); ++i) points_[i]->inverse_depth = depth_buffer[i];
  for (size_t i = 0; i < num_kf; ++i) keyframes_[i]->log_prior_scale = scale_buffer[i];
  return true;
}

double WindowOptimizer::BlockSquaredNorm(const PointState& p, int target_id, const Block& block,
                                         std::vector<double>* scratch) const {
  const double* host_pose = FindKeyframe(p.host_id)->pose;
  const double* target_pose = FindKeyframe(target_id)->pose;
  // Usually the solve's last evaluation is at this state (not where the inverse-depth bound moved
  // the point).
  double sq = 0.0;
  if (!block.compressed ||
      !block.compressed->CachedSquaredNorm(host_pose, target_pose, p.inverse_depth, &sq)) {
    scratch->resize(block.cost->num_residuals());
    block.cost->EvaluateTangent(host_pose, target_pose, p.inverse_depth, scratch->data(), nullptr,
                                nullptr, nullptr);
    for (double r : *scratch) sq += r * r;
  }
  return sq;
}

int WindowOptimizer::GateOutliers() {
  // Block costs per target keyframe at the current estimate.
  std::map<int, std::vector<double>> costs_by_target;
  std::vector<std::vector<std::pair<int, double>>> per_point(points_.size());
  std::vector<double> scratch;
  for (size_t i = 0; i < points_.size(); ++i) {
    const PointState& p = *points_[i];
    for (const auto& [target_id, block] : p.residuals) {
      const double sq = BlockSquaredNorm(p, target_id, block, &scratch);
      costs_by_target[target_id].push_back(sq);
      per_point[i].emplace_back(target_id, sq);
    }
  }
  std::map<int, double> threshold;
  for (auto& [target_id, costs] : costs_by_target) {
    threshold[target_id] =
        options_.outlier_gate_factor * Quantile(costs, options_.outlier_gate_percentile);
  }
  int removed = 0;
  for (size_t i = 0; i < points_.size(); ++i) {
    for (const auto& [target_id, sq] : per_point[i]) {
      if (sq > threshold[target_id] || !std::isfinite(sq)) {
        points_[i]->residuals.erase(target_id);
        ++removed;
      }
    }
  }
  RemovePointsWithoutResiduals();
  return removed;
}

WindowResult WindowOptimizer::AddKeyframe(KeyframeData data) {
  const int level = options_.pyramid_level;
  auto input_error = [&](const std::string& what) {
    std::ostringstream msg;
    msg << "keyframe " << data.frame_index << ": " << what;
    throw InputError(msg.str());
  };
  if (data.features.num_levels() <= level) {
    input_error("feature pyramid has " + std::to_string(data.features.num_levels()) +
                " levels; window.pyramid_level = " + std::to_string(level) + " needs " +
                std::to_string(level + 1));
  }
  if (options_.coarse_iterations > 0 && data.features.num_levels() <= level + 1) {
    input_error("feature pyramid has " + std::to_string(data.features.num_levels()) +
                " levels; window.coarse_iterations > 0 with window.pyramid_level = " +
                std::to_string(level) + " needs " + std::to_string(level + 2));
  }
  if (data.depth.num_levels() <= level) {
    input_error("depth pyramid has " + std::to_string(data.depth.num_levels()) +
                " levels; window.pyramid_level = " + std::to_string(level) + " needs " +
                std::to_string(level + 1));
  }
  if (!(data.initial_depth_scale > 0.0) || !std::isfinite(data.initial_depth_scale)) {
    input_error("initial_depth_scale = " + std::to_string(data.initial_depth_scale) +
                " violates > 0 and finite");
  }
  if (!(data.prior_depth_scale > 0.0) || !std::isfinite(data.prior_depth_scale)) {
    input_error("prior_depth_scale = " + std::to_string(data.prior_depth_scale) +
                " violates > 0 and finite");
  }
  FeatureLevel& f = data.features.levels[level];
  const ImageF& d = data.depth.levels[level];
  if (d.width() != f.width || d.height() != f.height || d.channels() != 1) {
    std::ostringstream msg;
    msg << "depth level " << level << " is " << d.width() << "x" << d.height() << "x"
        << d.channels() << "; expected " << f.width << "x" << f.height << "x1 as the features";
    input_error(msg.str());
  }
  if (f.channels < 1 || f.data.size() != static_cast<size_t>(f.width) * f.height * f.channels ||
      f.width < options_.patch_size + 3 || f.height < options_.patch_size + 3) {
    std::ostringstream msg;
    msg << "feature level " << level << " is " << f.width << "x" << f.height << "x" << f.channels
        << " with " << f.data.size() << " values; expected a consistent planar map larger than "
        << options_.patch_size + 2 << " px";
    input_error(msg.str());
  }
  if (f.has_mask() && f.mask.size() != static_cast<size_t>(f.width) * f.height) {
    input_error("mask has " + std::to_string(f.mask.size()) + " values; expected " +
                std::to_string(f.width * f.height));
  }
  if (options_.coarse_iterations > 0) {
    const FeatureLevel& c = data.features.levels[level + 1];
    if (c.channels != f.channels ||
        c.data.size() != static_cast<size_t>(c.width) * c.height * c.channels ||
        c.width < options_.patch_size + 1 || c.height < options_.patch_size + 1) {
      std::ostringstream msg;
      msg << "feature level " << level + 1 << " (window.coarse_iterations) is " << c.width << "x"
          << c.height << "x" << c.channels << " with " << c.data.size()
          << " values; expected a consistent planar map with the " << f.channels
          << " channels of level " << level;
      input_error(msg.str());
    }
  }
  if (channels_ != 0 && f.channels != channels_) {
    input_error("features have " + std::to_string(f.channels) + " channels; the window's have " +
                std::to_string(channels_));
  }
  // A non-finite feature value or pose would make every block touching the keyframe, and with
  // them the whole window, NaN (Ceres then fails or the solve is thrown away at every later
  // keyframe while the keyframe stays in). Such a keyframe is refused: the window stays as it
  // was and the result says why.
  size_t non_finite = 0;
  for (float v : f.data) non_finite += std::isfinite(v) ? 0 : 1;
  const Eigen::Matrix4d pose_matrix = data.world_from_cam.Matrix();
  if (non_finite > 0 || !pose_matrix.allFinite()) {
    WindowResult rejected;
    std::ostringstream msg;
    msg << "keyframe " << data.frame_index << " rejected: ";
    if (non_finite > 0) {
      msg << non_finite << " of " << f.data.size() << " feature values at pyramid level " << level
          << " are not finite";
    } else {
      msg << "its pose is not finite";
    }
    msg << "; the window keeps its previous state";
    rejected.message = msg.str();
    rejected.keyframe_poses = KeyframePoses();
    rejected.num_points = num_points();
    rejected.num_residual_blocks = num_residual_blocks();
    return rejected;
  }
  channels_ = f.channels;
  if (!loss_) {
    const double a = options_.loss_scale * std::sqrt(static_cast<double>(channels_) *
                                                     options_.patch_size * options_.patch_size);
    if (options_.loss == "cauchy") {
      loss_ = std::make_unique<ceres::CauchyLoss>(a);
    } else {
      loss_ = std::make_unique<ceres::HuberLoss>(a);
    }
  }

  auto kf = std::make_unique<KeyframeState>();
  kf->id = next_keyframe_id_++;
  kf->frame_index = data.frame_index;
  kf->timestamp_ns = data.timestamp_ns;
  PoseToParameters(data.world_from_cam, kf->pose);
  // The relative pose prior's measurements: the new keyframe's pose relative to the newest
  // window keyframe's CURRENT (bundle-adjusted) pose is what the frontend measured (dfo_run hands
  // in the reference keyframe's adjusted pose composed with the tracked relative pose), so
  // chaining those relative poses gives a frontend-like trajectory whose relative poses the prior
  // uses. (Relating the keyframes' poses as handed in instead would fold every earlier BA
  // correction of the previous keyframe into the "measurement".)
  if (keyframes_.empty()) {
    kf->frontend_pose = data.world_from_cam;
  } else {
    const KeyframeState& newest = *keyframes_.back();
    kf->frontend_pose =
        newest.frontend_pose * (PoseFromParameters(newest.pose).Inverse() * data.world_from_cam);
  }
  if (options_.coarse_iterations > 0) kf->coarse = std::move(data.features.levels[level + 1]);
  kf->level = std::move(f);
  for (double zoom : zoom_ladder_) {
    kf->zoom_blurred.push_back(
        GaussianBlur(kf->level, options_.zoom_blur_sigma_px * std::sqrt(zoom * zoom - 1.0)));
  }
  kf->depth = d;
  kf->initial_depth_scale = data.initial_depth_scale;
  kf->prior_depth_scale = data.prior_depth_scale;
  KeyframeState* new_kf = kf.get();
  keyframes_.push_back(std::move(kf));
  const double depth_edge_fraction = SelectPoints(new_kf);
  ConnectNewKeyframe(new_kf);

  WindowResult result;
  result.depth_edge_fraction = depth_edge_fraction;
  if (options_.searched_points_only) {
    ActivateCandidates(&result);
  } else if (options_.depth_search_range > 1.0) {
    SearchNewPointDepths(new_kf, &result);
  }
  result.num_candidates = static_cast<int>(candidates_.size());
  const auto solve_start = std::chrono::steady_clock::now();
  if (keyframes_.size() < 2) {
    result.message = "nothing to optimise (one keyframe)";
  } else {
    double c0 = 0.0, c1 = 0.0;
    std::string why;
    // The warm-up's failure is not the window's: the solve at pyramid_level starts from where
    // it left the state (untouched when it failed) and decides.
    if (options_.coarse_iterations > 0) {
      std::string coarse_why;
      Solve(options_.coarse_iterations, &c0, &c1, &coarse_why, /*coarse=*/true);
    }
    result.converged = true;
    if (Solve(options_.max_iterations, &c0, &c1, &why, /*coarse=*/false, &result)) {
      result.optimized = true;
      result.initial_cost = c0;
      result.final_cost = c1;
      result.num_gated_blocks = GateOutliers();
      if (result.num_gated_blocks > 0) {
        double c2 = 0.0, c3 = 0.0;
        if (Solve(std::max(1, options_.max_iterations / 2), &c2, &c3, &why, /*coarse=*/false,
                  &result)) {
          result.final_cost = c3;
        } else {
          result.message = "second solve: " + why;
        }
      }
    } else {
      result.message = why;
    }
    result.converged = result.converged && result.optimized;
  }
  result.solve_ms = MsSince(solve_start);

  if (num_keyframes() > options_.max_keyframes) {
    const auto marg_start = std::chrono::steady_clock::now();
    const int position = ChooseKeyframeToMarginalize();
    result.marginalized_frame_index = keyframes_[position]->frame_index;
    result.marginalized_pose = PoseFromParameters(keyframes_[position]->pose);
    result.marginalized_points = HostedPoints(result.marginalized_frame_index);
    MarginalizeKeyframe(position, &result);
    result.marginalization_ms = MsSince(marg_start);
  }
  result.keyframe_poses = KeyframePoses();
  result.num_points = num_points();
  result.num_residual_blocks = num_residual_blocks();
  return result;
}

// DSO's choice (FullSystem::flagFramesForMarginalization): a keyframe with < 5% of its selected
// points still observed in the newest keyframe goes first (oldest first); otherwise the one
// maximising sqrt(d(i, newest)) * sum_j 1 / (d(i, j) + eps), d the distance between camera
// centres: far from the newest, close to the others. The newest two never leave.
int WindowOptimizer::ChooseKeyframeToMarginalize() const {
  const int n = num_keyframes();
  const int newest_id = keyframes_.back()->id;
  std::map<int, int> in_newest;
  for (const auto& p : points_) {
    if (p->residuals.count(newest_id)) ++in_newest[p->host_id];
  }
  for (int i = 0; i < n - 2; ++i) {
    const KeyframeState& kf = *keyframes_[i];
    const double fraction =
        kf.num_selected > 0 ? static_cast<double>(in_newest[kf.id]) / kf.num_selected : 0.0;
    if (fraction < options_.min_point_fraction) return i;
  }
  std::vector<Eigen::Vector3d> centres;
  for (const auto& kf : keyframes_) centres.push_back(PoseFromParameters(kf->pose).translation());
  double mean_step = 0.0;
  for (int i = 1; i < n; ++i) mean_step += (centres[i] - centres[i - 1]).norm();
  const double eps = 1e-5 * std::max(mean_step / std::max(n - 1, 1), 1e-9);
  int best = 0;
  double best_score = -1.0;
  for (int i = 0; i < n - 2; ++i) {
    double sum = 0.0;
    for (int j = 0; j < n; ++j) {
      if (j != i) sum += 1.0 / ((centres[i] - centres[j]).norm() + eps);
    }
    const double score = std::sqrt((centres[i] - centres[n - 1]).norm()) * sum;
    if (score > best_score) {
      best_score = score;
      best = i;
    }
  }
  return best;
}

void WindowOptimizer::MarginalizeKeyframe(int position, WindowResult* result) {
  KeyframeState* leaving = keyframes_[position].get();
  const int leaving_id = leaving->id;
  auto warn = [result](const std::string& text) {
    if (!result->message.empty()) result->message += "; ";
    result->message += text;
  };

  if (options_.marginalization) {
    // Variables: every window pose (index = position), then the marginalised points.
    std::vector<MarginalizationVariable> variables;
    std::map<int, int> pose_var;  // keyframe id -> variable
    for (const auto& kf : keyframes_) {
      pose_var[kf->id] = static_cast<int>(variables.size());
      variables.push_back({kPoseTangentSize, kf->id == leaving_id});
    }
    // First estimates: the pose values at which the current prior was linearised.
    std::map<int, std::array<double, kPoseAmbientSize>> first_estimate;
    if (options_.first_estimate_jacobians && prior_) {
      for (size_t b = 0; b < prior_keyframe_ids_.size(); ++b) {
        std::array<double, kPoseAmbientSize> x;
        std::copy(prior_->x0()[b].begin(), prior_->x0()[b].end(), x.begin());
        first_estimate[prior_keyframe_ids_[b]] = x;
      }
    }
    auto linearization_pose = [&](const KeyframeState* kf) -> const double* {
      auto it = first_estimate.find(kf->id);
      return it != first_estimate.end() ? it->second.data() : kf->pose;
    };
    std::vector<LinearizedFactor> factors;
    int marginalized_points = 0;
    for (const auto& p : points_) {
      if (p->host_id != leaving_id) continue;
      if (static_cast<int>(p->residuals.size()) < options_.min_marginalized_observations) continue;
      const int point_var = static_cast<int>(variables.size());
      variables.push_back({1, true});
      ++marginalized_points;
      for (const auto& [target_id, block] : p->residuals) {
        const FeatureMetricCost* cost = block.cost.get();
        const KeyframeState* target = FindKeyframe(target_id);
        const int n = cost->num_residuals();
        LinearizedFactor factor;
        factor.residual.resize(n);
        RowMajorMatrixXd j_host(n, 6), j_target(n, 6);
        Eigen::VectorXd j_depth(n);
        cost->EvaluateTangent(linearization_pose(leaving), linearization_pose(target),
                              p->inverse_depth, factor.residual.data(), j_host.data(),
                              j_target.data(), j_depth.data());
        if (!first_estimate.empty()) {
          // Residual at the current estimate, Jacobians at the first estimates.
          cost->EvaluateTangent(leaving->pose, target->pose, p->inverse_depth,
                                factor.residual.data(), nullptr, nullptr, nullptr);
        }
        factor.variables = {pose_var[leaving_id], pose_var[target_id], point_var};
        factor.jacobians = {j_host, j_target, j_depth};
        ApplyLossCorrection(loss_.get(), &factor);
        factors.push_back(std::move(factor));
      }
      if (options_.depth_prior_weight > 0.0) {
        LinearizedFactor factor;
        const double sqrt_w = std::sqrt(options_.depth_prior_weight);
        double residual = 0.0, jacobian = 0.0;
        if (scaled_depth_prior_) {
          // ScaledInverseDepthPriorCost with the keyframe's log scale held at its last value.
          residual = sqrt_w * (std::log(p->inverse_depth / p->prior_inverse_depth) -
                               leaving->log_prior_scale);
          jacobian = sqrt_w / p->inverse_depth;
        } else {
          jacobian = sqrt_w / p->prior_inverse_depth;
          residual = jacobian * (p->inverse_depth - p->prior_inverse_depth);
        }
        factor.residual = Eigen::VectorXd::Constant(1, residual);
        factor.variables = {point_var};
        factor.jacobians = {Eigen::MatrixXd::Constant(1, 1, jacobian)};
        factors.push_back(std::move(factor));
      }
    }
    if (prior_) {
      // The old prior joins (it involves the leaving pose in general); it enters unweighted, the
      // weight is applied in each solve only, so it does not compound.
      std::vector<const double*> blocks;
      for (int id : prior_keyframe_ids_) blocks.push_back(FindKeyframe(id)->pose);
      LinearizedFactor factor = prior_->Linearize(blocks.data());
      for (int& v : factor.variables) v = pose_var[prior_keyframe_ids_[v]];
      factors.push_back(std::move(factor));
    }
    prior_.reset();
    prior_keyframe_ids_.clear();
    if (!factors.empty()) {
      MarginalizationOptions marg_options;
      marg_options.relative_eigenvalue_floor = options_.relative_eigenvalue_floor;
      LinearPrior prior;
      std::string why;
      bool ok = Marginalize(variables, factors, marg_options, &prior, &why);
      if (ok) {
        // Gauge of the kept poses at x0 (left perturbations of world_from_cam): a common
        // [upsilon; omega] for all (6 directions) and the scale, upsilon_i = t_i (7th).
        const int n = static_cast<int>(prior.jacobian.cols());
        Eigen::MatrixXd nullspace = Eigen::MatrixXd::Zero(n, 7);
        // With first-estimate Jacobians the prior's linearisation point is the first estimate
        // of each pose that has one (its Jacobians were taken there), else the current value.
        for (size_t b = 0; b < prior.variables.size(); ++b) {
          const double* x = linearization_pose(keyframes_[prior.variables[b]].get());
          nullspace.block<6, 6>(prior.offsets[b], 0).setIdentity();
          nullspace.block<3, 1>(prior.offsets[b], 6) = Eigen::Vector3d(x[4], x[5], x[6]);
        }
        // With a depth prior the scale is observable: its information is kept, scaled by
        // prior_scale_memory at each marginalisation (the projector keeps sqrt of it).
        const double scale_kept =
            options_.depth_prior_weight > 0.0 ? std::sqrt(options_.prior_scale_memory) : 0.0;
        ok = ProjectOutNullspace(nullspace, options_.relative_eigenvalue_floor, &prior, scale_kept);
        if (!ok) why = "no information left after removing the gauge directions";
      }
      if (ok) {
        std::vector<PriorBlockKind> kinds;
        std::vector<std::vector<double>> x0;
        // The factors' residuals were taken at the current poses: re-express the prior about its
        // linearisation points, r0 <- r0 + J0 (x_current [-] x0) (a no-op without FEJ).
        Eigen::VectorXd shift = Eigen::VectorXd::Zero(prior.jacobian.cols());
        for (size_t b = 0; b < prior.variables.size(); ++b) {
          const KeyframeState* kf = keyframes_[prior.variables[b]].get();  // poses come first
          const double* x = linearization_pose(kf);
          prior_keyframe_ids_.push_back(kf->id);
          kinds.push_back(PriorBlockKind::kPose);
          x0.emplace_back(x, x + kPoseAmbientSize);
          shift.segment<6>(prior.offsets[b]) =
              (PoseFromParameters(kf->pose) * PoseFromParameters(x).Inverse()).Log();
        }
        prior.residual += prior.jacobian * shift;
        prior_ = std::make_unique<LinearPriorCost>(
            std::move(prior), std::move(kinds), std::move(x0), options_.first_estimate_jacobians);
        result->marginalized_into_prior = true;
      } else {
        warn("marginalisation prior of keyframe " + std::to_string(leaving->frame_index) +
             " rejected: " + why + " (its information is dropped)");
      }
    }
    (void)marginalized_points;
  } else {
    prior_.reset();
    prior_keyframe_ids_.clear();
  }

  // Drop the leaving keyframe's points and every block into it.
  points_.erase(std::remove_if(points_.begin(), points_.end(),
                               [leaving_id](const std::unique_ptr<PointState>& p) {
                                 return p->host_id == leaving_id;
                               }),
                points_.end());
  for (auto& p : points_) p->residuals.erase(leaving_id);
  candidates_.erase(std::remove_if(candidates_.begin(), candidates_.end(),
                                   [leaving_id](const std::unique_ptr<PointState>& p) {
                                     return p->host_id == leaving_id;
                                   }),
                    candidates_.end());
  keyframes_.erase(keyframes_.begin() + position);
  RemovePointsWithoutResiduals();
}

}  // namespace dfo
