// Direct feature-metric tracking (DFO paper, Yin & Liu, Sec. III: z-scored feature maps, K x K
// patches, Gauss-Newton with inverse-compositional updates, outlier rule 0.5 (median + max),
// coarse-to-fine with translation rescaled by mean-depth ratios) with DSO's multi-hypothesis
// initialisation (Engel et al., "Direct Sparse Odometry", 2018, Sec. IV-A: constant velocity,
// zero, half and double motion, small rotations; a hypothesis abandoned when its residual at a
// level exceeds 1.5x the best so far).
#include "dfo_frontend/tracker.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "dfo_core/error.h"

namespace dfo {

// Reference data of one pyramid level, built once by SetReference.
struct Tracker::Level {
  PinholeCamera camera;
  int width = 0, height = 0, channels = 0;
  int patch_pixels = 0;     // K * K
  double mean_depth = 0.0;  // mean valid depth of the whole level's depth map
  int num_patches = 0;
  FeatureLevel reference;                // the reference features (for the test helpers)
  std::vector<Eigen::Vector2i> centers;  // patch centres, pixels
  // Per patch pixel (num_patches * patch_pixels, patch-major):
  std::vector<Eigen::Vector3f> points;  // p = d K^-1 u in the reference camera
  std::vector<Eigen::Vector2f> pixels;  // u
  std::vector<float> values;            // C reference feature values
  std::vector<float> jacobians;         // C x 6 row-major, d F_ref(pi(Exp(delta) p)) / d delta
  // Per patch: sum of J^T J over its pixels and channels (constant: inverse compositional).
  std::vector<Matrix6d> hessians;
};

// Outcome of one level's alignment.
struct Tracker::LevelResult {
  bool ok = false;  // enough valid patches and a finite pose
  TrackLevelStats stats;
};

namespace {

// Minimum number of valid patches for a 6-DoF solve at a level.
constexpr int kMinPatchesPerLevel = 12;

// Per-patch quantities of one evaluation at a pose.
struct Evaluation {
  std::vector<uint8_t> valid;      // patch fully inside the current image, in front of the camera
  std::vector<float> energy;       // squared residual norm over the patch (all pixels and channels)
  std::vector<Vector6d> gradient;  // sum J^T r over the patch
  int num_valid = 0;
};

void CheckPyramidsMatch(const FeatureLevel& a, const FeatureLevel& b, int level, const char* what) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels) {
    std::ostringstream msg;
    msg << what << ": level " << level << " features are " << b.width << "x" << b.height << "x"
        << b.channels << " but the reference's are " << a.width << "x" << a.height << "x"
        << a.channels;
    throw InputError(msg.str());
  }
}

}  // namespace

Tracker::Tracker(const TrackerOptions& options) : options_(options) { options_.Check(); }
Tracker::~Tracker() = default;
Tracker::Tracker(Tracker&&) noexcept = default;
Tracker& Tracker::operator=(Tracker&&) noexcept = default;
Tracker::Tracker(const Tracker&) = default;
Tracker& Tracker::operator=(const Tracker&) = default;

double Tracker::reference_mean_depth(int level) const {
  if (levels_.empty()) return 0.0;
  DFO_CHECK(level >= 0 && level < static_cast<int>(levels_.size())) << level;
  return levels_[level].mean_depth;
}

double Tracker::reference_parallax_depth(int level) const {
  double sum_inverse = 0.0;
  int n = 0;
  for (float z : reference_depths(level)) {
    if (!(z > 0.0f) || !std::isfinite(z)) continue;
    sum_inverse += 1.0 / z;
    ++n;
  }
  return n > 0 && sum_inverse > 0.0 ? n / sum_inverse : 0.0;
}

int Tracker::num_reference_points(int level) const {
  if (levels_.empty()) return 0;
  DFO_CHECK(level >= 0 && level < static_cast<int>(levels_.size())) << level;
  return levels_[level].num_patches;
}

std::vector<Eigen::Vector2i> Tracker::reference_points(int level) const {
  if (levels_.empty()) return {};
  DFO_CHECK(level >= 0 && level < static_cast<int>(levels_.size())) << level;
  return levels_[level].centers;
}

std::vector<float> Tracker::reference_depths(int level) const {
  if (levels_.empty()) return {};
  DFO_CHECK(level >= 0 && level < static_cast<int>(levels_.size())) << level;
  const Level& lv = levels_[level];
  std::vector<float> out;
  const int centre = lv.patch_pixels / 2;  // K x K patch, row-major: the middle pixel
  for (int i = 0; i < lv.num_patches; ++i) {
    out.push_back(lv.points[static_cast<size_t>(i) * lv.patch_pixels + centre].z());
  }
  return out;
}

int Tracker::SetReference(const FeaturePyramid& features, const DepthPyramid& depth) {
  const int num_levels = options_.num_levels;
  if (features.num_levels() < num_levels || depth.num_levels() < num_levels) {
    std::ostringstream msg;
    msg << "tracker reference: " << features.num_levels() << " feature and " << depth.num_levels()
        << " depth levels given; tracker.num_levels = " << num_levels
        << " needs at least that many of each";
    throw InputError(msg.str());
  }
  const int half = options_.patch_size / 2;
  // The patch must lie inside the image with one more pixel for the central differences.
  const int border = half + 1;
  std::vector<Level> levels(num_levels);
  for (int l = 0; l < num_levels; ++l) {
    const FeatureLevel& f = features.levels[l];
    const ImageF& d = depth.levels[l];
    if (d.width() != f.width || d.height() != f.height || d.channels() != 1) {
      std::ostringstream msg;
      msg << "tracker reference: level " << l << " depth is " << d.width() << "x" << d.height()
          << "x" << d.channels() << " but the features are " << f.width << "x" << f.height
          << "; expected a 1-channel depth map of the same size";
      throw InputError(msg.str());
    }
    DFO_CHECK(f.channels >= 1 &&
              f.data.size() == static_cast<size_t>(f.width) * f.height * f.channels)
        << "level " << l;
    Level& lv = levels[l];
    lv.camera = f.camera;
    lv.width = f.width;
    lv.height = f.height;
    lv.channels = f.channels;
    lv.patch_pixels = options_.patch_size * options_.patch_size;
    lv.mean_depth = depth.MeanDepth(l);
    lv.reference = f;
    const int C = f.channels, w = f.width, h = f.height;
    if (w - 2 * border < 1 || h - 2 * border < 1) continue;

    // Point selection: the best-gradient pixel of each grid cell whose whole patch has valid
    // depth (DSO's bucketing keeps points spread over the image); with a mask, only mask pixels.
    const int inner_w = w - 2 * border, inner_h = h - 2 * border;
    const int cell = std::max(options_.min_cell_px,
                              static_cast<int>(std::ceil(std::sqrt(
                                  static_cast<double>(inner_w) * inner_h / options_.max_points))));
    const float min_grad_sq = static_cast<float>(options_.min_gradient * options_.min_gradient);
    auto gradient_sq = [&](int x, int y) {
      float s = 0.0f;
      for (int c = 0; c < C; ++c) {
        const float gx = 0.5f * (f.At(c, x + 1, y) - f.At(c, x - 1, y));
        const float gy = 0.5f * (f.At(c, x, y + 1) - f.At(c, x, y - 1));
        s += gx * gx + gy * gy;
      }
      return s;
    };
    // The whole patch needs valid depth; with max_patch_depth_ratio, also no depth edge in the
    // patch grown by one pixel (colours there mix surfaces whose parallax differs).
    const float max_ratio = static_cast<float>(options_.max_patch_depth_ratio);
    auto patch_depth_valid = [&](int x, int y) {
      // A hole anywhere in the square makes DepthSpread infinite.
      if (max_ratio <= 0.0f) return std::isfinite(DepthSpread(d, x, y, half));
      return DepthSpread(d, x, y, half + 1) <= max_ratio;
    };
    for (int cy = border; cy < h - border; cy += cell) {
      for (int cx = border; cx < w - border; cx += cell) {
        float best = -1.0f;
        Eigen::Vector2i best_px(-1, -1);
        for (int y = cy; y < std::min(cy + cell, h - border); ++y) {
          for (int x = cx; x < std::min(cx + cell, w - border); ++x) {
            if (f.has_mask() && f.mask[static_cast<size_t>(y) * w + x] == 0) continue;
            const float g = gradient_sq(x, y);
            if (g < min_grad_sq || g <= best) continue;
            if (!patch_depth_valid(x, y)) continue;
            best = g;
            best_px = Eigen::Vector2i(x, y);
          }
        }
        if (best_px.x() >= 0 && lv.num_patches < options_.max_points) {
          lv.centers.push_back(best_px);
          ++lv.num_patches;
        }
      }
    }

    // Patch pixels: 3D points, reference values and the inverse-compositional Jacobian
    //   J = dF_ref/du (central differences) * dpi/dp * d(Exp(delta) p)/d delta,
    //   d(Exp(delta) p)/d delta at 0 = [I, -hat(p)] for delta = [upsilon; omega].
    const size_t n_px = static_cast<size_t>(lv.num_patches) * lv.patch_pixels;
    lv.points.resize(n_px);
    lv.pixels.resize(n_px);
    lv.values.resize(n_px * C);
    lv.jacobians.resize(n_px * C * 6);
    lv.hessians.assign(lv.num_patches, Matrix6d::Zero());
    size_t k = 0;
    for (int i = 0; i < lv.num_patches; ++i) {
      for (int dy = -half; dy <= half; ++dy) {
        for (int dx = -half; dx <= half; ++dx, ++k) {
          const int x = lv.centers[i].x() + dx, y = lv.centers[i].y() + dy;
          const Eigen::Vector2d u(x, y);
          const Eigen::Vector3d p = lv.camera.Unproject(u, static_cast<double>(d(x, y)));
          lv.points[k] = p.cast<float>();
          lv.pixels[k] = u.cast<float>();
          Eigen::Matrix<double, 3, 6> dp_ddelta;
          dp_ddelta.leftCols<3>().setIdentity();
          dp_ddelta.rightCols<3>() = -SO3d::Hat(p);
          const Eigen::Matrix<double, 2, 6> du_ddelta = lv.camera.ProjectJacobian(p) * dp_ddelta;
          for (int c = 0; c < C; ++c) {
            lv.values[k * C + c] = f.At(c, x, y);
            const double gx = 0.5 * (f.At(c, x + 1, y) - f.At(c, x - 1, y));
            const double gy = 0.5 * (f.At(c, x, y + 1) - f.At(c, x, y - 1));
            const Eigen::Matrix<double, 1, 6> j = gx * du_ddelta.row(0) + gy * du_ddelta.row(1);
            for (int m = 0; m < 6; ++m)
              lv.jacobians[(k * C + c) * 6 + m] = static_cast<float>(j(m));
            lv.hessians[i] += j.transpose() * j;
          }
        }
      }
    }
  }
  levels_ = std::move(levels);
  last_rmse_ = -1.0;
  return levels_[0].num_patches;
}

namespace {

// Residuals r = F_ref(u) - F_cur(pi(T p)) of every patch at pose T, with the per-patch energy
// and gradient J^T r. A patch is valid when all its pixels project in front of the camera and
// inside the image (bilinear needs [0, w-1] x [0, h-1]).
template <typename LevelT>
void Evaluate(const LevelT& lv, const FeatureLevel& cur, const SE3d& cur_from_ref, Evaluation* ev,
              std::vector<float>* residuals_out = nullptr) {
  const int C = lv.channels;
  const int P = lv.patch_pixels;
  const Eigen::Matrix3f R = cur_from_ref.rotationMatrix().cast<float>();
  const Eigen::Vector3f t = cur_from_ref.translation().cast<float>();
  const float fx = static_cast<float>(lv.camera.fx), fy = static_cast<float>(lv.camera.fy);
  const float cx = static_cast<float>(lv.camera.cx), cy = static_cast<float>(lv.camera.cy);
  const float max_x = static_cast<float>(cur.width - 1), max_y = static_cast<float>(cur.height - 1);
  const size_t plane = static_cast<size_t>(cur.width) * cur.height;
  ev->valid.assign(lv.num_patches, 0);
  ev->energy.assign(lv.num_patches, 0.0f);
  ev->gradient.assign(lv.num_patches, Vector6d::Zero());
  ev->num_valid = 0;
  if (residuals_out) residuals_out->assign(static_cast<size_t>(lv.num_patches) * P * C, 0.0f);
  std::vector<float> r(static_cast<size_t>(P) * C);
  for (int i = 0; i < lv.num_patches; ++i) {
    bool inside = true;
    float energy = 0.0f;
    Eigen::Matrix<float, 6, 1> g = Eigen::Matrix<float, 6, 1>::Zero();
    for (int j = 0; j < P && inside; ++j) {
      const size_t k = static_cast<size_t>(i) * P + j;
      const Eigen::Vector3f q = R * lv.points[k] + t;
      if (!(q.z() > 1e-6f)) {
        inside = false;
        break;
      }
      const float u = fx * q.x() / q.z() + cx;
      const float v = fy * q.y() / q.z() + cy;
      if (!(u >= 0.0f && v >= 0.0f && u <= max_x && v <= max_y)) {
        inside = false;
        break;
      }
      const int x0 = std::min(static_cast<int>(u), cur.width - 2);
      const int y0 = std::min(static_cast<int>(v), cur.height - 2);
      const float ax = u - static_cast<float>(x0), ay = v - static_cast<float>(y0);
      const float w00 = (1.0f - ax) * (1.0f - ay), w10 = ax * (1.0f - ay);
      const float w01 = (1.0f - ax) * ay, w11 = ax * ay;
      const size_t o = static_cast<size_t>(y0) * cur.width + x0;
      const float* ref = &lv.values[k * C];
      const float* jac = &lv.jacobians[k * C * 6];
      for (int c = 0; c < C; ++c) {
        const float* ch = cur.data.data() + c * plane + o;
        const float value =
            w00 * ch[0] + w10 * ch[1] + w01 * ch[cur.width] + w11 * ch[cur.width + 1];
        const float res = ref[c] - value;
        r[static_cast<size_t>(j) * C + c] = res;
        energy += res * res;
        for (int m = 0; m < 6; ++m) g(m) += jac[c * 6 + m] * res;
      }
    }
    if (!inside || !std::isfinite(energy)) continue;
    ev->valid[i] = 1;
    ev->energy[i] = energy;
    ev->gradient[i] = g.cast<double>();
    ++ev->num_valid;
    if (residuals_out) {
      std::copy(r.begin(), r.end(), residuals_out->begin() + static_cast<size_t>(i) * P * C);
    }
  }
}

}  // namespace

double Tracker::OutlierThreshold(std::vector<double> squared_norms) {
  if (squared_norms.empty()) return 0.0;
  const size_t n = squared_norms.size();
  const double max = *std::max_element(squared_norms.begin(), squared_norms.end());
  std::nth_element(squared_norms.begin(), squared_norms.begin() + n / 2, squared_norms.end());
  double median = squared_norms[n / 2];
  if (n % 2 == 0) {
    median =
        0.5 * (median + *std::max_element(squared_norms.begin(), squared_norms.begin() + n / 2));
  }
  // DFO paper: residuals whose squared norm exceeds 0.5 * (median + max) are outliers.
  return 0.5 * (median + max);
}

Tracker::LevelResult Tracker::AlignLevel(const FeaturePyramid& features, int level,
                                         SE3d* cur_from_ref) const {
  const Level& lv = levels_[level];
  const FeatureLevel& cur = features.levels[level];
  LevelResult result;
  result.stats.num_points = lv.num_patches;
  const int max_iterations = options_.MaxIterations(level);
  const double threshold = options_.ConvergenceThreshold(level);
  const double depth_scale = lv.mean_depth > 0.0 ? lv.mean_depth : 1.0;
  Evaluation ev;
  std::vector<double> energies;
  SE3d pose = *cur_from_ref;
  for (int iteration = 0;; ++iteration) {
    Evaluate(lv, cur, pose, &ev);
    if (ev.num_valid < kMinPatchesPerLevel) {
      result.stats.num_valid = ev.num_valid;
      result.stats.num_inliers = 0;
      result.stats.iterations = iteration;
      *cur_from_ref = pose;
      return result;
    }
    energies.clear();
    for (int i = 0; i < lv.num_patches; ++i) {
      if (ev.valid[i]) energies.push_back(ev.energy[i]);
    }
    const double outlier_threshold = options_.outlier_rule
                                         ? OutlierThreshold(energies)
                                         : std::numeric_limits<double>::infinity();
    Matrix6d H = Matrix6d::Zero();
    Vector6d b = Vector6d::Zero();
    double energy = 0.0;
    int inliers = 0;
    // Fixed-order reduction: results do not depend on anything but the inputs.
    for (int i = 0; i < lv.num_patches; ++i) {
      if (!ev.valid[i] || ev.energy[i] > outlier_threshold) continue;
      H += lv.hessians[i];
      b += ev.gradient[i];
      energy += ev.energy[i];
      ++inliers;
    }
    result.stats.num_valid = ev.num_valid;
    result.stats.num_inliers = inliers;
    result.stats.iterations = iteration;
    result.stats.rmse =
        inliers > 0
            ? std::sqrt(energy / (static_cast<double>(inliers) * lv.patch_pixels * lv.channels))
            : 0.0;
    if (iteration >= max_iterations || inliers < kMinPatchesPerLevel) break;
    // Gauss-Newton step of the inverse-compositional problem: min |r + J delta|^2.
    const Vector6d delta = -H.ldlt().solve(b);
    if (!delta.allFinite()) break;
    // T <- T * Exp(delta)^-1 (Baker & Matthews' inverse composition).
    pose = pose * SE3d::Exp(delta).Inverse();
    Vector6d scaled = delta;
    scaled.head<3>() /= depth_scale;
    if (scaled.norm() < threshold) {
      // Converged: one more evaluation for the final statistics at the updated pose.
      Evaluate(lv, cur, pose, &ev);
      energies.clear();
      for (int i = 0; i < lv.num_patches; ++i) {
        if (ev.valid[i]) energies.push_back(ev.energy[i]);
      }
      if (ev.num_valid < kMinPatchesPerLevel) {
        result.stats.num_valid = ev.num_valid;
        result.stats.num_inliers = 0;
        *cur_from_ref = pose;
        return result;
      }
      const double thr = options_.outlier_rule ? OutlierThreshold(energies)
                                               : std::numeric_limits<double>::infinity();
      double e = 0.0;
      int n = 0;
      for (int i = 0; i < lv.num_patches; ++i) {
        if (!ev.valid[i] || ev.energy[i] > thr) continue;
        e += ev.energy[i];
        ++n;
      }
      result.stats.num_valid = ev.num_valid;
      result.stats.num_inliers = n;
      result.stats.iterations = iteration + 1;
      result.stats.rmse =
          n > 0 ? std::sqrt(e / (static_cast<double>(n) * lv.patch_pixels * lv.channels)) : 0.0;
      break;
    }
  }
  *cur_from_ref = pose;
  result.ok = result.stats.num_inliers >= kMinPatchesPerLevel && pose.translation().allFinite() &&
              pose.quaternion().coeffs().allFinite();
  return result;
}

std::vector<SE3d> Tracker::MakeHypotheses(const SE3d& last_from_ref, const SE3d& motion) const {
  std::vector<SE3d> out;
  const Vector6d log_motion = motion.Log();
  out.push_back(motion * last_from_ref);                       // constant velocity
  out.push_back(last_from_ref);                                // zero motion
  out.push_back(SE3d::Exp(0.5 * log_motion) * last_from_ref);  // half motion
  out.push_back(motion * motion * last_from_ref);              // double motion
  if (options_.rotation_hypotheses_deg > 0.0) {
    const double angle = options_.rotation_hypotheses_deg * M_PI / 180.0;
    for (int axis = 0; axis < 3; ++axis) {
      for (int sign = 1; sign >= -1; sign -= 2) {
        Vector6d xi = Vector6d::Zero();
        xi(3 + axis) = sign * angle;
        out.push_back(SE3d::Exp(xi) * out.front());
      }
    }
  }
  return out;
}

TrackResult Tracker::Track(const FeaturePyramid& features, const std::vector<SE3d>& hypotheses) {
  DFO_CHECK(has_reference()) << "Tracker::Track called before SetReference";
  const int num_levels = options_.num_levels;
  if (features.num_levels() < num_levels) {
    std::ostringstream msg;
    msg << "tracker: " << features.num_levels()
        << " feature levels given; tracker.num_levels = " << num_levels
        << " needs at least that many";
    throw InputError(msg.str());
  }
  for (int l = 0; l < num_levels; ++l) {
    CheckPyramidsMatch(levels_[l].reference, features.levels[l], l, "tracker");
  }
  TrackResult best;
  best.status = TrackingStatus::kLost;
  best.num_points = levels_[0].num_patches;
  best.levels.assign(num_levels, TrackLevelStats());
  best.cur_from_ref = hypotheses.empty() ? SE3d() : hypotheses.front();
  if (levels_[0].num_patches < std::max(options_.min_inliers_lost, kMinPatchesPerLevel)) {
    return best;  // nothing to track (e.g. a reference depth map of zeros)
  }
  const std::vector<SE3d> guesses = hypotheses.empty() ? std::vector<SE3d>{SE3d()} : hypotheses;
  std::vector<double> best_level_rmse(num_levels, std::numeric_limits<double>::infinity());
  bool have_best = false;
  int total_iterations = 0;
  for (size_t h = 0; h < guesses.size(); ++h) {
    SE3d pose = guesses[h];
    if (!pose.translation().allFinite() || !pose.quaternion().coeffs().allFinite()) continue;
    // Translations are handled at each level's depth scale: the guess (finest scale) is
    // rescaled to the coarsest level, then by mean_depth(l-1) / mean_depth(l) between levels
    // (the paper; a no-op up to averaging with metric ground-truth depth).
    auto rescale = [&](int from, int to) {
      const double a = levels_[from].mean_depth, b = levels_[to].mean_depth;
      if (a > 0.0 && b > 0.0) pose = SE3d(pose.so3(), pose.translation() * (b / a));
    };
    rescale(0, num_levels - 1);
    std::vector<TrackLevelStats> stats(num_levels);
    bool abandoned = false;
    bool finest_ok = false;
    for (int l = num_levels - 1; l >= 0; --l) {
      if (l < num_levels - 1) rescale(l + 1, l);
      if (levels_[l].num_patches < kMinPatchesPerLevel) {
        if (l == 0) abandoned = true;
        continue;  // too few points at this coarse level: skip it
      }
      SE3d level_pose = pose;
      const LevelResult r = AlignLevel(features, l, &level_pose);
      total_iterations += r.stats.iterations;
      stats[l] = r.stats;
      if (!r.ok) {
        if (l == 0) {
          abandoned = true;
          break;
        }
        continue;  // keep the pose from before this level
      }
      pose = level_pose;
      // DSO: abandon a hypothesis whose level residual exceeds 1.5x the best so far.
      if (r.stats.rmse > options_.hypothesis_abandon_ratio * best_level_rmse[l]) {
        abandoned = true;
        break;
      }
      best_level_rmse[l] = std::min(best_level_rmse[l], r.stats.rmse);
      if (l == 0) finest_ok = true;
    }
    if (abandoned || !finest_ok) continue;
    if (!have_best || stats[0].rmse < best.rmse) {
      have_best = true;
      best.cur_from_ref = pose;
      best.levels = stats;
      best.rmse = stats[0].rmse;
      best.num_inliers = stats[0].num_inliers;
      best.hypothesis = static_cast<int>(h);
    }
    // Good enough: stop trying (DSO stops when the residual is not worse than the last frame's).
    const double good =
        std::max(options_.good_enough_rmse,
                 last_rmse_ > 0.0 ? options_.hypothesis_abandon_ratio * last_rmse_ : 0.0);
    if (best.rmse <= good) {
      best.hypotheses_tried = static_cast<int>(h) + 1;
      break;
    }
    best.hypotheses_tried = static_cast<int>(h) + 1;
  }
  if (best.hypotheses_tried == 0) best.hypotheses_tried = static_cast<int>(guesses.size());
  best.iterations = total_iterations;
  best.inlier_ratio =
      best.num_points > 0 ? static_cast<double>(best.num_inliers) / best.num_points : 0.0;
  const bool finite = best.cur_from_ref.translation().allFinite() &&
                      best.cur_from_ref.quaternion().coeffs().allFinite();
  if (!have_best || !finite || best.num_inliers < options_.min_inliers_lost ||
      best.rmse > options_.max_rmse_lost) {
    best.status = TrackingStatus::kLost;
  } else if (best.num_inliers >= options_.min_inliers_ok &&
             best.inlier_ratio >= options_.min_inlier_ratio_ok &&
             best.rmse <= options_.max_rmse_ok) {
    best.status = TrackingStatus::kOk;
  } else {
    best.status = TrackingStatus::kDegraded;
  }
  if (best.status != TrackingStatus::kLost) {
    last_rmse_ = best.rmse;
  } else {
    last_rmse_ = -1.0;
  }
  return best;
}

void Tracker::Linearize(const FeaturePyramid& features, int level, const SE3d& cur_from_ref,
                        Eigen::VectorXd* residuals, Eigen::MatrixXd* jacobian,
                        std::vector<int>* patch_ids) const {
  DFO_CHECK(has_reference() && level >= 0 && level < static_cast<int>(levels_.size())) << level;
  const Level& lv = levels_[level];
  CheckPyramidsMatch(lv.reference, features.levels[level], level, "tracker");
  Evaluation ev;
  std::vector<float> r;
  Evaluate(lv, features.levels[level], cur_from_ref, &ev, &r);
  const int C = lv.channels, P = lv.patch_pixels;
  const int rows = ev.num_valid * P * C;
  residuals->resize(rows);
  jacobian->resize(rows, 6);
  patch_ids->clear();
  int row = 0;
  for (int i = 0; i < lv.num_patches; ++i) {
    if (!ev.valid[i]) continue;
    patch_ids->push_back(i);
    for (int j = 0; j < P * C; ++j, ++row) {
      const size_t idx = static_cast<size_t>(i) * P * C + j;
      (*residuals)(row) = r[idx];
      for (int m = 0; m < 6; ++m) (*jacobian)(row, m) = lv.jacobians[idx * 6 + m];
    }
  }
}

Eigen::VectorXd Tracker::InverseCompositionalResiduals(const FeaturePyramid& features, int level,
                                                       const SE3d& cur_from_ref,
                                                       const Vector6d& delta) const {
  DFO_CHECK(has_reference() && level >= 0 && level < static_cast<int>(levels_.size())) << level;
  const Level& lv = levels_[level];
  Evaluation ev;
  std::vector<float> r;
  Evaluate(lv, features.levels[level], cur_from_ref, &ev, &r);
  const int C = lv.channels, P = lv.patch_pixels;
  const SE3d warp = SE3d::Exp(delta);
  const FeatureLevel& ref = lv.reference;
  Eigen::VectorXd out(ev.num_valid * P * C);
  int row = 0;
  for (int i = 0; i < lv.num_patches; ++i) {
    if (!ev.valid[i]) continue;
    for (int j = 0; j < P; ++j) {
      const size_t k = static_cast<size_t>(i) * P + j;
      // The exact reference pixel and depth (the float point would put u ~1e-5 px off the
      // integer pixel, where bilinear interpolation has its kink).
      const Eigen::Vector3d p = lv.camera.Unproject(Eigen::Vector2d(lv.pixels[k].cast<double>()),
                                                    static_cast<double>(lv.points[k].z()));
      const Eigen::Vector2d u = lv.camera.Project(Eigen::Vector3d(warp * p));
      const double x = std::clamp(u.x(), 0.0, ref.width - 1.0);
      const double y = std::clamp(u.y(), 0.0, ref.height - 1.0);
      const int x0 = std::min(static_cast<int>(x), ref.width - 2);
      const int y0 = std::min(static_cast<int>(y), ref.height - 2);
      const double ax = x - x0, ay = y - y0;
      for (int c = 0; c < C; ++c) {
        const double f_ref =
            (1 - ax) * (1 - ay) * ref.At(c, x0, y0) + ax * (1 - ay) * ref.At(c, x0 + 1, y0) +
            (1 - ax) * ay * ref.At(c, x0, y0 + 1) + ax * ay * ref.At(c, x0 + 1, y0 + 1);
        // r(delta) = F_ref(pi(Exp(delta) p)) - F_cur(pi(T p)) = r(0) + (F_ref(..) - F_ref(u)).
        out(row++) = r[k * C + c] + (f_ref - lv.values[k * C + c]);
      }
    }
  }
  return out;
}

}  // namespace dfo
