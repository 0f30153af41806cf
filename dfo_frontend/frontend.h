// The frontend: per frame, feature and depth pyramids, then frame-to-reference tracking with the
// direct feature-metric tracker (tracker.h), a simple reference-switch rule, a constant-velocity
// motion model and recovery after a loss. Synchronous and deterministic.
//
//   FrontendOptions options;            // hand-made features, ground-truth depth
//   Frontend frontend(options);
//   for (const Frame& frame : frames) {
//     TrackedFrame tracked = frontend.Process(frame);   // pose + status of every frame
//   }
//
// With options.reference.policy = "external" the caller decides the reference switch (the
// backend's keyframe manager in dfo_run): after Process, MakeLastFrameReference makes the frame
// just processed the reference and hands out its KeyframeData; the tracker then tracks against it.
#ifndef DFO_FRONTEND_FRONTEND_H_
#define DFO_FRONTEND_FRONTEND_H_

#include <memory>
#include <string>

#include "dfo_core/frame.h"
#include "dfo_core/keyframe.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/reference_options.h"
#include "dfo_frontend/tracker.h"

namespace dfo {

// Options of the frontend (YAML section "frontend"; nested structs are sub-sections).
struct FrontendOptions {
  // Feature source name: "handmade" (HandmadeFeatureSource) or "learned" (the feature network of
  // a model file; the application loads the model and passes the source to the Frontend
  // constructor, see dfo_frontend/learned/learned_sources.h).
  std::string features = "handmade";
  // Depth source name: "gt" (Frame::depth_m) or "learned" (the depth network of a model file,
  // passed to the constructor like the learned features).
  std::string depth = "gt";
  // Options of the hand-made features (used when features == "handmade").
  HandmadeFeatureOptions handmade;
  // The tracker (levels, patches, iterations, hypotheses, status thresholds).
  TrackerOptions tracker;
  // When a tracked frame becomes the new reference.
  ReferenceOptions reference;
  // Depth scale of a new reference: "none" takes the depth source's maps as they are;
  // "propagate" rescales a new reference's depth pyramid by the median over the old reference's
  // points of (their depth moved into the new frame by the tracked pose) / (the new map's depth at
  // their projection), so that the scale carries over from reference to reference (monocular
  // networks give each image its own scale). The first reference, and a restart after a loss,
  // keep the source's scale. Measured on the demo sequence with the default model (a reference
  // every ~3 frames): propagate 23.0 m Sim3 ATE against 9.8 m with none, the per-switch ratio
  // noise compounding as a random walk, so "none" is the default.
  std::string depth_scale = "none";
  // A frame whose tracking against the reference is lost is tracked again against the previous
  // frame (when that one was tracked and has depth), which then becomes the reference
  // (TrackedFrame::retracked_from; the Frontend hands its keyframe data out through
  // TakeRetrackKeyframe). Without it the lost frame keeps the last good pose and the next frame
  // restarts from it, so the motion of the lost frames is missing from the trajectory.
  bool retrack_on_loss = true;
  // A frame tracked with an RMS residual above this times that of the first frame tracked
  // against the reference (the keyframe residual rule's test, DSO's 2x) is tracked again against
  // the previous frame in the same way, and the result that fits better is kept: a frame that
  // has drifted into a wrong minimum (repeated texture, near points leaving the view) is not
  // made a keyframe with its wrong pose. >= 1; 0 = off.
  double retrack_residual_ratio = 2.0;
  // Threads for the frontend's own work, >= 1. The tracker is currently single-threaded (its
  // per-level problems are small); the value is validated and kept for the learned sources.
  int num_threads = 1;

  // Throws ConfigError naming the field, its value and the rule (nested options included, e.g.
  // "frontend.tracker.patch_size = 4 violates odd").
  void Check() const;
};

// Wall time of the stages of the last Process call, milliseconds.
struct FrontendTimings {
  double features_ms = 0.0;  // feature pyramid
  // Depth pyramid: only a frame that becomes a reference needs one (made by Process or
  // MakeLastFrameReference, whose time counts here for the last frame); 0 for the others.
  double depth_ms = 0.0;
  double tracking_ms = 0.0;  // alignment, including setting a new reference (points, Jacobians)
};

// Frame-to-reference visual odometry frontend.
class Frontend {
 public:
  // Throws ConfigError on bad options (FrontendOptions::Check, unknown source names, and
  // "learned" sources: those need the constructor below).
  explicit Frontend(const FrontendOptions& options);
  // With sources made by the caller (e.g. the learned ones, which need a loaded model). A null
  // source is created by name from options.features / options.depth as in the constructor
  // above; a given source is used whatever the name says (the names are then only labels, but
  // must still pass FrontendOptions::Check).
  Frontend(const FrontendOptions& options, std::unique_ptr<FeatureSource> features,
           std::unique_ptr<DepthSource> depth);
  ~Frontend();
  Frontend(const Frontend&) = delete;
  Frontend& operator=(const Frontend&) = delete;

  // Processes the next frame. Tracking failure is a status (kLost: the pose stays at the last
  // good pose and the next frame becomes a fresh reference, status kReference), never a throw.
  // Bad input throws InputError naming the frame index: an empty image, an image whose size
  // differs from the camera's, a depth map of another size, a missing depth map when the depth
  // source is "gt", a camera that differs from the reference's; the sources' own InputErrors
  // (e.g. a frame size the learned model does not accept) pass through.
  TrackedFrame Process(const Frame& frame);

  // Makes the frame of the last Process call the reference that the following frames are tracked
  // against (in either policy; with "external" this is the only switch besides the automatic
  // first/restart reference) and fills `keyframe` (may be null) with its index, time, pose
  // (TrackedFrame::world_from_cam) and the feature and depth pyramids it was processed with
  // (hand-made features with their keyframe blur, HandmadeFeatureOptions).
  // When the last frame already is the reference (status kReference, is_new_reference, or a
  // repeated call), nothing is switched and its data are returned. Returns false, switching
  // nothing, when there was no frame, the last frame was lost, or its depth is too sparse for a
  // reference (fewer valid depths than the tracker's minimum points x patch pixels); returns
  // false as well when the switch was tried but selected too few points: then the tracker has no
  // reference and the next frame restarts (status kReference).
  bool MakeLastFrameReference(KeyframeData* keyframe);

  // After a Process call whose frame was re-tracked (TrackedFrame::retracked_from >= 0): the
  // keyframe data of the frame that became the reference then, as MakeLastFrameReference gives
  // them. Returns false (keyframe untouched) when the last Process call did not re-track.
  bool TakeRetrackKeyframe(KeyframeData* keyframe);

  // Replaces the depth the tracker uses for the current reference, which must be frame
  // `frame_index` (e.g. the depths a sliding window optimised, projected into that keyframe,
  // DSO's tracking depth): the reference's points and Jacobians are rebuilt from its kept feature
  // pyramid and `depth` (levels and sizes as the frame's own depth pyramid), and the following
  // frames are tracked against them. Returns false, changing nothing, when frame_index is not the
  // current reference or `depth` selects fewer points than a reference needs (then the reference
  // keeps the depth it had). Throws InputError when the pyramid's levels or sizes do not match.
  bool SetReferenceDepth(int frame_index, const DepthPyramid& depth);
  // The depth pyramid the current reference was made with by the depth source (before any
  // SetReferenceDepth); empty without a reference.
  const DepthPyramid& reference_source_depth() const;

  // Timings of the last Process call.
  const FrontendTimings& last_timings() const;
  // Forgets the reference, the motion model and the pose (the next frame starts at identity).
  void Reset();

  const FrontendOptions& options() const;
  // The tracker (its current reference's points, for diagnostics).
  const Tracker& tracker() const { return tracker_; }

 private:
  struct State;
  // Fewest finest-level points of a usable reference, and fewest valid finest-level depths a
  // frame needs before a switch to it is tried.
  int MinReferencePoints() const;
  // Whether a new reference's depth is rescaled (FrontendOptions::depth_scale and the source).
  bool PropagatesDepthScale() const;
  // Median over the current reference's finest-level points of (their depth moved by
  // cam_from_ref) / (`depth`'s finest-level value at their projection with `camera`); 0 when
  // fewer than 20 points pair up.
  double DepthScaleFromReference(const DepthPyramid& depth, const SE3d& cam_from_ref,
                                 const PinholeCamera& camera) const;
  int MinReferenceDepths() const;
  // The depth source's pyramid of `frame`, its time added to timings_.depth_ms.
  DepthPyramid ComputeDepth(const Frame& frame);
  FrontendOptions options_;
  std::unique_ptr<FeatureSource> features_;
  // Features of the keyframes handed to the window when they differ from the tracker's
  // (HandmadeFeatureOptions::keyframe_blur_sigma_px); null: the tracker's.
  std::unique_ptr<FeatureSource> keyframe_features_;
  std::unique_ptr<DepthSource> depth_;
  Tracker tracker_;
  std::unique_ptr<State> state_;
  FrontendTimings timings_;
};

}  // namespace dfo

#endif  // DFO_FRONTEND_FRONTEND_H_
