// Types where the frontend and the backend meet (Eigen only): an input frame at the working
// resolution, and the frontend's result for it.
#ifndef DFO_CORE_FRAME_H_
#define DFO_CORE_FRAME_H_

#include <cstdint>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"
#include "dfo_core/lie.h"

namespace dfo {

// One input frame at the working resolution.
struct Frame {
  int index = 0;             // frame number in the sequence, 0-based
  int64_t timestamp_ns = 0;  // time of the frame in nanoseconds
  ImageU8 image;             // gray (1 channel) or RGB (3 channels), size camera.width x height
  ImageF depth_m;            // optional depth in metres (ground truth), same size as image,
                             // 0 (or non-finite) = invalid; empty = no depth
  PinholeCamera camera;      // intrinsics at the working resolution
};

// What happened to a frame in the frontend.
enum class TrackingStatus {
  kOk,        // tracked against the reference, all quality thresholds met
  kDegraded,  // tracked, but inlier count / ratio or residual is worse than the "ok" thresholds
  kLost,      // tracking failed (too few inliers, residual too high, non-finite pose, no depth):
              // the pose is the last good pose, the next frame starts a fresh reference
  kReference  // the frame became a (new) reference without being tracked (first frame, restart
              // after a loss); its pose is the last good pose (identity for the first frame)
};

// "ok", "degraded", "lost", "reference".
const char* TrackingStatusName(TrackingStatus status);

// Why a frame is lost (TrackingStatus::kLost).
enum class LostCause {
  kNone,       // not lost
  kTracking,   // tracked against the reference, but too few inliers, too high a residual or a
               // non-finite pose
  kNoDepth,    // no reference to track against, and this frame cannot start one: its depth has
               // too few valid pixels (a depth map of zeros or NaN)
  kFewPoints,  // the same, with valid depth but too few selectable (textured) points
};

// "", "tracking", "no_depth", "few_points".
const char* LostCauseName(LostCause cause);

// The frontend's result for one frame.
struct TrackedFrame {
  int index = 0;             // Frame::index
  int64_t timestamp_ns = 0;  // Frame::timestamp_ns
  TrackingStatus status = TrackingStatus::kLost;
  SE3d world_from_cam;            // pose estimate of this frame (camera-to-world)
  int reference_index = -1;       // index of the frame tracked against (-1: none)
  SE3d ref_from_cam;              // pose relative to that reference (reference-from-this-camera)
  bool is_new_reference = false;  // this frame is the reference for the following frames
  int num_points = 0;             // points (patches) selected in the reference at the finest level
  int num_inliers = 0;            // points kept by the outlier rule at the finest level
  double rmse = 0.0;              // final RMS residual per feature value over the inliers (z-score
                                  // units: 0 = perfect, ~1.4 = unrelated features)
  int iterations = 0;             // Gauss-Newton iterations over all levels and hypotheses
  // 1 / mean inverse depth of the reference's tracked points at the finest level (m): the
  // keyframe and reference rules divide the translation by it (Tracker::reference_parallax_depth).
  double reference_parallax_depth = 0.0;
  LostCause lost_cause = LostCause::kNone;  // why, when status is kLost
  // Tracking against reference `retracked_from` failed and the frame was tracked again against
  // the previous frame, which became the reference (reference_index); -1: no re-track.
  int retracked_from = -1;
};

}  // namespace dfo

#endif  // DFO_CORE_FRAME_H_
