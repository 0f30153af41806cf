#include "apps/common/lcm_streaming.h"

#include <ctime>

#include "dfo_core/error.h"

namespace dfo::apps {
namespace {

// CPU time of the calling thread, milliseconds.
double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

LcmStreamOptions LcmStreamOptionsFromConfig(const io::Config& config) {
  LcmStreamOptions o;
  o.enable = config.GetBool("lcm.enable");
  o.url = config.GetString("lcm.url");
  o.log_path = config.GetString("lcm.log_path");
  o.channels.pose = config.GetString("lcm.pose_channel");
  o.channels.keyframes = config.GetString("lcm.keyframes_channel");
  o.channels.status = config.GetString("lcm.status_channel");
  o.channels.stop = config.GetString("lcm.stop_channel");
  if (o.enable && o.url.empty()) {
    throw ConfigError("lcm.url is empty but lcm.enable is true; name an LCM URL, e.g. " +
                      std::string(io::kDefaultLcmUrl));
  }
  o.channels.Check("lcm");
  return o;
}

namespace {

io::LcmPublisherOptions PublisherOptions(const LcmStreamOptions& options) {
  io::LcmPublisherOptions p;
  if (options.enable) p.url = options.url;
  p.log_path = options.log_path;
  p.channels = options.channels;
  return p;
}

// The keyframe a frame's published pose is composed from: a keyframe is its own reference.
int PoseKeyframeIndex(const FrameRecord& frame) {
  return frame.keyframe ? frame.tracked.index : frame.pose_keyframe_index;
}

}  // namespace

LcmRunStreamer::LcmRunStreamer(const LcmStreamOptions& options, RunMode mode)
    : options_(options), mode_(mode), publisher_(PublisherOptions(options)) {}

std::string LcmRunStreamer::Describe() const {
  std::string s;
  if (publisher_.live()) s = options_.url;
  if (publisher_.logging())
    s += (s.empty() ? "" : " and ") + std::string("the log ") + options_.log_path;
  return s;
}

void LcmRunStreamer::PublishStatus(const SequenceRunResult& result) {
  dfo::run_status_t status{};
  status.utime = io::NsToUtime(last_timestamp_ns_);
  status.frames_done = static_cast<int32_t>(result.frames.size());
  status.frames_total = static_cast<int32_t>(result.frames_in_sequence);
  const double elapsed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  status.fps = elapsed_s > 0.0 ? static_cast<double>(result.frames.size()) / elapsed_s : 0.0;
  status.keyframes = static_cast<int32_t>(result.keyframes.size());
  status.lost = lost_;
  status.sequence = result.sequence_name;
  publisher_.Publish(options_.channels.status, status);
}

void LcmRunStreamer::OnFrame(const FrameRecord& frame, const SequenceRunResult& result,
                             const TrajectoryStore& poses) {
  const auto begin = std::chrono::steady_clock::now();
  const double cpu_begin_ms = ThreadCpuMs();
  if (!started_) {
    // The run started when the first frame started loading.
    start_ = begin - std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                         std::chrono::duration<double, std::milli>(frame.total_ms));
    started_ = true;
  }
  const TrackedFrame& t = frame.tracked;
  timestamps_ns_[t.index] = t.timestamp_ns;
  last_timestamp_ns_ = t.timestamp_ns;
  lost_ += t.status == TrackingStatus::kLost ? 1 : 0;
  const TrajectoryStore& store = poses;
  // A keyframe is its own reference; other frames say what their pose is composed of, so that
  // a subscriber can follow their keyframe when the window moves it.
  const int keyframe_index = PoseKeyframeIndex(frame);
  const SE3d kf_from_cam = frame.keyframe ? SE3d() : frame.kf_from_cam;
  const bool stored = store.Contains(t.index);
  if (result.has_frontend()) {
    PublishPose(frame, stored, stored ? store.FrontendPose(t.index) : SE3d(),
                dfo::pose_t::SOURCE_FRONTEND, kf_from_cam);
  }
  if (result.has_windowed()) {
    // The windowed step carries the keyframe's step scale (window.rescale_source_steps).
    const SE3d step = stored && !frame.keyframe ? store.WindowedStep(t.index) : kf_from_cam;
    PublishPose(frame, stored, stored ? store.WindowedPose(t.index) : SE3d(),
                dfo::pose_t::SOURCE_WINDOWED, step);
    if (stored && !frame.keyframe && keyframe_index >= 0) published_steps_[t.index] = step;
    // The keyframe whose solve was applied with this frame (the frame itself, or an earlier
    // keyframe when the window solves on the backend thread).
    if (frame.solved_keyframe >= 0) PublishKeyframeBatch(frame.solved_keyframe, result, store);
  }
  PublishStatus(result);
  publish_ms_.push_back(
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count());
  publish_cpu_ms_.push_back(ThreadCpuMs() - cpu_begin_ms);
}

void LcmRunStreamer::PublishPose(const FrameRecord& frame, bool stored, const SE3d& world_from_cam,
                                 int8_t source, const SE3d& step) {
  const TrackedFrame& t = frame.tracked;
  publisher_.Publish(
      options_.channels.pose,
      io::MakePoseMessage(t.index, t.timestamp_ns, stored ? world_from_cam : t.world_from_cam,
                          t.status, frame.keyframe, source, PoseKeyframeIndex(frame), step));
}

void LcmRunStreamer::PublishKeyframeBatch(int keyframe_index, const SequenceRunResult& result,
                                          const TrajectoryStore& store) {
  const int position = FindKeyframeRecord(result.keyframes, keyframe_index);
  if (position < 0 || !result.keyframes[position].ba_ran) return;
  const KeyframeRecord* kf = &result.keyframes[position];
  // The store's windowed poses of the window's keyframes: the solve's result when it was kept,
  // the previous ones when not.
  const auto stamp = timestamps_ns_.find(kf->frame_index);
  dfo::keyframe_batch_t batch{};
  batch.utime = io::NsToUtime(stamp != timestamps_ns_.end() ? stamp->second : last_timestamp_ns_);
  batch.frame_index = kf->frame_index;
  batch.optimized = kf->window.optimized ? 1 : 0;
  const auto add = [&](int index, bool in_window) {
    if (!store.IsKeyframe(index)) return;
    const auto found = timestamps_ns_.find(index);
    batch.keyframes.push_back(
        io::MakeKeyframePose(index, found != timestamps_ns_.end() ? found->second : 0,
                             store.WindowedPose(index), in_window));
  };
  for (const auto& [index, pose] : kf->window.keyframe_poses) add(index, true);
  if (kf->window.marginalized_frame_index >= 0) add(kf->window.marginalized_frame_index, false);
  for (int index : kf->followers) add(index, false);
  batch.num_keyframes = static_cast<int32_t>(batch.keyframes.size());
  publisher_.Publish(options_.channels.keyframes, batch);

  // The frames published before this solve was applied: those whose step it rescaled go again.
  // Frames before the keyframe are never rescaled again (solves are applied in order).
  published_steps_.erase(published_steps_.begin(), published_steps_.lower_bound(keyframe_index));
  for (auto it = result.frames.rbegin(); it != result.frames.rend(); ++it) {
    const int index = it->tracked.index;
    if (index <= keyframe_index) break;
    const auto published = published_steps_.find(index);
    if (published == published_steps_.end() || it->keyframe ||
        it->pose_keyframe_index != keyframe_index || !store.Contains(index)) {
      continue;
    }
    const SE3d step = store.WindowedStep(index);
    if (step.translation() == published->second.translation()) continue;
    PublishPose(*it, true, store.WindowedPose(index), dfo::pose_t::SOURCE_WINDOWED, step);
    published->second = step;
  }
}

void LcmRunStreamer::Finish(const SequenceRunResult& result) {
  if (!started_) start_ = std::chrono::steady_clock::now();
  PublishStatus(result);
  dfo::stop_t stop{};
  stop.utime = io::NsToUtime(last_timestamp_ns_);
  stop.frames_done = static_cast<int32_t>(result.frames.size());
  stop.error = result.error.empty() ? 0 : 1;
  stop.reason = result.error.empty() ? "finished" : result.error;
  publisher_.Publish(options_.channels.stop, stop);
}

}  // namespace dfo::apps
