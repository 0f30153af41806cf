// What the backend needs of a keyframe: the frontend's pose estimate when the frame became a
// keyframe and the feature and depth pyramids it was tracked with. The frontend produces it
// (Frontend::MakeLastFrameReference), the backend consumes it (WindowOptimizer::AddKeyframe);
// neither includes the other.
#ifndef DFO_CORE_KEYFRAME_H_
#define DFO_CORE_KEYFRAME_H_

#include <cstdint>

#include "dfo_core/feature_map.h"
#include "dfo_core/lie.h"

namespace dfo {

// A keyframe as handed from the frontend to the backend.
struct KeyframeData {
  int frame_index = 0;       // Frame::index of the keyframe
  int64_t timestamp_ns = 0;  // Frame::timestamp_ns
  // Camera-to-world estimate when it became a keyframe: the frontend's (Frontend::
  // MakeLastFrameReference); dfo_run hands the window the same frontend relative pose composed on
  // the bundle-adjusted pose of the keyframe it was tracked against (TrajectoryStore), so that
  // the new keyframe starts consistent with the window.
  SE3d world_from_cam;
  FeaturePyramid features;  // z-scored feature maps as tracked (planar C x H x W per level)
  DepthPyramid depth;       // depth per level (m, 0 = invalid) from the frontend's depth source
  // The window starts the keyframe's points at depth * initial_depth_scale (e.g. the source's
  // depth brought to the window's scale) and pulls them, with its depth prior, toward depth *
  // prior_depth_scale (1: the depth source's own scale, which then anchors the window's scale);
  // both > 0.
  double initial_depth_scale = 1.0;
  double prior_depth_scale = 1.0;
};

}  // namespace dfo

#endif  // DFO_CORE_KEYFRAME_H_
