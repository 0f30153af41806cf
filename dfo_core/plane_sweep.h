// Reference depth for real video from known poses: multi-view plane-sweep stereo.
//
// Real monocular sequences such as KITTI odometry have ground-truth poses but no depth maps. With
// the poses known, a frame's depth follows from its neighbours by stereo: every pixel tries
// inverse depths between 1 / max_depth_m and 1 / min_depth_m, each view is warped onto the frame
// for that depth, and the depth whose mean zero-normalised cross-correlation (ZNCC) over a
// (2 r + 1)^2 window is best wins (Collins' plane sweep with fronto-parallel planes, the cost of
// COLMAP's and DSO's patch matching). Only confident pixels keep a depth:
//   - the best cost 1 - mean ZNCC is at most max_cost,
//   - every other local minimum farther than 3 samples away costs >= uniqueness x the best,
//   - the best is not at either end of the range,
//   - the window has texture (grey-level standard deviation >= min_texture),
//   - the epipolar segment of the depth range is >= min_epipolar_px long in some view (pixels
//     near the epipole of a forward-moving camera have no parallax, so no depth),
//   - at least min_views views see the whole window at the best depth.
// The inverse depth is refined to sub-sample precision by the parabola through the best sample
// and its neighbours. Everything else is 0 (no depth).
//
//   PlaneSweepOptions options;
//   std::vector<StereoView> views = {{&image_prev, prev_from_ref}, {&image_next, next_from_ref}};
//   PlaneSweepResult r = PlaneSweepDepth(image_ref, camera, views, options);
//
// Two users: `dfo_eval stereo-depth` makes reference depth of real frames from their
// ground-truth poses with it (for depth metrics; ground truth never enters a training loss
// through it), and the keyframe stereo (dfo_backend/keyframe_stereo.h) matches each new keyframe
// against the frames before it at the system's own poses.
#ifndef DFO_CORE_PLANE_SWEEP_H_
#define DFO_CORE_PLANE_SWEEP_H_

#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"
#include "dfo_core/lie.h"

namespace dfo {

struct PlaneSweepOptions {
  double min_depth_m = 2.0;       // nearest depth tried, > 0
  double max_depth_m = 120.0;     // farthest depth tried, > min_depth_m
  int num_depths = 192;           // inverse-depth samples, uniform in 1 / depth, >= 8
  int window_radius = 3;          // ZNCC window half side in pixels, >= 1
  double max_cost = 0.3;          // largest accepted 1 - mean ZNCC, in (0, 2]
  double uniqueness = 1.5;        // second local minimum / best, >= 1
  double min_texture = 4.0;       // smallest grey-level standard deviation of the window, >= 0
  double min_epipolar_px = 20.0;  // shortest epipolar segment of the depth range, >= 0
  int min_views = 2;              // fewest views that must see the window, >= 1
  int num_threads = 1;            // worker threads (the result does not depend on it), >= 1

  // Throws dfo::ConfigError naming the field, its value and the rule.
  void Check() const;
};

// A neighbouring view: its grey image (same size and camera as the reference) and its pose
// relative to the reference camera (view_from_ref maps reference-camera points into the view).
struct StereoView {
  const ImageF* image = nullptr;
  SE3d view_from_ref;
};

struct PlaneSweepResult {
  ImageF depth;                   // metres, 0 = no confident depth
  double confident_fraction = 0;  // share of pixels with a depth
};

// Plane-sweep depth of `reference` (1 channel, grey levels 0-255) from `views` (file comment).
// Throws dfo::InputError when an image is missing, has another size than the camera, or more
// than one channel.
PlaneSweepResult PlaneSweepDepth(const ImageF& reference, const PinholeCamera& camera,
                                 const std::vector<StereoView>& views,
                                 const PlaneSweepOptions& options);

}  // namespace dfo

#endif  // DFO_CORE_PLANE_SWEEP_H_
