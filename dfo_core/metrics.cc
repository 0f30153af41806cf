#include "dfo_core/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "dfo_core/error.h"

namespace dfo {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRadToDeg = 180.0 / M_PI;

void CheckSameSize(const Trajectory& ground_truth, const Trajectory& estimate, const char* what) {
  if (ground_truth.size() != estimate.size()) {
    std::ostringstream msg;
    msg << what << ": ground truth has " << ground_truth.size() << " poses, estimate "
        << estimate.size() << "; associate the trajectories first (same size, pose i with pose i)";
    throw InputError(msg.str());
  }
}

// Cumulative path length of the positions: dist[0] = 0, dist[i] = dist[i-1] + |p_i - p_{i-1}|
// (KITTI devkit trajectoryDistances, evo geometry.accumulated_distances).
std::vector<double> PathDistances(const Trajectory& trajectory) {
  std::vector<double> dist(trajectory.size(), 0.0);
  for (size_t i = 1; i < trajectory.size(); ++i) {
    dist[i] = dist[i - 1] + RobustNorm(trajectory[i].world_from_cam.translation() -
                                       trajectory[i - 1].world_from_cam.translation());
  }
  return dist;
}

// Largest |x| (0 for none; inf when one is infinite; NaN values are passed over).
double LargestMagnitude(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

// The power of two 2^e nearest above the largest |x| (1 for 0): dividing by it is exact.
int ScaleExponent(double largest) {
  int e = 0;
  if (largest > 0.0) std::frexp(largest, &e);
  return e;
}

double Mean(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  double sum = 0.0;
  for (double x : v) sum += x;
  if (std::isfinite(sum)) return sum / static_cast<double>(v.size());
  // The sum left the double range (values near 1e308): the same sum scaled by a power of two.
  const double largest = LargestMagnitude(v);
  if (!std::isfinite(largest)) return sum / static_cast<double>(v.size());  // inf or NaN inside
  const int e = ScaleExponent(largest);
  sum = 0.0;
  for (double x : v) sum += std::ldexp(x, -e);
  return std::ldexp(sum / static_cast<double>(v.size()), e);
}

// sqrt(mean((x - center)^2)). Squares of values beyond 1e154 overflow: then the same computation
// on values scaled by a power of two (exact), so the result is right whenever it is representable.
double RootMeanSquare(const std::vector<double>& v, double center, double* sum_of_squares) {
  double sum = 0.0;
  for (double x : v) sum += (x - center) * (x - center);
  if (sum_of_squares != nullptr) *sum_of_squares = sum;
  if (std::isfinite(sum) && sum >= std::numeric_limits<double>::min()) {
    return std::sqrt(sum / static_cast<double>(v.size()));
  }
  double largest = 0.0;
  for (double x : v) largest = std::max(largest, std::abs(x - center));
  if (largest == 0.0 || !std::isfinite(largest) || std::isnan(sum)) {
    return std::sqrt(sum / static_cast<double>(v.size()));  // all 0, or inf / NaN inside
  }
  const int e = ScaleExponent(largest);
  double scaled = 0.0;
  for (double x : v) {
    const double d = std::ldexp(x - center, -e);
    scaled += d * d;
  }
  return std::ldexp(std::sqrt(scaled / static_cast<double>(v.size())), e);
}

// Population standard deviation (numpy's np.std, ddof = 0).
double PopulationStd(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  return RootMeanSquare(v, Mean(v), nullptr);
}

// Throws InputError when an error value is not finite. The inputs are finite (readers and
// AlignTrajectory check), so this means a difference of positions left the double range.
void CheckFiniteErrors(const std::vector<double>& errors, const char* metric, const char* what) {
  for (size_t i = 0; i < errors.size(); ++i) {
    if (!std::isfinite(errors[i])) {
      std::ostringstream msg;
      msg << metric << ": the error of " << what << " " << i << " is " << errors[i]
          << " (a non-finite pose, or positions so far apart that their difference exceeds the "
             "double range)";
      throw InputError(msg.str());
    }
  }
}

}  // namespace

ErrorStatistics ComputeStatistics(const std::vector<double>& errors) {
  ErrorStatistics s;
  s.count = errors.size();
  if (errors.empty()) {
    s.rmse = s.mean = s.median = s.std = s.min = s.max = s.sse = kNaN;
    return s;
  }
  s.rmse = RootMeanSquare(errors, 0.0, &s.sse);
  s.mean = Mean(errors);
  s.std = PopulationStd(errors);
  std::vector<double> sorted = errors;
  std::sort(sorted.begin(), sorted.end());
  s.min = sorted.front();
  s.max = sorted.back();
  const size_t n = sorted.size();
  s.median = (n % 2 == 1) ? sorted[n / 2] : 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]);
  return s;
}

AteResult ComputeAte(const Trajectory& ground_truth, const Trajectory& estimate) {
  CheckSameSize(ground_truth, estimate, "ATE");
  AteResult result;
  result.errors.reserve(estimate.size());
  // evo APE translation_part: E = positions_est - positions_ref, error = |E_i|.
  for (size_t i = 0; i < estimate.size(); ++i) {
    result.errors.push_back(RobustNorm(estimate[i].world_from_cam.translation() -
                                       ground_truth[i].world_from_cam.translation()));
  }
  CheckFiniteErrors(result.errors, "ATE", "pose");
  result.stats = ComputeStatistics(result.errors);
  return result;
}

void RpeOptions::Check() const {
  if (!(delta > 0.0) || !std::isfinite(delta)) {
    throw ConfigError("rpe.delta = " + std::to_string(delta) + " violates > 0");
  }
  if (delta_unit == DeltaUnit::kFrames && delta != std::floor(delta)) {
    throw ConfigError("rpe.delta = " + std::to_string(delta) +
                      " violates 'a whole number of frames' (delta_unit = frames)");
  }
  if (!(rel_delta_tol >= 0.0)) {
    throw ConfigError("rpe.rel_delta_tol = " + std::to_string(rel_delta_tol) + " violates >= 0");
  }
}

namespace {

// evo filters.filter_pairs_by_index.
std::vector<std::pair<size_t, size_t>> PairsByIndex(size_t n, size_t delta, bool all_pairs) {
  std::vector<std::pair<size_t, size_t>> pairs;
  if (all_pairs) {
    for (size_t i = 0; i + delta < n; ++i) pairs.emplace_back(i, i + delta);
  } else {
    for (size_t i = 0; i + delta < n; i += delta) pairs.emplace_back(i, i + delta);
  }
  return pairs;
}

// evo filters.filter_pairs_by_path.
std::vector<std::pair<size_t, size_t>> PairsByPath(const Trajectory& trajectory, double delta,
                                                   double tol, bool all_pairs) {
  std::vector<std::pair<size_t, size_t>> pairs;
  const size_t n = trajectory.size();
  if (n == 0) return pairs;
  if (all_pairs) {
    // evo runs a bounded binary search on the (monotone) path length from i to j; on a monotone
    // sequence that finds the j nearest to the target, the lower one on ties, as here.
    const std::vector<double> dist = PathDistances(trajectory);
    for (size_t i = 0; i < n; ++i) {
      const double target = dist[i] + delta;
      const auto it = std::lower_bound(dist.begin() + i, dist.end(), target);
      size_t best = n;  // none
      double best_residual = std::numeric_limits<double>::infinity();
      const size_t hi = static_cast<size_t>(it - dist.begin());
      for (size_t j : {hi == 0 ? n : hi - 1, hi}) {
        if (j >= n || j < i) continue;
        const double residual = std::abs(dist[j] - target);
        if (residual < best_residual) {
          best_residual = residual;
          best = j;
        }
      }
      if (best < n) {
        const double length = dist[best] - dist[i];
        if (length >= delta - tol && length <= delta + tol) pairs.emplace_back(i, best);
      }
    }
    return pairs;
  }
  // Consecutive mode: the path length accumulates from pose 0 and an id is taken (and the
  // accumulator reset) whenever it reaches delta; the first id is therefore not 0.
  std::vector<size_t> ids;
  double current = 0.0;
  for (size_t i = 0; i < n; ++i) {
    if (i > 0) {
      current += RobustNorm(trajectory[i].world_from_cam.translation() -
                            trajectory[i - 1].world_from_cam.translation());
    }
    if (current >= delta) {
      ids.push_back(i);
      current = 0.0;
    }
  }
  for (size_t k = 1; k < ids.size(); ++k) pairs.emplace_back(ids[k - 1], ids[k]);
  return pairs;
}

}  // namespace

RpeResult ComputeRpe(const Trajectory& ground_truth, const Trajectory& estimate,
                     const RpeOptions& options) {
  options.Check();
  CheckSameSize(ground_truth, estimate, "RPE");
  const Trajectory& pair_source = options.pairs_from_reference ? ground_truth : estimate;
  RpeResult result;
  if (options.delta_unit == DeltaUnit::kFrames) {
    result.pairs =
        PairsByIndex(pair_source.size(), static_cast<size_t>(options.delta), options.all_pairs);
  } else {
    result.pairs = PairsByPath(pair_source, options.delta, options.delta * options.rel_delta_tol,
                               options.all_pairs);
  }
  result.translation_errors.reserve(result.pairs.size());
  result.rotation_errors_deg.reserve(result.pairs.size());
  for (const auto& [i, j] : result.pairs) {
    // evo rpe_base: Q_rel = Q_i^-1 Q_j, P_rel = P_i^-1 P_j, E = Q_rel^-1 P_rel.
    const SE3d q_rel = ground_truth[i].world_from_cam.Inverse() * ground_truth[j].world_from_cam;
    const SE3d p_rel = estimate[i].world_from_cam.Inverse() * estimate[j].world_from_cam;
    const SE3d e = q_rel.Inverse() * p_rel;
    result.translation_errors.push_back(RobustNorm(e.translation()));
    result.rotation_errors_deg.push_back(e.so3().Angle() * kRadToDeg);
  }
  CheckFiniteErrors(result.translation_errors, "RPE", "pair");
  CheckFiniteErrors(result.rotation_errors_deg, "RPE", "pair");
  result.translation = ComputeStatistics(result.translation_errors);
  result.rotation_deg = ComputeStatistics(result.rotation_errors_deg);
  return result;
}

void KittiOdometryOptions::Check() const {
  if (lengths_m.empty()) throw ConfigError("kitti.lengths_m is empty, expected >= 1 length");
  for (size_t i = 0; i < lengths_m.size(); ++i) {
    if (!(lengths_m[i] > 0.0)) {
      throw ConfigError("kitti.lengths_m[" + std::to_string(i) +
                        "] = " + std::to_string(lengths_m[i]) + " violates > 0");
    }
  }
  if (step_frames <= 0) {
    throw ConfigError("kitti.step_frames = " + std::to_string(step_frames) + " violates > 0");
  }
}

KittiOdometryResult ComputeKittiOdometryErrors(const Trajectory& ground_truth,
                                               const Trajectory& estimate,
                                               const KittiOdometryOptions& options) {
  options.Check();
  CheckSameSize(ground_truth, estimate, "KITTI odometry errors");
  const std::vector<double> dist = PathDistances(ground_truth);
  const size_t n = ground_truth.size();

  std::vector<double> t_sum(options.lengths_m.size(), 0.0), r_sum(options.lengths_m.size(), 0.0);
  std::vector<size_t> counts(options.lengths_m.size(), 0);
  double t_total = 0.0, r_total = 0.0;
  size_t total = 0;
  const size_t step = static_cast<size_t>(options.step_frames);
  for (size_t first = 0; first < n; first += step) {
    for (size_t l = 0; l < options.lengths_m.size(); ++l) {
      const double len = options.lengths_m[l];
      // lastFrameFromSegmentLength: first frame whose distance exceeds dist[first] + len.
      const auto it = std::upper_bound(dist.begin() + first, dist.end(), dist[first] + len);
      if (it == dist.end()) continue;
      const size_t last = static_cast<size_t>(it - dist.begin());
      const SE3d delta_gt =
          ground_truth[first].world_from_cam.Inverse() * ground_truth[last].world_from_cam;
      const SE3d delta_est =
          estimate[first].world_from_cam.Inverse() * estimate[last].world_from_cam;
      const SE3d error = delta_est.Inverse() * delta_gt;
      // rotationError: acos of the clamped (trace - 1) / 2, as the devkit.
      const Eigen::Matrix3d R = error.rotationMatrix();
      const double d = 0.5 * (R.trace() - 1.0);
      const double r_err = std::acos(std::max(std::min(d, 1.0), -1.0));
      const double t_err = RobustNorm(error.translation());
      if (!std::isfinite(t_err) || !std::isfinite(r_err)) {
        throw InputError("KITTI odometry errors: the error of the segment from frame " +
                         std::to_string(first) + " to " + std::to_string(last) +
                         " is not finite (a non-finite pose, or positions beyond the double "
                         "range)");
      }
      t_sum[l] += t_err / len;
      r_sum[l] += r_err / len;
      ++counts[l];
      t_total += t_err / len;
      r_total += r_err / len;
      ++total;
    }
  }
  KittiOdometryResult result;
  result.num_segments = total;
  // The devkit reports t_err * 100 (%) and r_err in deg/m; deg/100 m is the usual table unit.
  result.t_rel_pct = total > 0 ? 100.0 * t_total / static_cast<double>(total) : kNaN;
  result.r_rel_deg_per_100m =
      total > 0 ? 100.0 * kRadToDeg * r_total / static_cast<double>(total) : kNaN;
  for (size_t l = 0; l < options.lengths_m.size(); ++l) {
    KittiLengthErrors e;
    e.length_m = options.lengths_m[l];
    e.num_segments = counts[l];
    const double c = static_cast<double>(counts[l]);
    e.t_rel_pct = counts[l] > 0 ? 100.0 * t_sum[l] / c : kNaN;
    e.r_rel_deg_per_100m = counts[l] > 0 ? 100.0 * kRadToDeg * r_sum[l] / c : kNaN;
    result.per_length.push_back(e);
  }
  return result;
}

void SnippetAteOptions::Check() const {
  if (snippet_length < 2) {
    throw ConfigError("snippet_ate.snippet_length = " + std::to_string(snippet_length) +
                      " violates >= 2");
  }
  if (stride < 1) {
    throw ConfigError("snippet_ate.stride = " + std::to_string(stride) + " violates >= 1");
  }
}

SnippetAteResult ComputeSnippetAte(const Trajectory& ground_truth, const Trajectory& estimate,
                                   const SnippetAteOptions& options) {
  options.Check();
  CheckSameSize(ground_truth, estimate, "snippet ATE");
  SnippetAteResult result;
  const size_t len = static_cast<size_t>(options.snippet_length);
  const size_t n = ground_truth.size();
  for (size_t start = 0; start + len <= n; start += static_cast<size_t>(options.stride)) {
    const SE3d gt_first_inv = ground_truth[start].world_from_cam.Inverse();
    const SE3d est_first_inv = estimate[start].world_from_cam.Inverse();
    std::vector<Eigen::Vector3d> gt(len), est(len);
    for (size_t k = 0; k < len; ++k) {
      gt[k] = (gt_first_inv * ground_truth[start + k].world_from_cam).translation();
      est[k] = (est_first_inv * estimate[start + k].world_from_cam).translation();
    }
    // compute_ate: offset so the first positions agree (both are 0 here up to round-off).
    const Eigen::Vector3d offset = gt[0] - est[0];
    // Both scaled by one power of two (exact, and the fitted scale is unchanged) so that the dot
    // products below neither overflow nor underflow; the error is scaled back at the end.
    double largest = 0.0;
    for (size_t k = 0; k < len; ++k) {
      est[k] += offset;
      largest = std::max({largest, gt[k].cwiseAbs().maxCoeff(), est[k].cwiseAbs().maxCoeff()});
    }
    if (!std::isfinite(largest)) {
      throw InputError("snippet ATE: the snippet from frame " + std::to_string(start) +
                       " has non-finite relative positions (a non-finite pose, or positions "
                       "beyond the double range)");
    }
    const int e = ScaleExponent(largest);
    double num = 0.0, den = 0.0;
    for (size_t k = 0; k < len; ++k) {
      for (int c = 0; c < 3; ++c) {
        gt[k][c] = std::ldexp(gt[k][c], -e);
        est[k][c] = std::ldexp(est[k][c], -e);
      }
      num += gt[k].dot(est[k]);
      den += est[k].squaredNorm();
    }
    const double scale = den > 0.0 ? num / den : 0.0;
    double sum_sq = 0.0;
    for (size_t k = 0; k < len; ++k) sum_sq += (scale * est[k] - gt[k]).squaredNorm();
    // sqrt(sum of squares) / N, SfMLearner's definition.
    result.errors.push_back(std::ldexp(std::sqrt(sum_sq) / static_cast<double>(len), e));
  }
  result.mean = Mean(result.errors);
  result.std = PopulationStd(result.errors);
  return result;
}

constexpr int kScaleDriftChords = 5;

namespace {

// min, max and log_std of result->ratios (see ScaleDriftResult).
void SummarizeScaleRatios(ScaleDriftResult* result) {
  const std::vector<double>& ratios = result->ratios;
  if (ratios.empty()) {
    result->log_std = result->min = result->max = kNaN;
    return;
  }
  result->min = *std::min_element(ratios.begin(), ratios.end());
  result->max = *std::max_element(ratios.begin(), ratios.end());
  if (ratios.size() < 2 || !(result->min > 0.0)) {
    result->log_std = kNaN;
    return;
  }
  double mean = 0.0;
  for (double r : ratios) mean += std::log(r);
  mean /= static_cast<double>(ratios.size());
  double sq = 0.0;
  for (double r : ratios) sq += (std::log(r) - mean) * (std::log(r) - mean);
  result->log_std = std::sqrt(sq / static_cast<double>(ratios.size()));
}

}  // namespace

ScaleDriftResult ComputeScaleDrift(const Trajectory& ground_truth, const Trajectory& estimate,
                                   double segment_length_m) {
  CheckSameSize(ground_truth, estimate, "scale drift");
  if (!(segment_length_m > 0.0) || !std::isfinite(segment_length_m)) {
    throw InputError("scale drift: the stretch length must be > 0 m, got " +
                     std::to_string(segment_length_m));
  }
  ScaleDriftResult result;
  result.segment_length_m = segment_length_m;
  // Lengths along chords between poses a fifth of a stretch apart, not frame to frame: per-frame
  // jitter would lengthen the estimate's path and read as scale.
  const double chord_m = segment_length_m / kScaleDriftChords;
  const auto position = [](const Trajectory& t, size_t i) {
    return t[i].world_from_cam.translation();
  };
  double gt_length = 0.0, est_length = 0.0, gt_since_sample = 0.0;
  size_t first = 0, sample = 0;
  for (size_t i = 1; i < ground_truth.size(); ++i) {
    gt_since_sample += RobustNorm(position(ground_truth, i) - position(ground_truth, i - 1));
    if (gt_since_sample < chord_m) continue;
    gt_length += RobustNorm(position(ground_truth, i) - position(ground_truth, sample));
    est_length += RobustNorm(position(estimate, i) - position(estimate, sample));
    gt_since_sample = 0.0;
    sample = i;
    if (gt_length >= segment_length_m * (1.0 - 1e-9) || i + 1 == ground_truth.size()) {
      if (gt_length >= segment_length_m * (1.0 - 1e-9)) {
        result.ratios.push_back(est_length / gt_length);
        result.first_index.push_back(first);
      }
      gt_length = est_length = 0.0;
      first = i;
    }
  }
  SummarizeScaleRatios(&result);
  return result;
}

ScaleDriftResult ComputeStepScale(const Trajectory& ground_truth, const Trajectory& estimate,
                                  int segment_frames) {
  CheckSameSize(ground_truth, estimate, "step scale");
  if (segment_frames < 1) {
    throw InputError("step scale: the stretch must be >= 1 frame, got " +
                     std::to_string(segment_frames));
  }
  ScaleDriftResult result;
  result.segment_frames = segment_frames;
  const size_t frames = static_cast<size_t>(segment_frames);
  const size_t chord = std::max<size_t>(1, frames / kScaleDriftChords);
  const auto position = [](const Trajectory& t, size_t i) {
    return t[i].world_from_cam.translation();
  };
  for (size_t first = 0; first + frames < ground_truth.size(); first += frames) {
    double gt_length = 0.0, est_length = 0.0;
    for (size_t a = first; a < first + frames; a += chord) {
      const size_t b = std::min(a + chord, first + frames);
      gt_length += RobustNorm(position(ground_truth, b) - position(ground_truth, a));
      est_length += RobustNorm(position(estimate, b) - position(estimate, a));
    }
    if (!(gt_length > 0.0)) continue;
    result.ratios.push_back(est_length / gt_length);
    result.first_index.push_back(first);
  }
  SummarizeScaleRatios(&result);
  return result;
}

namespace {

// The path that starts at `start` and takes, at step i, the direction of direction_source's step
// i with the length of length_source's step i; the timestamps are direction_source's.
Trajectory RebuiltPath(const Trajectory& direction_source, const Trajectory& length_source,
                       const Eigen::Vector3d& start) {
  Trajectory out;
  Eigen::Vector3d p = start;
  out.Add(direction_source[0].timestamp_ns, SE3d(SO3d(), p));
  for (size_t i = 1; i < direction_source.size(); ++i) {
    const Eigen::Vector3d d = direction_source[i].world_from_cam.translation() -
                              direction_source[i - 1].world_from_cam.translation();
    const double length = RobustNorm(length_source[i].world_from_cam.translation() -
                                     length_source[i - 1].world_from_cam.translation());
    const double norm = RobustNorm(d);
    if (norm > 0.0 && std::isfinite(norm)) p += d * (length / norm);
    out.Add(direction_source[i].timestamp_ns, SE3d(SO3d(), p));
  }
  return out;
}

// ATE rmse of `path` aligned onto the ground truth; NaN when it cannot be aligned.
double AlignedAteRmse(const Trajectory& ground_truth, const Trajectory& path,
                      const TrajectoryAlignmentOptions& alignment) {
  try {
    const TrajectoryAlignment aligned = AlignTrajectory(path, ground_truth, alignment);
    return ComputeAte(ground_truth, aligned.aligned_estimate).stats.rmse;
  } catch (const InputError&) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace

AteSplit ComputeAteSplit(const Trajectory& ground_truth, const Trajectory& estimate,
                         const TrajectoryAlignmentOptions& alignment) {
  CheckSameSize(ground_truth, estimate, "ATE split");
  if (ground_truth.size() < 2) {
    throw InputError("ATE split: needs at least 2 poses, got " +
                     std::to_string(ground_truth.size()));
  }
  AteSplit split;
  split.directions_rmse = AlignedAteRmse(
      ground_truth, RebuiltPath(estimate, ground_truth, estimate[0].world_from_cam.translation()),
      alignment);
  split.lengths_rmse = AlignedAteRmse(
      ground_truth,
      RebuiltPath(ground_truth, estimate, ground_truth[0].world_from_cam.translation()), alignment);
  return split;
}

}  // namespace dfo
