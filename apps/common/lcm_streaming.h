// dfo_run's LCM streaming: the `lcm` configuration section and the frame observer that publishes
// a run as it happens (dfo_io/lcm/ has the message types and the publisher).
//
//   LcmStreamOptions lcm_options = LcmStreamOptionsFromConfig(config);
//   std::unique_ptr<LcmRunStreamer> streamer;
//   if (lcm_options.active()) streamer = std::make_unique<LcmRunStreamer>(lcm_options, mode);
//   run_options.frame_observer = [&](const FrameRecord& f, const SequenceRunResult& r,
//                                    const Odometry& odometry) {
//     streamer->OnFrame(f, r, odometry.poses());
//   };
//   SequenceRunResult result = RunSequence(provider, &odometry, run_options);
//   streamer->Finish(result);
//
// Per processed frame, in this order, on the channels of the `lcm` section:
//   pose_channel       a dfo.pose_t with the frontend-only pose (modes frontend and both) and one
//                      with the windowed pose (modes windowed and both), each with the keyframe
//                      it is composed on;
//   keyframes_channel  when a keyframe's window solve was applied with this frame (the frame
//                      itself when it became a keyframe; an earlier keyframe with
//                      run.backend_thread): a dfo.keyframe_batch_t (frame_index: that keyframe)
//                      with every window keyframe's windowed pose after the bundle adjustment
//                      (and, in_window = false, the keyframe that left and those that left
//                      earlier and moved with their window neighbours);
//   status_channel     a dfo.run_status_t (frames done, fps so far, keyframes, lost).
// Finish publishes a last status and one dfo.stop_t. The same messages go to lcm.url
// (lcm.enable) and into the event log lcm.log_path (when set).
#ifndef DFO_APPS_COMMON_LCM_STREAMING_H_
#define DFO_APPS_COMMON_LCM_STREAMING_H_

#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "apps/common/backend_config.h"
#include "apps/common/sequence_runner.h"
#include "dfo_io/config.h"
#include "dfo_io/lcm/publisher.h"

namespace dfo::apps {

// The `lcm` section.
struct LcmStreamOptions {
  bool enable = false;                   // publish live on url
  std::string url = io::kDefaultLcmUrl;  // LCM URL
  std::string log_path;                  // event log written by dfo_run; "" = none
  io::LcmChannels channels;              // channel of each message type

  // True when there is anything to publish to (enable, or a log path).
  bool active() const { return enable || !log_path.empty(); }
};

// lcm.* of a Config of io::DfoSchema(); throws ConfigError for an empty url with enable, or for
// channel names that are empty or shared (io::LcmChannels::Check).
LcmStreamOptions LcmStreamOptionsFromConfig(const io::Config& config);

class LcmRunStreamer {
 public:
  // Opens lcm.url (enable) and creates the log (log_path). Throws InputError as io::LcmPublisher:
  // a URL that cannot be opened is named with the likely cause.
  LcmRunStreamer(const LcmStreamOptions& options, RunMode mode);

  // SequenceRunOptions::frame_observer: publishes what the file comment lists for `frame`.
  // Never throws; failures are counted in stats().
  // `poses`: the system's poses as of this frame (Odometry::poses()).
  void OnFrame(const FrameRecord& frame, const SequenceRunResult& result,
               const TrajectoryStore& poses);
  // The keyframes_channel message of keyframe `keyframe_index` (its record in result.keyframes)
  // with the window keyframes' poses in `store`; OnFrame calls it for the frame's
  // solved_keyframe; dfo_run calls it for a solve applied after the last frame (backend thread).
  // Frames already published against that keyframe whose windowed step the solve rescaled
  // (backend thread, TrajectoryStore::SetWindowedStepScale's rescale_added) are published again
  // with the new step, so that a subscriber keeping each frame's newest message has the
  // trajectory file's poses.
  void PublishKeyframeBatch(int keyframe_index, const SequenceRunResult& result,
                            const TrajectoryStore& store);
  // After the run: the final status and the stop message (reason "finished", or the run's error).
  void Finish(const SequenceRunResult& result);

  // Wall time of each OnFrame call in milliseconds (the publishing overhead per frame, including
  // any time the thread was descheduled, e.g. while a listener on the same cores ran).
  const std::vector<double>& publish_ms() const { return publish_ms_; }
  // CPU time of the calling thread in each OnFrame call, milliseconds (the publishing work).
  const std::vector<double>& publish_cpu_ms() const { return publish_cpu_ms_; }
  const io::LcmPublisherStats& stats() const { return publisher_.stats(); }
  const LcmStreamOptions& options() const { return options_; }
  // "udpm://... and the log out/x.lcmlog", for messages.
  std::string Describe() const;

 private:
  void PublishStatus(const SequenceRunResult& result);
  // One pose message of `frame` (`stored`: it is in the pose store).
  void PublishPose(const FrameRecord& frame, bool stored, const SE3d& world_from_cam, int8_t source,
                   const SE3d& step);

  LcmStreamOptions options_;
  RunMode mode_;
  io::LcmPublisher publisher_;
  std::unordered_map<int, int64_t> timestamps_ns_;  // frame index -> timestamp, for batches
  // The windowed step last published for each frame since the oldest keyframe whose solve may
  // still rescale it (frame index -> kf_from_cam).
  std::map<int, SE3d> published_steps_;
  std::vector<double> publish_ms_;
  std::vector<double> publish_cpu_ms_;
  std::chrono::steady_clock::time_point start_;
  bool started_ = false;
  int lost_ = 0;
  int64_t last_timestamp_ns_ = 0;
};

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_LCM_STREAMING_H_
