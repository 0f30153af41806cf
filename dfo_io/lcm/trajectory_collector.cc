#include "dfo_io/lcm/trajectory_collector.h"

#include <utility>

#include "dfo_core/error.h"

namespace dfo::io {

LcmTrajectoryCollector::LcmTrajectoryCollector(LcmChannels channels)
    : channels_(std::move(channels)) {}

bool LcmTrajectoryCollector::ApplyPose(const dfo::pose_t& m, std::string* error) {
  const std::string frame = "frame " + std::to_string(m.frame_index) + ": ";
  if (m.frame_index < 0) {
    *error = "negative frame_index " + std::to_string(m.frame_index);
    return false;
  }
  if (m.source != dfo::pose_t::SOURCE_FRONTEND && m.source != dfo::pose_t::SOURCE_WINDOWED) {
    *error = frame + "unknown source code " + std::to_string(m.source);
    return false;
  }
  TrackingStatus status;
  if (!FromLcmStatus(m.status, &status)) {
    *error = frame + "unknown status code " + std::to_string(m.status);
    return false;
  }
  if (m.keyframe_index < -1) {
    *error = frame + "keyframe_index " + std::to_string(m.keyframe_index) + " is below -1";
    return false;
  }
  FramePose p;
  p.timestamp_ns = m.timestamp_ns;
  p.is_keyframe = m.is_keyframe != 0;
  p.keyframe_index = m.keyframe_index;
  std::string why;
  if (!PoseFromArrays(m.position, m.orientation, &p.world_from_cam, &why)) {
    *error = frame + "world_from_cam: " + why;
    return false;
  }
  if (!PoseFromArrays(m.kf_position, m.kf_orientation, &p.kf_from_cam, &why)) {
    *error = frame + "kf_from_cam: " + why;
    return false;
  }
  if (m.source == dfo::pose_t::SOURCE_FRONTEND) {
    frontend_[m.frame_index] = p;
    ++counts_.frontend_poses;
  } else {
    windowed_[m.frame_index] = p;
    if (p.is_keyframe) windowed_keyframes_[m.frame_index] = p.world_from_cam;
    ++counts_.windowed_poses;
  }
  return true;
}

bool LcmTrajectoryCollector::ApplyKeyframes(const dfo::keyframe_batch_t& m, std::string* error) {
  // Check all before applying any: a bad batch changes nothing.
  std::vector<std::pair<int, SE3d>> poses;
  for (const dfo::keyframe_pose_t& k : m.keyframes) {
    SE3d pose;
    std::string why;
    if (k.frame_index < 0) {
      *error = "keyframe with negative frame_index " + std::to_string(k.frame_index);
      return false;
    }
    if (!PoseFromArrays(k.position, k.orientation, &pose, &why)) {
      *error = "keyframe " + std::to_string(k.frame_index) + ": " + why;
      return false;
    }
    poses.emplace_back(k.frame_index, pose);
  }
  for (const auto& [index, pose] : poses) windowed_keyframes_[index] = pose;
  ++counts_.keyframe_batches;
  return true;
}

LcmCollectorEvent LcmTrajectoryCollector::Handle(const std::string& channel, const void* data,
                                                 size_t size) {
  LcmCollectorEvent event;
  event.channel = channel;
  std::string error;
  bool ok = true;
  if (channel == channels_.pose) {
    event.kind = LcmCollectorEvent::Kind::kPose;
    ok = DecodeLcmMessage(data, size, &event.pose, &error) && ApplyPose(event.pose, &error);
  } else if (channel == channels_.keyframes) {
    event.kind = LcmCollectorEvent::Kind::kKeyframes;
    ok = DecodeLcmMessage(data, size, &event.keyframes, &error) &&
         ApplyKeyframes(event.keyframes, &error);
  } else if (channel == channels_.status) {
    event.kind = LcmCollectorEvent::Kind::kStatus;
    ok = DecodeLcmMessage(data, size, &event.status, &error);
    if (ok) {
      status_ = event.status;
      ++counts_.status;
    }
  } else if (channel == channels_.stop) {
    event.kind = LcmCollectorEvent::Kind::kStop;
    ok = DecodeLcmMessage(data, size, &event.stop, &error);
    if (ok) {
      stop_ = event.stop;
      ++counts_.stops;
    }
  } else {
    event.kind = LcmCollectorEvent::Kind::kIgnored;
    ++counts_.ignored;
  }
  if (!ok) {
    event.kind = LcmCollectorEvent::Kind::kMalformed;
    event.message = channel + ": " + error;
    ++counts_.malformed;
    ++counts_.malformed_by_channel[channel];
  }
  return event;
}

Trajectory LcmTrajectoryCollector::FrontendTrajectory() const {
  Trajectory t;
  for (const auto& [index, p] : frontend_) t.Add(p.timestamp_ns, p.world_from_cam);
  return t;
}

Trajectory LcmTrajectoryCollector::WindowedTrajectory() const {
  Trajectory t;
  for (const auto& [index, p] : windowed_) {
    SE3d pose = p.world_from_cam;
    if (p.is_keyframe) {
      const auto kf = windowed_keyframes_.find(index);
      if (kf != windowed_keyframes_.end()) pose = kf->second;
    } else if (p.keyframe_index >= 0) {
      const auto kf = windowed_keyframes_.find(p.keyframe_index);
      if (kf != windowed_keyframes_.end()) pose = kf->second * p.kf_from_cam;
    }
    t.Add(p.timestamp_ns, pose);
  }
  return t;
}

}  // namespace dfo::io
