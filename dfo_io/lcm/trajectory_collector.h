// Collecting a dfo run from its LCM messages (live or from an event log): every frame's
// frontend-only and windowed pose, the windowed ones kept up to date with the keyframe batches,
// the newest run status and the stop message. What dfo_lcm_listen is built on; another C++
// program can use it the same way:
//
//   LcmTrajectoryCollector collector;               // default channel names
//   // in an lcm::LCM raw subscription handler, or for each event of a log:
//   LcmCollectorEvent event = collector.Handle(channel, data, size);
//   if (event.kind == LcmCollectorEvent::Kind::kMalformed) { /* report event.message */ }
//   ...
//   Trajectory windowed = collector.WindowedTrajectory();   // equals dfo_run's windowed_tum.txt
//
// Messages that are not what their channel promises (another type's fingerprint, truncated,
// non-finite or non-unit poses, unknown codes) are reported as kMalformed and change nothing.
// Handle never throws for message content.
#ifndef DFO_IO_LCM_TRAJECTORY_COLLECTOR_H_
#define DFO_IO_LCM_TRAJECTORY_COLLECTOR_H_

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "dfo_core/trajectory.h"
#include "dfo_io/lcm/event_log.h"  // ReadLcmLog: the events of a log, for Handle
#include "dfo_io/lcm/messages.h"

namespace dfo::io {

// What Handle did with one message; the decoded message is in the member of its kind.
struct LcmCollectorEvent {
  enum class Kind {
    kPose,       // a pose_t on the pose channel, stored
    kKeyframes,  // a keyframe_batch_t on the keyframes channel, applied
    kStatus,     // a run_status_t on the status channel
    kStop,       // a stop_t on the stop channel
    kIgnored,    // a channel that is not one of the four
    kMalformed,  // not a valid message of its channel's type; `message` says why; skipped
  };
  Kind kind = Kind::kIgnored;
  std::string channel;
  std::string message;  // kMalformed: the reason, naming the channel
  dfo::pose_t pose{};
  dfo::keyframe_batch_t keyframes{};
  dfo::run_status_t status{};
  dfo::stop_t stop{};
};

// Messages seen so far, by kind.
struct LcmCollectorCounts {
  int64_t frontend_poses = 0;
  int64_t windowed_poses = 0;
  int64_t keyframe_batches = 0;
  int64_t status = 0;
  int64_t stops = 0;
  int64_t ignored = 0;
  int64_t malformed = 0;
  std::map<std::string, int64_t> malformed_by_channel;  // the malformed ones, by channel name
};

class LcmTrajectoryCollector {
 public:
  explicit LcmTrajectoryCollector(LcmChannels channels = {});

  // Decodes, checks and applies one message received on `channel`.
  LcmCollectorEvent Handle(const std::string& channel, const void* data, size_t size);

  // Frontend-only poses of every frame received, in frame-index order, as published (they do
  // not change after publication).
  Trajectory FrontendTrajectory() const;
  // Windowed poses of every frame received, in frame-index order: a keyframe at its newest pose
  // (from the newest keyframe batch naming it, else its own pose message), any other frame as
  // (newest pose of its keyframe) * kf_from_cam, or as published when its keyframe is unknown.
  Trajectory WindowedTrajectory() const;
  // Number of distinct frames with a frontend / windowed pose.
  size_t num_frontend_frames() const { return frontend_.size(); }
  size_t num_windowed_frames() const { return windowed_.size(); }

  const LcmCollectorCounts& counts() const { return counts_; }
  const LcmChannels& channels() const { return channels_; }
  // True once a stop_t arrived; stop_message() is the newest one.
  bool stopped() const { return stop_.has_value(); }
  const std::optional<dfo::stop_t>& stop_message() const { return stop_; }
  const std::optional<dfo::run_status_t>& last_status() const { return status_; }

 private:
  struct FramePose {
    int64_t timestamp_ns = 0;
    SE3d world_from_cam;
    bool is_keyframe = false;
    int keyframe_index = -1;
    SE3d kf_from_cam;
  };
  bool ApplyPose(const dfo::pose_t& m, std::string* error);
  bool ApplyKeyframes(const dfo::keyframe_batch_t& m, std::string* error);

  LcmChannels channels_;
  LcmCollectorCounts counts_;
  std::map<int, FramePose> frontend_;
  std::map<int, FramePose> windowed_;
  std::map<int, SE3d> windowed_keyframes_;  // newest world_from_kf per keyframe
  std::optional<dfo::run_status_t> status_;
  std::optional<dfo::stop_t> stop_;
};

}  // namespace dfo::io

#endif  // DFO_IO_LCM_TRAJECTORY_COLLECTOR_H_
