// The depth the tracker aligns frames with, built from what the sliding window knows (DSO's
// CoarseTracker, ../shared/DESIGN.md "Tracking against the window"):
//
//   std::vector<Eigen::Vector3d> points = window.PointsInKeyframe(newest);   // optimised points
//   TrackingDepth d = BuildTrackingDepth(source_depth, cameras, points, options);
//   if (d.from_window) frontend.SetReferenceDepth(newest, d.depth);
//
// Every window point, in the newest keyframe's camera, is projected into each pyramid level with
// that level's camera; a pixel within `splat_radius_px` of one or more projections takes the
// inverse-depth average of those points (at coarse levels several points share a pixel, as
// DSO's dilation to the coarser levels). Pixels that no window point covers take the depth
// source's map of the keyframe multiplied by `scale`, the median over the window points of
// (window depth) / (source depth at the point's pixel): the source's shape at the window's scale
// (fill "scaled_source"), or stay invalid (fill "none": only window points, as DSO).
#ifndef DFO_BACKEND_TRACKING_DEPTH_H_
#define DFO_BACKEND_TRACKING_DEPTH_H_

#include <Eigen/Core>
#include <string>
#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/feature_map.h"

namespace dfo {

// YAML section "tracker" (keys depth, depth_fill, min_window_points) and
// window.initial_depth_scale, window.source_scale. Check() names the key.
struct TrackingDepthOptions {
  // tracker.depth: "window" (after each window solve the newest keyframe is tracked against the
  // window's optimised points, filled as the file comment says) or "source" (the depth source's
  // map of the keyframe as it is). Without a window (run.mode frontend) the source is used.
  std::string depth = "window";
  // tracker.depth_fill: what pixels without a window point get: "scaled_source" or "none".
  std::string fill = "scaled_source";
  // tracker.min_window_points: fewest window points inside the newest keyframe's image for a
  // window depth (and for a scale estimate); fewer and the keyframe is tracked against its
  // source depth (scaled as below when possible). >= 1.
  int min_window_points = 50;
  // tracker.splat_radius_px: half side of the square of pixels a window point gives its depth to
  // at each level, >= 0 (1 = the 3 x 3 patch around it).
  int splat_radius_px = 1;
  // window.initial_depth_scale: where a new keyframe's points start when it enters the window:
  // "source" at the depth source's map as it is (the window's depth search and solve then bring
  // them to the window's scale by parallax), "window" at that map times the median ratio of the
  // window's points seen from the keyframe's starting pose to it. Measured on real video (KITTI
  // 03 in 100-frame pieces, docs/tracking_against_the_window.md), "window" feeds the window's
  // own scale error back into every new keyframe: the scale grew up to 7.5x in 100 frames.
  std::string initial_depth_scale = "source";
  // window.source_scale: the scale at which each new keyframe's depth map enters the window (its
  // points' start, unless initial_depth_scale is "window", and its depth prior's centre): "raw",
  // the depth source's own scale; "run_median", that map times the median, over every keyframe
  // of the run so far, of the window-to-source ratio seen from the keyframe (the `window_scale`
  // of KeyframeRecord). With "raw" the prior anchors the window at the source's scale while the
  // window's geometry holds it elsewhere (the window's depth over a network's is 1.1-1.6 on
  // KITTI), and the two pull against each other by as much as each stretch's geometry allows;
  // "run_median" keeps the source's shape and its change of scale from image to image and
  // anchors the window at the source's scale times one calibration factor, robust to single
  // keyframes and fixed once the run is long. A factor over the recent keyframes only (the last
  // 30 or 100) follows the window's own drift and lets it run away (docs/window.md). "window",
  // that map times the keyframe's own window-to-source ratio: the window's scale is carried from
  // keyframe to keyframe by the points they share, as DSO carries it, and the source gives only
  // the shape (its per-image scale no longer reaches the window); on real video the ratio jumps
  // where the keyframe sees few or only far window points (docs/window.md).
  std::string source_scale = "raw";
  // window.rescale_source_steps: a frame tracked against its keyframe's source depth (tracker.depth
  // "source", or a keyframe that fell back to it) gets, in the windowed trajectory, its
  // translation from the keyframe multiplied by the median ratio of the window's depth to that
  // depth over the window's points seen from the keyframe after its solve: the frame's step is
  // then in the scale of the keyframe's windowed pose, as the steps between keyframes are. Off,
  // the step keeps the source's scale (frames between keyframes then zigzag where the window's
  // scale differs from the source's). Frames tracked against the window's depth need no factor.
  bool rescale_source_steps = true;

  void Check() const;
};

// The result of BuildTrackingDepth.
struct TrackingDepth {
  DepthPyramid depth;            // levels as the source pyramid (m, 0 = invalid)
  int num_points = 0;            // window points projecting inside the finest level
  double scale = 0.0;            // median (window depth / source depth); 0 when unknown
  std::vector<uint8_t> covered;  // finest level, row-major: 1 where a window point gave the depth
  bool from_window = false;      // false: too few points (depth is empty)
  std::string note;              // why from_window is false
};

// Median over `points` (camera frame of the keyframe) that project inside `camera` onto a valid
// depth of `depth` (same size as the camera) of z / depth there; 0 when fewer than min_pairs
// points pair up.
double WindowToSourceScale(const std::vector<Eigen::Vector3d>& points, const ImageF& depth,
                           const PinholeCamera& camera, int min_pairs);

// Builds the tracking depth (file comment). `cameras[l]` is level l's camera (size of
// source.levels[l]); needs cameras.size() >= source.num_levels(). Never throws on data: a result
// with from_window = false says why.
TrackingDepth BuildTrackingDepth(const DepthPyramid& source,
                                 const std::vector<PinholeCamera>& cameras,
                                 const std::vector<Eigen::Vector3d>& points,
                                 const TrackingDepthOptions& options);

}  // namespace dfo

#endif  // DFO_BACKEND_TRACKING_DEPTH_H_
