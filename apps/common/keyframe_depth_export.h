// The depth a run's keyframes settled on in the window, for run.write_keyframe_depth: every
// keyframe that went to the window with its windowed pose, its image and the points it hosted as
// they were when it left the window (or at the end of the run), in the layout of
// dfo_io/keyframe_depth_io.h.
#ifndef DFO_APPS_COMMON_KEYFRAME_DEPTH_EXPORT_H_
#define DFO_APPS_COMMON_KEYFRAME_DEPTH_EXPORT_H_

#include "apps/common/sequence_runner.h"
#include "dfo_io/dataset.h"
#include "dfo_io/keyframe_depth_io.h"

namespace dfo::apps {

// `sequence` is the one the run's frames came from (SequenceFrameProvider: frame i of the run is
// its frame i). Throws InputError when the run has no window (mode frontend).
io::KeyframeDepthFolder KeyframeDepthOfRun(const SequenceRunResult& result,
                                           const io::Sequence& sequence);

// How close a keyframe depth folder's points are to reference depth maps (dfo_eval
// keyframe-depth): the synthetic sequences' true depth, or the ground-truth-pose stereo of real
// frames (dfo_eval stereo-depth).
struct KeyframeDepthCheck {
  int keyframes = 0;  // keyframes with a reference map
  int keyframes_without_reference = 0;
  size_t points = 0;  // their points with a valid reference depth
  // Each estimate scaled by one factor for the whole run (the median of reference / estimate
  // over every point), the way a trainer with one scale per run sees it; and by each keyframe's
  // own median (as per-image median scaling, which hides scale drift).
  double run_scale = 0.0;
  double abs_rel_run_scale = 0.0;
  double abs_rel_keyframe_scale = 0.0;
  double a1_run_scale = 0.0;  // share of points within a factor 1.25
  // Coefficient of variation of the keyframes' own medians (their scale drift along the run).
  double keyframe_scale_cv = 0.0;
  // The same for the depths the points started at (the depth source's, scaled).
  double start_abs_rel_run_scale = 0.0;
  double start_abs_rel_keyframe_scale = 0.0;
  // abs_rel (run scale) of the points with 1, 2-3 and 4 or more observations, of their start
  // depths, and their counts.
  double abs_rel_by_observations[3] = {0.0, 0.0, 0.0};
  double start_abs_rel_by_observations[3] = {0.0, 0.0, 0.0};
  // Median of log(estimate / reference) (run scale) per bin: a bias of the bin against the run.
  double median_log_ratio_by_observations[3] = {0.0, 0.0, 0.0};
  size_t points_by_observations[3] = {0, 0, 0};
};

// Reference map of a keyframe: `reference_dir`/<its image file's stem>.png, 16-bit, metres times
// `reference_scale`, 0 = none, at any size (the point's pixel is scaled to it, nearest pixel).
// Reference depths outside (min_depth, max_depth) are left out. Throws InputError naming the
// folder when no keyframe has a reference map or no point a valid reference depth.
KeyframeDepthCheck CheckKeyframeDepth(const io::KeyframeDepthFolder& folder,
                                      const std::string& reference_dir, double reference_scale,
                                      double min_depth, double max_depth);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_KEYFRAME_DEPTH_EXPORT_H_
