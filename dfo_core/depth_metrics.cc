#include "dfo_core/depth_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "dfo_core/error.h"

namespace dfo {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// numpy's np.median: the mean of the two middle values for an even count.
double Median(std::vector<double> v) {
  const size_t n = v.size();
  const size_t mid = n / 2;
  std::nth_element(v.begin(), v.begin() + mid, v.end());
  const double upper = v[mid];
  if (n % 2 == 1) return upper;
  const double lower = *std::max_element(v.begin(), v.begin() + mid);
  return 0.5 * (lower + upper);
}

}  // namespace

void DepthMetricsOptions::Check() const {
  if (!(min_depth > 0.0)) {
    throw ConfigError("depth_metrics.min_depth = " + std::to_string(min_depth) + " violates > 0");
  }
  if (!(max_depth > min_depth) || !std::isfinite(max_depth)) {
    throw ConfigError("depth_metrics.max_depth = " + std::to_string(max_depth) +
                      " violates > min_depth (" + std::to_string(min_depth) + ") and finite");
  }
}

DepthErrors ComputeDepthErrors(const ImageF& ground_truth, const ImageF& prediction,
                               const DepthMetricsOptions& options) {
  options.Check();
  if (ground_truth.width() != prediction.width() || ground_truth.height() != prediction.height() ||
      ground_truth.channels() != 1 || prediction.channels() != 1) {
    throw InputError(
        "depth maps differ in size: ground truth " + std::to_string(ground_truth.width()) + "x" +
        std::to_string(ground_truth.height()) + "x" + std::to_string(ground_truth.channels()) +
        ", prediction " + std::to_string(prediction.width()) + "x" +
        std::to_string(prediction.height()) + "x" + std::to_string(prediction.channels()) +
        " (expected equal, 1 channel)");
  }
  // Monodepth2 evaluate_depth.py: mask = gt > MIN_DEPTH & gt < MAX_DEPTH.
  std::vector<double> gt, pred;
  gt.reserve(ground_truth.size());
  pred.reserve(ground_truth.size());
  for (size_t i = 0; i < ground_truth.size(); ++i) {
    const double g = ground_truth.vector()[i];
    if (!(g > options.min_depth && g < options.max_depth)) continue;  // NaN fails too
    gt.push_back(g);
    const double p = prediction.vector()[i];
    pred.push_back(std::isfinite(p) ? p : 0.0);  // a non-finite prediction is clamped below
  }
  DepthErrors e;
  if (gt.empty()) {
    e.abs_rel = e.sq_rel = e.rmse = e.rmse_log = e.a1 = e.a2 = e.a3 = kNaN;
    e.median_scale = e.median_ground_truth = e.median_prediction = kNaN;
    return e;
  }
  e.median_ground_truth = Median(gt);
  e.median_prediction = Median(pred);
  if (options.median_scaling) {
    e.median_scale = e.median_prediction > 0.0 ? e.median_ground_truth / e.median_prediction : 1.0;
    for (double& p : pred) p *= e.median_scale;
  }
  for (double& p : pred) p = std::min(std::max(p, options.min_depth), options.max_depth);

  // compute_errors(gt, pred).
  const size_t n = gt.size();
  double abs_rel = 0, sq_rel = 0, sq = 0, sq_log = 0;
  size_t a1 = 0, a2 = 0, a3 = 0;
  for (size_t i = 0; i < n; ++i) {
    const double g = gt[i], p = pred[i];
    const double thresh = std::max(g / p, p / g);
    a1 += thresh < 1.25;
    a2 += thresh < 1.25 * 1.25;
    a3 += thresh < 1.25 * 1.25 * 1.25;
    const double diff = g - p;
    sq += diff * diff;
    const double log_diff = std::log(g) - std::log(p);
    sq_log += log_diff * log_diff;
    abs_rel += std::abs(diff) / g;
    sq_rel += diff * diff / g;
  }
  const double dn = static_cast<double>(n);
  e.abs_rel = abs_rel / dn;
  e.sq_rel = sq_rel / dn;
  e.rmse = std::sqrt(sq / dn);
  e.rmse_log = std::sqrt(sq_log / dn);
  e.a1 = static_cast<double>(a1) / dn;
  e.a2 = static_cast<double>(a2) / dn;
  e.a3 = static_cast<double>(a3) / dn;
  e.num_pixels = n;
  e.num_images = 1;
  return e;
}

DepthErrors AverageDepthErrors(const std::vector<DepthErrors>& per_image) {
  DepthErrors mean;
  mean.median_scale = 0.0;
  mean.median_ground_truth = mean.median_prediction = kNaN;  // per image only
  size_t count = 0;
  for (const DepthErrors& e : per_image) {
    if (e.num_images == 0) continue;
    mean.abs_rel += e.abs_rel;
    mean.sq_rel += e.sq_rel;
    mean.rmse += e.rmse;
    mean.rmse_log += e.rmse_log;
    mean.a1 += e.a1;
    mean.a2 += e.a2;
    mean.a3 += e.a3;
    mean.median_scale += e.median_scale;
    mean.num_pixels += e.num_pixels;
    ++count;
  }
  mean.num_images = count;
  if (count == 0) {
    mean.abs_rel = mean.sq_rel = mean.rmse = mean.rmse_log = mean.a1 = mean.a2 = mean.a3 = kNaN;
    mean.median_scale = mean.median_scale_cv = kNaN;
    return mean;
  }
  const double c = static_cast<double>(count);
  mean.abs_rel /= c;
  mean.sq_rel /= c;
  mean.rmse /= c;
  mean.rmse_log /= c;
  mean.a1 /= c;
  mean.a2 /= c;
  mean.a3 /= c;
  mean.median_scale /= c;
  double variance = 0.0;
  for (const DepthErrors& e : per_image) {
    if (e.num_images == 0) continue;
    variance += (e.median_scale - mean.median_scale) * (e.median_scale - mean.median_scale) / c;
  }
  mean.median_scale_cv = std::sqrt(variance) / mean.median_scale;
  return mean;
}

}  // namespace dfo
