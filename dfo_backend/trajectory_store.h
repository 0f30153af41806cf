// Per-frame poses of a run with a sliding window: every frame's pose is kept relative to the
// keyframe it was tracked against, so that when bundle adjustment moves a keyframe, the frames
// tracked against it move with it. One store holds two trajectories built from the SAME frontend
// outputs:
//   frontend-only  frame pose = frontend pose of its keyframe  * kf_from_frame
//   windowed       frame pose = windowed pose of its keyframe  * kf_from_frame
// where a keyframe's frontend pose is the frontend's own estimate and its windowed pose starts at
// (windowed pose of the keyframe it was tracked against) * kf_from_frame and then follows the
// backend (SetWindowedPose). Deterministic; no I/O.
#ifndef DFO_BACKEND_TRAJECTORY_STORE_H_
#define DFO_BACKEND_TRAJECTORY_STORE_H_

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "dfo_core/lie.h"
#include "dfo_core/trajectory.h"

namespace dfo {

class TrajectoryStore {
 public:
  // Adds frame `frame_index` (strictly increasing from call to call, across AddFrame and
  // AddKeyframe) tracked against keyframe `keyframe_index` (already in the store as a keyframe)
  // with pose kf_from_frame (TrackedFrame::ref_from_cam). keyframe_index = -1 (no keyframe yet,
  // e.g. a lost first frame): kf_from_frame is the frame's world pose in both trajectories.
  // scale_step: in the windowed trajectory the translation of kf_from_frame is multiplied by the
  // keyframe's step scale as it is now (SetWindowedStepScale; kept for the frame when the scale
  // changes later), for a frame tracked against a depth whose scale is not the window's. Throws
  // InternalError on an index out of order or an unknown keyframe.
  void AddFrame(int frame_index, int64_t timestamp_ns, int keyframe_index,
                const SE3d& kf_from_frame, bool scale_step = false);

  // Adds frame `frame_index` as a keyframe that was not tracked against one (the first frame, a
  // restart after a loss) with the frontend's pose for it. Its relation to the previous keyframe
  // is taken from the frontend poses, so its windowed pose starts at
  // windowed(previous keyframe) * frontend(previous keyframe)^-1 * frontend_world_from_cam
  // (the frontend pose itself when it is the first keyframe).
  void AddKeyframe(int frame_index, int64_t timestamp_ns, const SE3d& frontend_world_from_cam);

  // Makes the frame added last (by AddFrame, with a keyframe) a keyframe: frontend pose =
  // frontend(its keyframe) * kf_from_frame, windowed pose = windowed(its keyframe) *
  // kf_from_frame. Throws InternalError when frame_index is not the frame added last, or it has
  // no keyframe.
  void PromoteToKeyframe(int frame_index);

  // Sets the windowed pose of keyframe `frame_index` (after bundle adjustment): every frame
  // tracked against it follows. Throws InternalError when it is not a keyframe.
  void SetWindowedPose(int frame_index, const SE3d& world_from_kf);

  // Sets keyframe `frame_index`'s step scale (1 until set): the factor on the translation of
  // kf_from_frame, in the windowed trajectory, of the frames added after this call with
  // scale_step and tracked against it (the window's depth over the depth they were tracked
  // against, so that their steps from the keyframe are in the scale of the keyframe's windowed
  // pose). Frames added before keep theirs, so that a step once published does not change,
  // unless `rescale_added`: then the frames already added with scale_step against the keyframe
  // (and not promoted since) take it too (a solve that finished after frames were tracked
  // against the same depth as the frames after it: the backend thread). A frame promoted to
  // keyframe keeps its scaled step in its windowed pose. Throws InternalError when it is not a
  // keyframe or the factor is not finite and positive.
  void SetWindowedStepScale(int frame_index, double scale, bool rescale_added = false);

  bool Contains(int frame_index) const;
  bool IsKeyframe(int frame_index) const;
  // Pose of a stored frame in either trajectory (InternalError when not stored).
  SE3d FrontendPose(int frame_index) const;
  SE3d WindowedPose(int frame_index) const;
  // A non-keyframe's pose relative to its keyframe in the windowed trajectory (kf_from_frame
  // with its step scale); identity for a keyframe, the absolute pose without a keyframe.
  SE3d WindowedStep(int frame_index) const;

  // Every frame, in order.
  Trajectory FrontendTrajectory() const;
  Trajectory WindowedTrajectory() const;
  // The keyframes only, in order, with their windowed (or frontend) poses.
  Trajectory KeyframeTrajectory(bool windowed = true) const;
  // Frame indices of the keyframes, in order.
  std::vector<int> KeyframeIndices() const;

  int num_frames() const { return static_cast<int>(frames_.size()); }
  int num_keyframes() const { return num_keyframes_; }

 private:
  struct Entry {
    int frame_index = 0;
    int64_t timestamp_ns = 0;
    int keyframe_index = -1;  // the keyframe tracked against; -1 = none (then pose is absolute)
    SE3d kf_from_frame;       // pose relative to that keyframe (or world pose without one)
    double step_scale = 1.0;  // windowed: the factor on kf_from_frame's translation
    bool scale_step = false;  // AddFrame's scale_step
    bool is_keyframe = false;
    SE3d frontend_world_from_kf;       // keyframes: the frontend's pose
    SE3d windowed_world_from_kf;       // keyframes: the backend's pose
    double windowed_step_scale = 1.0;  // keyframes: SetWindowedStepScale
  };
  const Entry& Get(int frame_index) const;
  Entry& GetMutable(int frame_index);
  void Append(const Entry& entry);
  SE3d Pose(const Entry& e, bool windowed) const;
  // kf_from_frame of `e` in the windowed trajectory (its translation times e.step_scale).
  static SE3d ScaledStep(const Entry& e);

  std::vector<Entry> frames_;
  std::unordered_map<int, size_t> position_;  // frame index -> position in frames_
  int num_keyframes_ = 0;
  int last_keyframe_ = -1;  // frame index of the newest keyframe
};

}  // namespace dfo

#endif  // DFO_BACKEND_TRAJECTORY_STORE_H_
