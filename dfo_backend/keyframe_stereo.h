// A new keyframe's depth from the frames before it: multi-view stereo on the window's poses.
//
// The depth source (a network on real video) gives each keyframe a single image's depth, off by
// a different factor for near and far things (docs/tracking_against_the_window.md). Where the
// keyframe and the frames just before it, at the poses the system has estimated for them, agree
// on a depth by plane-sweep stereo (dfo_core/plane_sweep.h: ZNCC, confident pixels only), that
// depth replaces the source's; elsewhere the source's stays. The stereo depth is in the window's
// scale (the poses' scale); it is divided by the keyframe's window/source ratio so that the map
// stays in the source's scale for everything downstream (the window's new points and its depth
// prior, the tracker, the windowed step scale). This is the geometry-first depth of DSO's
// immature points, done densely over the keyframe at its entry, with the network filling what
// geometry cannot tell.
//
//   KeyframeStereoResult r =
//       ApplyKeyframeStereo(grey, camera, views, window_scale, options, &keyframe_depth);
#ifndef DFO_BACKEND_KEYFRAME_STEREO_H_
#define DFO_BACKEND_KEYFRAME_STEREO_H_

#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/feature_map.h"
#include "dfo_core/plane_sweep.h"

namespace dfo {

// YAML section "stereo". Check() names the key.
struct KeyframeStereoOptions {
  // stereo.views: how many of the frames before a new keyframe it is matched against (their
  // windowed poses); 0 = off. Needs a window (the scale of its poses).
  int views = 0;
  // stereo.depth_samples: inverse depths tried, between 1/12 and 8 times the inverse of the
  // source's median depth at the window's scale.
  int depth_samples = 64;
  // stereo.window_radius: half side of the ZNCC window in pixels.
  int window_radius = 2;
  // stereo.min_epipolar_px: a pixel gets a stereo depth only when its depth range spans at least
  // this many pixels in some view (no parallax near the epipole of a forward-moving camera).
  double min_epipolar_px = 7.0;
  // stereo.max_cost: largest accepted 1 - mean ZNCC.
  double max_cost = 0.3;
  // stereo.uniqueness: the second local minimum costs at least this times the best.
  double uniqueness = 1.5;
  // stereo.max_source_ratio: a stereo depth more than this factor from the source's (at the
  // window's scale) is not taken; 0 = no such limit.
  double max_source_ratio = 0.0;
  // run.threads: threads of the plane sweep (its result does not depend on them), >= 1.
  int num_threads = 1;

  bool enabled() const { return views > 0; }
  void Check() const;
};

// What ApplyKeyframeStereo did.
struct KeyframeStereoResult {
  int num_views = 0;          // views matched
  int num_replaced = 0;       // finest-level pixels whose depth now comes from the stereo
  double fraction = 0.0;      // num_replaced over the finest level's pixels
  double confident = 0.0;     // share of the pixels the stereo was confident about
  double milliseconds = 0.0;  // wall time of the whole call (the plane sweep most of it)
};

// Replaces the finest level of *depth (source scale, metres; coarser levels rebuilt from it as
// the depth sources do) by the stereo depth of `reference` (grey, the finest level's size and
// `camera`) against `views`, divided by window_scale (window depth / source depth, > 0), where
// the stereo is confident (file comment). Fewer than 2 views or no valid source depth: nothing
// changes (num_views says how many were given). Throws dfo::InputError on images of the wrong
// size (dfo_core/plane_sweep.h).
KeyframeStereoResult ApplyKeyframeStereo(const ImageF& reference, const PinholeCamera& camera,
                                         const std::vector<StereoView>& views, double window_scale,
                                         const KeyframeStereoOptions& options, DepthPyramid* depth);

}  // namespace dfo

#endif  // DFO_BACKEND_KEYFRAME_STEREO_H_
