#include "dfo_core/alignment.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
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

namespace {

// Three coordinates for messages: "(x, y, z)" with enough digits to tell huge values apart.
std::string FormatPoint(const Eigen::Vector3d& p) {
  std::ostringstream s;
  s.precision(9);
  s << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return s.str();
}

// A point set centred on its mean and scaled by a power of two, both exact in floating point, so
// that squares and products of the coordinates never overflow or underflow, whatever their
// magnitude (1e-300 or 1e300): points = mean + 2^exponent * centred.
struct NormalizedPoints {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3Xd centred;  // max |coefficient| in [0.5, 1), or all 0 when the points coincide
  int exponent = 0;
  // Every axis's spread is 0 (identical) / at most a few units in the last place of that axis's
  // coordinates (identical up to rounding).
  bool identical = false;
  bool identical_up_to_rounding = false;
};

// x * 2^e for every coefficient (std::ldexp: exact unless the result leaves the double range).
template <typename Derived>
typename Derived::PlainObject Ldexp(const Eigen::MatrixBase<Derived>& m, int e) {
  return m.unaryExpr([e](double v) { return std::ldexp(v, e); });
}

// The exponent e of 2^e > |v| >= 2^(e-1) (0 for v = 0).
int Exponent(double v) {
  int e = 0;
  if (v != 0.0) std::frexp(v, &e);
  return e;
}

// Throws InputError naming `name` and the column when a coordinate is not finite.
NormalizedPoints Normalize(const Eigen::Matrix3Xd& points, const std::string& name) {
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    if (!points.col(i).allFinite()) {
      throw InputError(name + " position " + std::to_string(i) + " is not finite " +
                       FormatPoint(points.col(i)) + ", expected finite coordinates");
    }
  }
  // Per axis: bring the coordinates into [-1, 1) so that their sum cannot overflow, and centre
  // them there. Then one power of two for all axes (a similarity keeps its geometry) brings the
  // largest centred coordinate into [0.5, 1). Powers of two only, so nothing is rounded beyond
  // what the unscaled computation rounds.
  NormalizedPoints out;
  Eigen::Matrix3Xd centred(3, points.cols());
  int axis_exponent[3];
  int largest_exponent = std::numeric_limits<int>::min();
  const double eps = std::numeric_limits<double>::epsilon();
  out.identical = out.identical_up_to_rounding = true;
  for (int r = 0; r < 3; ++r) {
    axis_exponent[r] = Exponent(points.row(r).cwiseAbs().maxCoeff());
    const Eigen::RowVectorXd scaled = Ldexp(points.row(r), -axis_exponent[r]);
    const double scaled_mean = scaled.mean();
    centred.row(r) = (scaled.array() - scaled_mean).matrix();
    out.mean(r) = std::ldexp(scaled_mean, axis_exponent[r]);
    const double spread = centred.row(r).cwiseAbs().maxCoeff();  // in [0, 2)
    if (spread > 0.0) {
      out.identical = false;
      largest_exponent = std::max(largest_exponent, Exponent(spread) + axis_exponent[r]);
    }
    if (spread > 64.0 * eps) out.identical_up_to_rounding = false;
  }
  if (out.identical) {
    out.centred = Eigen::Matrix3Xd::Zero(3, points.cols());
    return out;
  }
  out.exponent = largest_exponent;
  out.centred.resize(3, points.cols());
  for (int r = 0; r < 3; ++r) {
    out.centred.row(r) = Ldexp(centred.row(r), axis_exponent[r] - largest_exponent);
  }
  return out;
}

// Throws InputError when the positions coincide (or differ only in the last bits of their
// coordinates) or lie on one line: no rotation (nor, for points that coincide, scale) would be
// determined by them.
void CheckSpread(const NormalizedPoints& p, const Eigen::Matrix3Xd& points,
                 const std::string& name) {
  const Eigen::Index n = points.cols();
  const double eps = std::numeric_limits<double>::epsilon();
  if (p.identical || p.identical_up_to_rounding) {
    std::ostringstream msg;
    msg << "all " << n << " " << name << " positions are "
        << (p.identical ? "identical" : "identical up to rounding") << " ("
        << FormatPoint(points.col(0))
        << (p.identical ? "" : " and within a few units in the last place of each coordinate")
        << "): an alignment needs positions that move";
    throw InputError(msg.str());
  }
  // Collinear within rounding: the largest distance from the principal axis (through the mean)
  // is at the level of the rounding of the distances along it. Distances on the normalised
  // points, so neither squares nor products leave the double range.
  const Eigen::Matrix3d cov = p.centred * p.centred.transpose() / static_cast<double>(n);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(cov);
  const Eigen::Vector3d axis = eigen.eigenvectors().col(2);  // largest eigenvalue
  double along = 0.0, across = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double a = p.centred.col(i).dot(axis);
    along = std::max(along, std::abs(a));
    across = std::max(across, RobustNorm(Eigen::Vector3d(p.centred.col(i) - a * axis)));
  }
  if (across <= 64.0 * eps * along) {
    std::ostringstream msg;
    msg.precision(3);
    msg << "the " << n << " " << name << " positions lie on one line (collinear within double "
        << "precision: up to " << std::ldexp(along, p.exponent) << " from their mean along it, at "
        << "most " << std::ldexp(across, p.exponent) << " across it): the rotation about that "
        << "line is not determined, an alignment needs positions that span a plane";
    throw InputError(msg.str());
  }
}

}  // namespace

SimilarityTransform UmeyamaAlignment(const Eigen::Matrix3Xd& source, const Eigen::Matrix3Xd& target,
                                     bool with_scale, const std::string& source_name,
                                     const std::string& target_name) {
  if (source.cols() != target.cols()) {
    std::ostringstream msg;
    msg << "Umeyama alignment needs equally many points, got " << source.cols() << " and "
        << target.cols();
    throw InputError(msg.str());
  }
  const Eigen::Index n = source.cols();
  if (n < 3) {
    throw InputError("Umeyama alignment needs at least 3 point pairs (not all on one line), got " +
                     std::to_string(n));
  }
  // Centred and scaled by powers of two (exact), so that no square overflows or underflows:
  // source = mean_x + 2^ex x, target = mean_y + 2^ey y.
  const NormalizedPoints nx = Normalize(source, source_name);
  const NormalizedPoints ny = Normalize(target, target_name);
  CheckSpread(nx, source, source_name);
  CheckSpread(ny, target, target_name);
  const Eigen::Matrix3Xd& x = nx.centred;
  const Eigen::Matrix3Xd& y = ny.centred;
  // Umeyama eq. 34-35: means (above); eq. 36: variance of the source; eq. 38: covariance, both
  // of the normalised points (the true ones are 2^(2 ex) and 2^(ex + ey) times these).
  const double sigma_x = x.squaredNorm() / static_cast<double>(n);
  const double sigma_y = y.squaredNorm() / static_cast<double>(n);
  const Eigen::Matrix3d cov_xy = y * x.transpose() / static_cast<double>(n);

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(cov_xy, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  // evo refuses a covariance of rank < 2 ("Degenerate covariance rank"); here relative to the
  // spreads (|cov| <= sqrt(sigma_x sigma_y)) and to the rounding of the n-term sums, so the test
  // does not depend on the units.
  const double tolerance = 4.0 * static_cast<double>(n) * std::numeric_limits<double>::epsilon() *
                           std::sqrt(sigma_x * sigma_y);
  int rank = 0;
  for (int i = 0; i < 3; ++i) {
    if (d(i) > tolerance) ++rank;
  }
  if (rank < 2) {
    std::ostringstream msg;
    msg << "degenerate covariance rank " << rank << " in Umeyama alignment: the " << source_name
        << " and " << target_name << " positions move in "
        << (rank == 0 ? "uncorrelated ways" : "ways correlated along one direction only")
        << ", alignment is not possible";
    throw InputError(msg.str());
  }
  // Eq. 43: S = diag(1, 1, -1) when det(U) det(V) < 0, ensuring a right-handed rotation
  // (Kabsch), exactly as evo.
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2, 2) = -1.0;

  SimilarityTransform out;
  out.rotation = svd.matrixU() * S * svd.matrixV().transpose();  // eq. 40
  // Eq. 42 on the normalised points, times 2^(ey - ex).
  out.scale = with_scale
                  ? std::ldexp((d.asDiagonal() * S).trace() / sigma_x, ny.exponent - nx.exponent)
                  : 1.0;
  if (!std::isnormal(out.scale)) {
    std::ostringstream msg;
    msg << "the Sim3 scale from the " << source_name << " to the " << target_name
        << " positions is about 1e"
        << static_cast<long long>(std::floor(std::log10((d.asDiagonal() * S).trace() / sigma_x) +
                                             (ny.exponent - nx.exponent) * std::log10(2.0)))
        << ", beyond the range of double precision: the two trajectories' sizes differ too much";
    throw InputError(msg.str());
  }
  out.translation = ny.mean - out.scale * (out.rotation * nx.mean);  // eq. 41
  if (!out.translation.allFinite()) {
    std::ostringstream msg;
    msg.precision(3);
    msg << "the alignment's translation from the " << source_name << " to the " << target_name
        << " positions (scale " << out.scale << ", coordinates up to "
        << std::max(source.cwiseAbs().maxCoeff(), target.cwiseAbs().maxCoeff())
        << " in magnitude) is beyond the range of double precision";
    throw InputError(msg.str());
  }
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
  result.transform = UmeyamaAlignment(source, target,
                                      /*with_scale=*/options.type == AlignmentType::kSim3,
                                      "estimate", "ground-truth");
  result.num_poses_used = n;
  result.aligned_estimate = TransformTrajectory(estimate, result.transform);
  // Poses beyond the fitted ones (num_poses_to_align) may still leave the double range.
  for (size_t i = 0; i < result.aligned_estimate.size(); ++i) {
    const Eigen::Vector3d& p = result.aligned_estimate[i].world_from_cam.translation();
    if (!p.allFinite()) {
      throw InputError("estimate pose " + std::to_string(i) + " at " +
                       FormatPoint(estimate[i].world_from_cam.translation()) +
                       " is not representable in double precision once aligned (scale " +
                       std::to_string(result.transform.scale) + ")");
    }
  }
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
