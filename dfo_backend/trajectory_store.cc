#include "dfo_backend/trajectory_store.h"

#include <cmath>

#include "dfo_core/error.h"

namespace dfo {

const TrajectoryStore::Entry& TrajectoryStore::Get(int frame_index) const {
  const auto it = position_.find(frame_index);
  DFO_CHECK(it != position_.end()) << "frame " << frame_index << " is not in the store";
  return frames_[it->second];
}

TrajectoryStore::Entry& TrajectoryStore::GetMutable(int frame_index) {
  const auto it = position_.find(frame_index);
  DFO_CHECK(it != position_.end()) << "frame " << frame_index << " is not in the store";
  return frames_[it->second];
}

void TrajectoryStore::Append(const Entry& entry) {
  DFO_CHECK(frames_.empty() || entry.frame_index > frames_.back().frame_index)
      << "frame " << entry.frame_index << " added after frame " << frames_.back().frame_index;
  position_[entry.frame_index] = frames_.size();
  frames_.push_back(entry);
}

void TrajectoryStore::AddFrame(int frame_index, int64_t timestamp_ns, int keyframe_index,
                               const SE3d& kf_from_frame, bool scale_step) {
  if (keyframe_index >= 0) {
    DFO_CHECK(IsKeyframe(keyframe_index)) << "frame " << frame_index << " tracked against frame "
                                          << keyframe_index << ", which is not a keyframe";
  }
  Entry e;
  e.frame_index = frame_index;
  e.timestamp_ns = timestamp_ns;
  e.keyframe_index = keyframe_index;
  e.kf_from_frame = kf_from_frame;
  e.scale_step = scale_step && keyframe_index >= 0;
  if (e.scale_step) e.step_scale = Get(keyframe_index).windowed_step_scale;
  Append(e);
}

void TrajectoryStore::AddKeyframe(int frame_index, int64_t timestamp_ns,
                                  const SE3d& frontend_world_from_cam) {
  Entry e;
  e.frame_index = frame_index;
  e.timestamp_ns = timestamp_ns;
  e.is_keyframe = true;
  e.frontend_world_from_kf = frontend_world_from_cam;
  if (last_keyframe_ >= 0) {
    // Carry the frontend's relation to the previous keyframe over to the windowed trajectory.
    const Entry& prev = Get(last_keyframe_);
    e.windowed_world_from_kf = prev.windowed_world_from_kf *
                               (prev.frontend_world_from_kf.Inverse() * frontend_world_from_cam);
  } else {
    e.windowed_world_from_kf = frontend_world_from_cam;
  }
  Append(e);
  ++num_keyframes_;
  last_keyframe_ = frame_index;
}

void TrajectoryStore::PromoteToKeyframe(int frame_index) {
  DFO_CHECK(!frames_.empty() && frames_.back().frame_index == frame_index)
      << "frame " << frame_index << " is not the frame added last";
  Entry& e = frames_.back();
  if (e.is_keyframe) return;
  DFO_CHECK(e.keyframe_index >= 0) << "frame " << frame_index << " has no keyframe";
  const Entry& kf = Get(e.keyframe_index);
  e.frontend_world_from_kf = kf.frontend_world_from_kf * e.kf_from_frame;
  e.windowed_world_from_kf = kf.windowed_world_from_kf * ScaledStep(e);
  e.is_keyframe = true;
  ++num_keyframes_;
  last_keyframe_ = frame_index;
}

void TrajectoryStore::SetWindowedPose(int frame_index, const SE3d& world_from_kf) {
  Entry& e = GetMutable(frame_index);
  DFO_CHECK(e.is_keyframe) << "frame " << frame_index << " is not a keyframe";
  e.windowed_world_from_kf = world_from_kf;
}

void TrajectoryStore::SetWindowedStepScale(int frame_index, double scale, bool rescale_added) {
  Entry& e = GetMutable(frame_index);
  DFO_CHECK(e.is_keyframe) << "frame " << frame_index << " is not a keyframe";
  DFO_CHECK(std::isfinite(scale) && scale > 0.0)
      << "step scale " << scale << " of keyframe " << frame_index << " is not positive";
  e.windowed_step_scale = scale;
  if (!rescale_added) return;
  for (size_t i = position_.at(frame_index) + 1; i < frames_.size(); ++i) {
    Entry& f = frames_[i];
    if (!f.is_keyframe && f.scale_step && f.keyframe_index == frame_index) f.step_scale = scale;
  }
}

SE3d TrajectoryStore::ScaledStep(const Entry& e) {
  if (e.step_scale == 1.0) return e.kf_from_frame;
  return SE3d(e.kf_from_frame.so3(), e.step_scale * e.kf_from_frame.translation());
}

SE3d TrajectoryStore::WindowedStep(int frame_index) const {
  const Entry& e = Get(frame_index);
  if (e.is_keyframe) return SE3d();
  return e.keyframe_index < 0 ? e.kf_from_frame : ScaledStep(e);
}

bool TrajectoryStore::Contains(int frame_index) const { return position_.count(frame_index) > 0; }

bool TrajectoryStore::IsKeyframe(int frame_index) const {
  const auto it = position_.find(frame_index);
  return it != position_.end() && frames_[it->second].is_keyframe;
}

SE3d TrajectoryStore::Pose(const Entry& e, bool windowed) const {
  if (e.is_keyframe) return windowed ? e.windowed_world_from_kf : e.frontend_world_from_kf;
  if (e.keyframe_index < 0) return e.kf_from_frame;
  const Entry& kf = Get(e.keyframe_index);
  return windowed ? kf.windowed_world_from_kf * ScaledStep(e)
                  : kf.frontend_world_from_kf * e.kf_from_frame;
}

SE3d TrajectoryStore::FrontendPose(int frame_index) const { return Pose(Get(frame_index), false); }

SE3d TrajectoryStore::WindowedPose(int frame_index) const { return Pose(Get(frame_index), true); }

Trajectory TrajectoryStore::FrontendTrajectory() const {
  Trajectory t;
  for (const Entry& e : frames_) t.Add(e.timestamp_ns, Pose(e, false));
  return t;
}

Trajectory TrajectoryStore::WindowedTrajectory() const {
  Trajectory t;
  for (const Entry& e : frames_) t.Add(e.timestamp_ns, Pose(e, true));
  return t;
}

Trajectory TrajectoryStore::KeyframeTrajectory(bool windowed) const {
  Trajectory t;
  for (const Entry& e : frames_) {
    if (e.is_keyframe) t.Add(e.timestamp_ns, Pose(e, windowed));
  }
  return t;
}

std::vector<int> TrajectoryStore::KeyframeIndices() const {
  std::vector<int> out;
  for (const Entry& e : frames_) {
    if (e.is_keyframe) out.push_back(e.frame_index);
  }
  return out;
}

}  // namespace dfo
