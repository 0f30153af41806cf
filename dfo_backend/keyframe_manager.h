// The keyframe manager: decides, frame by frame, when the frame just tracked becomes the next
// keyframe (the frame the tracker then tracks against and the backend's window receives).
//
// Rules (DESIGN.md, backend; LSD-SLAM's depth-normalised distance, DSO's residual growth):
// a tracked frame becomes a keyframe when any of these fires, checked in this order,
//   translation  |t_kf->cur| / d(kf)           >  translation_ratio, d(kf) = 1 / mean inverse
//                                                 depth of the keyframe's tracked points
//   rotation     angle(R_kf->cur)              >  rotation_deg
//   residual     rmse                          >  residual_ratio x rmse of the first frame
//                                                 tracked after the keyframe
//   inliers      num_inliers / num_points      <  min_inlier_ratio
//   interval     frames since the keyframe     >= max_interval
// and none fires before min_interval frames have passed since the keyframe. The exception is a
// loss: a frame the frontend restarted from (status kReference, after a lost frame or the first
// frame) is always a keyframe. A lost frame itself never is (its pose is only the last good one).
//
//   KeyframeManager manager(options);
//   TrackedFrame tracked = frontend.Process(frame);
//   if (manager.Decide(tracked).new_keyframe && frontend.MakeLastFrameReference(&keyframe))
//     manager.AcceptKeyframe(tracked.index);
#ifndef DFO_BACKEND_KEYFRAME_MANAGER_H_
#define DFO_BACKEND_KEYFRAME_MANAGER_H_

#include "dfo_core/frame.h"

namespace dfo {

// Thresholds of the keyframe rules (YAML section "keyframe").
struct KeyframeOptions {
  // New keyframe when the distance from the keyframe divided by the keyframe's parallax depth
  // (TrackedFrame::reference_parallax_depth: 1 / mean inverse depth of its tracked points, so
  // near points count as much as they move in the image) exceeds this; > 0.
  double translation_ratio = 0.10;
  // New keyframe when the rotation from the keyframe exceeds this many degrees; in (0, 180].
  double rotation_deg = 5.0;
  // New keyframe when the tracking RMS residual exceeds this multiple of the RMS residual of the
  // first frame tracked after the keyframe; >= 1 (DSO uses 2).
  double residual_ratio = 2.0;
  // New keyframe when the finest-level inlier ratio (inliers / points) falls below this; in
  // [0, 1] (0 disables the rule).
  double min_inlier_ratio = 0.5;
  // No keyframe (except after a loss) fewer than this many frames after the last; >= 1
  // (1 = the next frame may already be one).
  int min_interval = 1;
  // New keyframe at the latest this many frames after the last; >= min_interval.
  int max_interval = 10;

  // Throws ConfigError naming the key, its value and the rule, e.g.
  // "keyframe.translation_ratio = -0.1 violates > 0" or
  // "keyframe.min_interval = 12 violates <= keyframe.max_interval (10)".
  void Check() const;
};

// Which rule made a keyframe.
enum class KeyframeReason {
  kNone,         // no keyframe
  kRestart,      // first frame, or the frontend restarted from it after a loss
  kTranslation,  // translation_ratio
  kRotation,     // rotation_deg
  kResidual,     // residual_ratio
  kInlierRatio,  // min_inlier_ratio
  kMaxInterval,  // max_interval
  kRetrack,      // the next frame was lost against the keyframe before and tracked against this
                 // one (FrontendOptions::retrack_on_loss)
};

// "none", "restart", "translation", "rotation", "residual", "inlier_ratio", "max_interval",
// "retrack".
const char* KeyframeReasonName(KeyframeReason reason);

// The decision for one frame and the quantities it was made from.
struct KeyframeDecision {
  bool new_keyframe = false;
  KeyframeReason reason = KeyframeReason::kNone;
  int frames_since_keyframe = 0;   // this frame's distance in frames from the current keyframe
  double translation_ratio = 0.0;  // |t_kf->cur| / parallax depth of kf (0: depth unknown)
  double rotation_deg = 0.0;       // angle of R_kf->cur in degrees
  double residual_ratio = 0.0;     // rmse / first rmse after the keyframe (0 when unknown)
  double inlier_ratio = 1.0;       // num_inliers / num_points (1 when no points)
};

// Applies the keyframe rules to the frontend's tracked frames. Deterministic, no I/O.
class KeyframeManager {
 public:
  // Throws ConfigError when options.Check() fails.
  explicit KeyframeManager(const KeyframeOptions& options);

  // The decision for `frame`, the next frame in sequence order (tracked against the current
  // keyframe: TrackedFrame::ref_from_cam, reference_parallax_depth, rmse, inliers). Updates the
  // frame count and the first residual after the keyframe. A frame tracked against another
  // reference than the current keyframe (the frontend switched on its own) is taken as the
  // keyframe's replacement: the counters restart from that reference.
  KeyframeDecision Decide(const TrackedFrame& frame);

  // Tells the manager that frame `frame_index` (the last frame passed to Decide) is now the
  // keyframe: the counters restart. Call it only when the frontend really switched (a frame
  // whose depth is too sparse cannot become a keyframe; the rules then fire again next frame).
  void AcceptKeyframe(int frame_index);

  // Frame index of the current keyframe; -1 before the first.
  int keyframe_index() const { return keyframe_index_; }
  // Number of keyframes accepted so far.
  int num_keyframes() const { return num_keyframes_; }
  const KeyframeOptions& options() const { return options_; }

 private:
  KeyframeOptions options_;
  int keyframe_index_ = -1;
  int num_keyframes_ = 0;
  int frames_since_keyframe_ = 0;
  double first_rmse_ = -1.0;  // rmse of the first frame tracked after the keyframe; < 0: none yet
};

}  // namespace dfo

#endif  // DFO_BACKEND_KEYFRAME_MANAGER_H_
