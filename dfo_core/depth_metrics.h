// Depth-map error metrics as Monodepth2 / SfMLearner `compute_errors`: AbsRel, SqRel, RMSE,
// RMSE log and the threshold accuracies delta < 1.25, 1.25^2, 1.25^3, computed per image over
// the pixels with valid ground truth and averaged over images (a mean of per-image figures, not
// a pooled mean over all pixels), with optional per-image median scaling for scale-ambiguous
// (monocular) predictions.
#ifndef DFO_CORE_DEPTH_METRICS_H_
#define DFO_CORE_DEPTH_METRICS_H_

#include <cstddef>
#include <vector>

#include "dfo_core/image.h"

namespace dfo {

// Options of ComputeDepthErrors. Defaults are the KITTI Eigen-split conventions.
struct DepthMetricsOptions {
  // Ground-truth pixels count when min_depth < gt < max_depth (metres), as Monodepth2's mask
  // `gt > MIN_DEPTH and gt < MAX_DEPTH`; predictions are clamped to [min_depth, max_depth].
  double min_depth = 1e-3;  // > 0
  double max_depth = 80.0;  // > min_depth
  // Multiply each prediction by median(gt) / median(pred) over the valid pixels before clamping
  // (monocular evaluation, SfMLearner / Monodepth2 --eval_mono).
  bool median_scaling = false;
  // Throws ConfigError naming the field, its value and the rule.
  void Check() const;
};

// Errors of one image, or the average over several.
struct DepthErrors {
  double abs_rel = 0.0;       // mean |gt - pred| / gt
  double sq_rel = 0.0;        // mean (gt - pred)^2 / gt
  double rmse = 0.0;          // sqrt(mean (gt - pred)^2), metres
  double rmse_log = 0.0;      // sqrt(mean (ln gt - ln pred)^2)
  double a1 = 0.0;            // fraction with max(gt/pred, pred/gt) < 1.25
  double a2 = 0.0;            // ... < 1.25^2
  double a3 = 0.0;            // ... < 1.25^3
  size_t num_pixels = 0;      // valid pixels used (summed over images for an average)
  size_t num_images = 0;      // 1 for one image with valid pixels, 0 for none; images averaged
  double median_scale = 1.0;  // the median-scaling ratio used (mean over images for an average)
  // One image only (NaN for an average): the medians over its valid pixels of the ground truth and
  // of the raw prediction (before median scaling and clamping; a non-finite prediction counts as
  // 0), in metres. median_ground_truth / median_prediction is the ratio median scaling uses.
  double median_ground_truth = 0.0;
  double median_prediction = 0.0;
  // For an average only: population standard deviation over mean of the per-image median-scaling
  // ratios (how much the prediction's own scale varies from image to image; 0 for one image).
  double median_scale_cv = 0.0;
};

// Errors of one predicted depth map against its ground truth (both single-channel, metres, same
// size; non-finite or <= 0 ground truth is invalid). An image without valid ground-truth pixels
// gives NaN errors and num_images = 0. Throws InputError when the sizes or channel counts differ
// and ConfigError on bad options.
DepthErrors ComputeDepthErrors(const ImageF& ground_truth, const ImageF& prediction,
                               const DepthMetricsOptions& options = {});

// Average of per-image errors as Monodepth2 (`errors.mean(0)`), skipping images with no valid
// pixel (num_images == 0). All NaN when none is left.
DepthErrors AverageDepthErrors(const std::vector<DepthErrors>& per_image);

}  // namespace dfo

#endif  // DFO_CORE_DEPTH_METRICS_H_
