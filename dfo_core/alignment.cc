#include "dfo_core/alignment.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cstdlib>
#include <limits>
#include <sstream>

#include "dfo_core/error.h"

namespace dfo {

AlignmentType ParseAlignmentType(const std::string& name) {
  if (name == "none") return AlignmentType::kNone;
  if (name == "se3") return AlignmentType::kSe3;
  if (name == "sim3") return AlignmentType::kSim3;
  throw InputError("unknown alignment '" + name + "', expected none, se3 or sim3");
}

std::string AlignmentTypeName(AlignmentType type) {
  switch (type) {
    case AlignmentType::kNone:
      return "none";
    case AlignmentType::kSe3:
      return "se3";
    case AlignmentType::kSim3:
      return "sim3";
  }
  return "unknown";
}

SE3d SimilarityTransform::Apply(const SE3d& world_from_cam) const {
  // evo PosePath3D.align: scale(s) multiplies every position, then transform(se3(r, t))
  // left-multiplies every pose.
  const Eigen::Matrix3d R = rotation * world_from_cam.rotationMatrix();
  const Eigen::Vector3d t = scale * (rotation * world_from_cam.translation()) + translation;
  return SE3d(SO3d::FromMatrix(R), t);
}

Eigen::Matrix4d SimilarityTransform::Matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = scale * rotation;
  m.topRightCorner<3, 1>() = translation;
  return m;
}

SimilarityTransform UmeyamaAlignment(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                     bool with_scale) {
  if (source.cols() != target.cols()) {
    std::ostringstream msg;
    msg << "Umeyama alignment needs equally many points, got " << source.cols() << " and "
        << target.cols();
    throw InputError(msg.str());
  }
  const Eigen::Index n = source.cols();
  if (n < 2) {
    throw InputError("Umeyama alignment needs at least 2 point pairs, got " + std::to_string(n));
  }
  // Umeyama eq. 34-35: means; eq. 36: variance of the source; eq. 38: covariance.
  const Eigen::Vector3d mean_x = source.rowwise().mean();
  const Eigen::Vector3d mean_y = target.rowwise().mean();
  const Eigen::Matrix3Xd x = source.colwise() - mean_x;
  const Eigen::Matrix3Xd y = target.colwise() - mean_y;
  const double sigma_x = x.squaredNorm() / static_cast<double>(n);
  const Eigen::Matrix3d cov_xy = y * x.transpose() / static_cast<double>(n);

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov_xy, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  int rank = 0;
  for (int i = 0; i < 3; ++i) {
    if (d(i) > std::numeric_limits<double>::epsilon()) ++rank;
  }
  if (rank < 2) {
    throw InputError(
        "degenerate covariance rank in Umeyama alignment (points collinear or identical), "
        "alignment is not possible");
  }
  // Eq. 43: S = diag(1, 1, -1) when det(U) det(V) < 0, ensuring a right-handed rotation
  // (Kabsch), exactly as evo.
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2, 2) = -1.0;

  SimilarityTransform out;
  out.rotation = svd.matrixU() * S * svd.matrixV().transpose();           // eq. 40
  out.scale = with_scale ? (d.asDiagonal() * S).trace() / sigma_x : 1.0;  // eq. 42
  out.translation = mean_y - out.scale * (out.rotation * mean_x);         // eq. 41
  return out;
}

void TrajectoryAlignmentOptions::Check() const {
  if (num_poses_to_align < 0) {
    throw ConfigError("alignment.num_poses_to_align = " + std::to_string(num_poses_to_align) +
                      " violates >= 0");
  }
}

Trajectory TransformTrajectory(const Trajectory& trajectory, const SimilarityTransform& transform) {
  Trajectory out;
  out.poses().reserve(trajectory.size());
  for (const auto& p : trajectory) out.Add(p.timestamp_ns, transform.Apply(p.world_from_cam));
  return out;
}

TrajectoryAlignment AlignTrajectory(const Trajectory& estimate, const Trajectory& ground_truth,
                                    const TrajectoryAlignmentOptions& options) {
  options.Check();
  if (estimate.size() != ground_truth.size()) {
    throw InputError("cannot align trajectories of different sizes: estimate has " +
                     std::to_string(estimate.size()) + " poses, ground truth " +
                     std::to_string(ground_truth.size()) + " (associate them first)");
  }
  if (estimate.empty()) throw InputError("cannot align empty trajectories");

  TrajectoryAlignment result;
  result.type = options.type;
  if (options.type == AlignmentType::kNone) {
    result.aligned_estimate = estimate;
    return result;
  }
  size_t n = estimate.size();
  if (options.num_poses_to_align > 0) {
    n = std::min(n, static_cast<size_t>(options.num_poses_to_align));
  }
  Eigen::Matrix3Xd source(3, n), target(3, n);
  for (size_t i = 0; i < n; ++i) {
    source.col(i) = estimate[i].world_from_cam.translation();
    target.col(i) = ground_truth[i].world_from_cam.translation();
  }
  result.transform =
      UmeyamaAlignment(source, target, /*with_scale=*/options.type == AlignmentType::kSim3);
  result.num_poses_used = n;
  result.aligned_estimate = TransformTrajectory(estimate, result.transform);
  return result;
}

namespace {

// Index of the stamp of `sorted` nearest to t, the first one on ties (numpy argmin), by binary
// search; `sorted` strictly increases.
size_t NearestSorted(const std::vector<int64_t>& sorted, int64_t t) {
  const auto it = std::lower_bound(sorted.begin(), sorted.end(), t);
  if (it == sorted.begin()) return 0;
  if (it == sorted.end()) return sorted.size() - 1;
  const size_t hi = static_cast<size_t>(it - sorted.begin());
  const size_t lo = hi - 1;
  // Equal distance: the lower index wins, as argmin returns the first minimum.
  return (t - sorted[lo] <= sorted[hi] - t) ? lo : hi;
}

}  // namespace

std::vector<std::pair<size_t, size_t>> AssociateByTimestamp(const Trajectory& a,
                                                            const Trajectory& b,
                                                            int64_t max_diff_ns) {
  DFO_CHECK(max_diff_ns >= 0) << "max_diff_ns = " << max_diff_ns;
  std::vector<std::pair<size_t, size_t>> pairs;
  if (a.empty() || b.empty()) return pairs;
  // evo: snd_longer = len(b) > len(a); the short trajectory is a only when b is longer.
  const bool b_longer = b.size() > a.size();
  const Trajectory& shorter = b_longer ? a : b;
  const Trajectory& longer = b_longer ? b : a;

  std::vector<int64_t> stamps(longer.size());
  bool strictly_increasing = true;
  for (size_t i = 0; i < longer.size(); ++i) {
    stamps[i] = longer[i].timestamp_ns;
    if (i > 0 && stamps[i] <= stamps[i - 1]) strictly_increasing = false;
  }
  for (size_t i = 0; i < shorter.size(); ++i) {
    const int64_t t = shorter[i].timestamp_ns;
    size_t best = 0;
    if (strictly_increasing) {
      best = NearestSorted(stamps, t);
    } else {
      // Unsorted stamps: a plain argmin (first minimum), as evo.
      int64_t best_diff = std::numeric_limits<int64_t>::max();
      for (size_t j = 0; j < stamps.size(); ++j) {
        const int64_t diff = std::llabs(stamps[j] - t);
        if (diff < best_diff) {
          best_diff = diff;
          best = j;
        }
      }
    }
    if (std::llabs(stamps[best] - t) <= max_diff_ns) {
      pairs.emplace_back(b_longer ? i : best, b_longer ? best : i);
    }
  }
  return pairs;
}

void ApplyAssociation(const std::vector<std::pair<size_t, size_t>>& pairs, const Trajectory& a,
                      const Trajectory& b, Trajectory* a_out, Trajectory* b_out) {
  DFO_CHECK(a_out != nullptr && b_out != nullptr);
  Trajectory ra, rb;
  ra.poses().reserve(pairs.size());
  rb.poses().reserve(pairs.size());
  for (const auto& [ia, ib] : pairs) {
    DFO_CHECK(ia < a.size() && ib < b.size()) << "pair (" << ia << ", " << ib << ")";
    ra.poses().push_back(a[ia]);
    rb.poses().push_back(b[ib]);
  }
  *a_out = std::move(ra);
  *b_out = std::move(rb);
}

}  // namespace dfo
