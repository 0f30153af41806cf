#include "dfo_backend/odometry.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <future>
#include <utility>

#include "dfo_core/error.h"
#include "dfo_core/timing.h"

namespace dfo {
namespace {

bool IsFinitePose(const SE3d& pose) {
  return pose.translation().allFinite() && pose.quaternion().coeffs().allFinite();
}

}  // namespace

// A keyframe's window solve, in flight on the backend thread (or about to run inline).
struct Odometry::PendingSolve {
  int frame_index = -1;
  std::future<WindowResult> result;
  DepthPyramid keyframe_depth;  // the source's, brought to the window's scale when known
  std::vector<PinholeCamera> cameras;
  std::chrono::steady_clock::time_point start;
  // When AddKeyframe returned (set by whoever ran it, before the result is ready).
  std::chrono::steady_clock::time_point finished;
  // What the frames after the keyframe are tracked against until the solve is applied.
  std::string submitted_depth;
};

const char* OdometryModeName(OdometryMode mode) {
  switch (mode) {
    case OdometryMode::kFrontend:
      return "frontend";
    case OdometryMode::kWindowed:
      return "windowed";
    case OdometryMode::kBoth:
      return "both";
  }
  return "unknown";
}

void OdometryOptions::Check() const {
  keyframe.Check();
  tracking.Check();
  stereo.Check();
  if (has_window()) window.Check();
}

void OdometryOptions::CheckAgainst(const TrackerOptions& tracker) const {
  if (!has_window()) return;
  const int levels = tracker.num_levels;
  if (window.pyramid_level >= levels) {
    throw ConfigError("window.pyramid_level = " + std::to_string(window.pyramid_level) +
                      " violates < tracker.num_levels (" + std::to_string(levels) + ")");
  }
  if (window.coarse_iterations > 0 && window.pyramid_level + 1 >= levels) {
    throw ConfigError("window.coarse_iterations = " + std::to_string(window.coarse_iterations) +
                      " needs window.pyramid_level + 1 < tracker.num_levels (" +
                      std::to_string(levels) +
                      "); set window.coarse_iterations=0 or use more tracker levels");
  }
}

int FindKeyframeRecord(const std::vector<KeyframeRecord>& records, int frame_index) {
  for (int i = static_cast<int>(records.size()) - 1; i >= 0; --i) {
    if (records[i].frame_index == frame_index) return i;
  }
  return -1;
}

Odometry::Odometry(const FrontendOptions& frontend_options, const OdometryOptions& options,
                   std::unique_ptr<FeatureSource> features, std::unique_ptr<DepthSource> depth)
    : options_((options.Check(), options)),
      frontend_(
          std::make_unique<Frontend>(frontend_options, std::move(features), std::move(depth))),
      manager_(options.keyframe),
      external_(frontend_options.reference.policy == "external") {
  options_.CheckAgainst(frontend_options.tracker);
  if (options_.has_window()) window_ = std::make_unique<WindowOptimizer>(options_.window);
}

Odometry::~Odometry() {
  // A solve still running on the backend thread ends before the window it works on.
  if (pending_ && pending_->result.valid()) pending_->result.wait();
}

OdometryFrame Odometry::Process(const Frame& frame) {
  OdometryFrame out;
  // A solve that finished on the backend thread since the last frame is applied first.
  out.solved_keyframe = ApplyPendingSolve(/*wait=*/false);
  const bool tracked_against_reference = frontend_->tracker().has_reference();
  const std::string tracked_depth = reference_depth_;
  out.tracked = frontend_->Process(frame);  // throws on bad input: nothing booked
  if (window_ && options_.stereo.enabled()) {
    recent_.push_back(
        {frame.index, out.tracked.status == TrackingStatus::kLost, GreyLevels(frame.image, 1.0f)});
    // The views of a keyframe are the frames before it; a re-track keyframe is the frame before
    // the newest one, hence one frame more than the views.
    while (static_cast<int>(recent_.size()) > options_.stereo.views + 2) recent_.pop_front();
  }
  const TrackedFrame& t = out.tracked;
  // Lost against the keyframe, tracked against the previous frame: that frame becomes a keyframe
  // first, so that this one is booked against it.
  KeyframeData retrack;
  if (t.retracked_from >= 0 && frontend_->TakeRetrackKeyframe(&retrack)) {
    WaitForWindow(&out);
    DFO_CHECK(retrack.frame_index == last_tracked_.index && poses_.Contains(retrack.frame_index) &&
              !poses_.IsKeyframe(retrack.frame_index))
        << "re-track reference " << retrack.frame_index << " is not the previous frame";
    poses_.PromoteToKeyframe(retrack.frame_index);
    BecomeKeyframe(last_tracked_, KeyframeReason::kRetrack, &out, /*promoted=*/true, &retrack);
  }
  last_tracked_ = t;
  if (t.status != TrackingStatus::kReference && tracked_against_reference) {
    out.tracking_depth = tracked_depth;
  }
  const auto finish = [&]() {
    // A frame that became the reference got its depth after Process (Frontend::last_timings).
    out.timings = frontend_->last_timings();
    out.frontend_world_from_cam = poses_.FrontendPose(t.index);
    out.windowed_world_from_cam = poses_.WindowedPose(t.index);
    return out;
  };
  const KeyframeDecision decision = manager_.Decide(t);
  if (t.status == TrackingStatus::kReference) {
    // First frame or restart after a loss: a keyframe by itself, related to the previous
    // keyframe only through the frontend's poses.
    WaitForWindow(&out);
    poses_.AddKeyframe(t.index, t.timestamp_ns, t.world_from_cam);
    out.kf_from_cam = t.world_from_cam;
    BecomeKeyframe(t, decision.reason, &out);
    return finish();
  }
  if (t.reference_index >= 0 && poses_.IsKeyframe(t.reference_index)) {
    out.pose_keyframe_index = t.reference_index;
    out.kf_from_cam = t.ref_from_cam;
  } else if (last_keyframe_ >= 0) {
    // Not tracked against a keyframe (a lost frame while restarting): keep the frontend's
    // relation to the newest keyframe.
    out.pose_keyframe_index = last_keyframe_;
    out.kf_from_cam = poses_.FrontendPose(last_keyframe_).Inverse() * t.world_from_cam;
  } else {
    out.kf_from_cam = t.world_from_cam;
  }
  // A frame tracked against its keyframe's source-based depth takes the keyframe's step scale in
  // the windowed trajectory (set at the keyframe's solve, which in sequential mode came first).
  const bool scale_step = window_ && options_.tracking.rescale_source_steps &&
                          (out.tracking_depth == "source" || out.tracking_depth == "scaled_source");
  poses_.AddFrame(t.index, t.timestamp_ns, out.pose_keyframe_index, out.kf_from_cam, scale_step);
  if (t.status == TrackingStatus::kLost) return finish();
  bool switched = false;
  if (external_) {
    switched = decision.new_keyframe && frontend_->MakeLastFrameReference(nullptr);
  } else {
    switched = t.is_new_reference;  // the frontend switched by its own rule
  }
  if (switched) {
    WaitForWindow(&out);
    poses_.PromoteToKeyframe(t.index);
    BecomeKeyframe(t, external_ ? decision.reason : KeyframeReason::kNone, &out);
  }
  return finish();
}

void Odometry::WaitForWindow(OdometryFrame* out) {
  const int solved = ApplyPendingSolve(/*wait=*/true);
  if (solved >= 0) out->solved_keyframe = solved;
}

void Odometry::BecomeKeyframe(const TrackedFrame& t, KeyframeReason reason, OdometryFrame* out,
                              bool promoted, KeyframeData* data) {
  manager_.AcceptKeyframe(t.index);
  last_keyframe_ = t.index;
  if (promoted) {
    out->promoted_keyframe = t.index;
  } else {
    out->keyframe = true;
    out->keyframe_reason = reason;
  }
  KeyframeRecord kf;
  kf.frame_index = t.index;
  kf.reason = reason;
  keyframes_.push_back(std::move(kf));
  reference_depth_ = "source";
  if (!window_) return;
  const auto start = std::chrono::steady_clock::now();
  // The window takes one keyframe at a time: the previous solve finishes first.
  WaitForWindow(out);
  SubmitToWindow(t, data);
  if (!options_.backend_thread) {
    ApplyPendingSolve(/*wait=*/true);
    out->solved_keyframe = t.index;
  }
  out->backend_ms = MsSince(start);
}

void Odometry::SubmitToWindow(const TrackedFrame& t, KeyframeData* given) {
  KeyframeRecord& kf = keyframes_.back();
  KeyframeData data;
  if (given != nullptr) {
    data = std::move(*given);
  } else {
    const bool ok = frontend_->MakeLastFrameReference(&data);
    DFO_CHECK(ok) << "frame " << t.index << " is the reference but has no keyframe data";
  }
  // The window works in the windowed trajectory's frame: the keyframe starts at its keyframe's
  // bundle-adjusted pose composed with the tracked relative pose.
  data.world_from_cam = poses_.WindowedPose(t.index);
  auto pending = std::make_unique<PendingSolve>();
  pending->frame_index = t.index;
  pending->start = std::chrono::steady_clock::now();
  for (const FeatureLevel& level : data.features.levels) pending->cameras.push_back(level.camera);
  const TrackingDepthOptions& tracking = options_.tracking;
  // The factor that brings the source's depth to the window's scale (median over the window's
  // points seen from the keyframe's starting pose): for the tracking depth until (or instead of)
  // the window's own, and, with initial_depth_scale "window", for the new points' start.
  if (window_->num_keyframes() > 0 && data.depth.num_levels() > 0 && !pending->cameras.empty()) {
    kf.window_scale =
        WindowToSourceScale(window_->PointsInCamera(data.world_from_cam), data.depth.levels[0],
                            pending->cameras[0], tracking.min_window_points);
  }
  // The keyframe's own image: the newest frame, or the one before it for a re-track keyframe.
  const auto own = std::find_if(recent_.rbegin(), recent_.rend(),
                                [&](const RecentFrame& r) { return r.index == t.index; });
  if (options_.stereo.enabled() && kf.window_scale > 0.0 && own != recent_.rend() &&
      !pending->cameras.empty()) {
    // The keyframe against the (at most stereo.views) frames before it, at their windowed poses,
    // oldest first.
    std::vector<StereoView> views;
    for (auto r = std::next(own);
         r != recent_.rend() && static_cast<int>(views.size()) < options_.stereo.views; ++r) {
      if (r->lost || !poses_.Contains(r->index)) continue;
      views.push_back({&r->grey, poses_.WindowedPose(r->index).Inverse() * data.world_from_cam});
    }
    std::reverse(views.begin(), views.end());
    kf.stereo = ApplyKeyframeStereo(own->grey, pending->cameras[0], views, kf.window_scale,
                                    options_.stereo, &data.depth);
    // The frames until the next keyframe are tracked against it.
    if (kf.stereo.num_replaced > 0) frontend_->SetReferenceDepth(t.index, data.depth);
  }
  if (tracking.source_scale != "raw" && kf.window_scale > 0.0) {
    if (tracking.source_scale == "window") {
      // The window's own scale, carried by the points it shares with the keyframe (DSO's way).
      kf.source_scale = kf.window_scale;
    } else {  // run_median
      window_scales_.push_back(kf.window_scale);
      std::vector<double> sorted = window_scales_;
      const auto middle = sorted.begin() + sorted.size() / 2;
      std::nth_element(sorted.begin(), middle, sorted.end());
      kf.source_scale = *middle;
    }
    data.initial_depth_scale = data.prior_depth_scale = kf.source_scale;
    kf.initial_depth_scale = kf.source_scale;
  }
  if (tracking.initial_depth_scale == "window" && kf.window_scale > 0.0) {
    data.initial_depth_scale = kf.window_scale;  // the depth prior stays as source_scale says
    kf.initial_depth_scale = kf.window_scale;
  }
  pending->keyframe_depth = data.depth;
  if (kf.window_scale > 0.0) pending->keyframe_depth.Scale(kf.window_scale);
  // While the solve runs on the backend thread, the next frames are tracked against the source's
  // depth at the window's scale.
  if (options_.backend_thread && tracking.depth == "window" && kf.window_scale > 0.0 &&
      frontend_->SetReferenceDepth(t.index, pending->keyframe_depth)) {
    kf.tracking_depth = reference_depth_ = "scaled_source";
  }
  pending->submitted_depth = kf.tracking_depth;
  if (options_.keyframe_filter) options_.keyframe_filter(&data);
  WindowOptimizer* window = window_.get();
  std::chrono::steady_clock::time_point* finished = &pending->finished;
  const auto solve = [window, finished, hook = options_.before_solve](KeyframeData d) {
    // The end time is written even when AddKeyframe throws.
    struct Stamp {
      std::chrono::steady_clock::time_point* at;
      ~Stamp() { *at = std::chrono::steady_clock::now(); }
    } stamp{finished};
    if (hook) hook(d.frame_index);
    return window->AddKeyframe(std::move(d));
  };
  if (options_.backend_thread) {
    pending->result = std::async(
        std::launch::async, [solve, d = std::move(data)]() mutable { return solve(std::move(d)); });
  } else {
    std::promise<WindowResult> promise;
    pending->result = promise.get_future();
    try {
      promise.set_value(solve(std::move(data)));
    } catch (...) {
      promise.set_exception(std::current_exception());
    }
  }
  pending_ = std::move(pending);
}

SE3d Odometry::FollowerPose(const LeftKeyframe& l) const {
  if (l.older < 0 && l.newer < 0) return poses_.WindowedPose(l.frame_index);
  if (l.older < 0) return poses_.WindowedPose(l.newer) * l.newer_from_left;
  const SE3d from_older = poses_.WindowedPose(l.older) * l.older_from_left;
  if (l.newer < 0) return from_older;
  const SE3d from_newer = poses_.WindowedPose(l.newer) * l.newer_from_left;
  // Weighted by the distance in frames: the nearer neighbour's move counts more.
  const double w =
      static_cast<double>(l.frame_index - l.older) / static_cast<double>(l.newer - l.older);
  return from_older * SE3d::Exp(w * (from_older.Inverse() * from_newer).Log());
}

int Odometry::ApplyPendingSolve(bool wait) {
  if (!pending_) return -1;
  if (!wait && pending_->result.wait_for(std::chrono::seconds(0)) != std::future_status::ready) {
    return -1;
  }
  const std::unique_ptr<PendingSolve> pending = std::move(pending_);
  const int position = FindKeyframeRecord(keyframes_, pending->frame_index);
  DFO_CHECK(position >= 0) << "no keyframe record for frame " << pending->frame_index;
  KeyframeRecord* kf = &keyframes_[position];
  kf->window = pending->result.get();  // rethrows what AddKeyframe threw
  kf->ba_ran = true;
  if (kf->window.marginalized_frame_index >= 0) {
    const int at = FindKeyframeRecord(keyframes_, kf->window.marginalized_frame_index);
    if (at >= 0) keyframes_[at].settled_points = std::move(kf->window.marginalized_points);
    kf->window.marginalized_points.clear();
  }
  // From the hand-over to the end of the solve (not to this call, which with the backend thread
  // may come frames later).
  kf->backend_ms = MsBetween(pending->start, pending->finished);
  const int t = pending->frame_index;
  bool finite = true;
  for (const auto& [index, pose] : kf->window.keyframe_poses) finite &= IsFinitePose(pose);
  if (kf->window.optimized && finite) {
    // A keyframe's reported pose follows the window while it is one of the newest max_keyframes
    // keyframes (see the file comment of odometry.h, "Reported poses").
    const auto reported = [&](int index) {
      const int at = FindKeyframeRecord(keyframes_, index);
      return at >= 0 && position - at < options_.window.max_keyframes;
    };
    for (const auto& [index, pose] : kf->window.keyframe_poses) {
      if (reported(index)) poses_.SetWindowedPose(index, pose);
    }
    const int left = kf->window.marginalized_frame_index;
    if (left >= 0 && IsFinitePose(kf->window.marginalized_pose) && reported(left)) {
      poses_.SetWindowedPose(left, kf->window.marginalized_pose);
      // It goes on following the window keyframes next to it (file comment of odometry.h).
      LeftKeyframe follower;
      follower.frame_index = left;
      const SE3d left_pose = poses_.WindowedPose(left);
      for (const auto& [index, pose] : kf->window.keyframe_poses) {
        if (index < left) {
          follower.older = index;
          follower.older_from_left = poses_.WindowedPose(index).Inverse() * left_pose;
        } else if (index > left && follower.newer < 0) {
          follower.newer = index;
          follower.newer_from_left = poses_.WindowedPose(index).Inverse() * left_pose;
        }
      }
      left_.push_back(follower);
    }
    left_.erase(std::remove_if(left_.begin(), left_.end(),
                               [&](const LeftKeyframe& l) { return !reported(l.frame_index); }),
                left_.end());
    for (const LeftKeyframe& l : left_) {
      if (l.frame_index == left) continue;  // where the solve left it
      poses_.SetWindowedPose(l.frame_index, FollowerPose(l));
      kf->followers.push_back(l.frame_index);
    }
  } else if (kf->window.optimized) {
    kf->window.optimized = false;
    kf->window.message = "non-finite keyframe pose after the solve; poses not taken";
  }

  const TrackingDepthOptions& tracking = options_.tracking;
  std::vector<Eigen::Vector3d> points;
  if (kf->window.optimized && (tracking.rescale_source_steps || tracking.depth == "window")) {
    points = window_->PointsInKeyframe(t);
  }
  // What the next frames are tracked against (only while the keyframe is still the reference).
  if (tracking.depth == "window" && last_keyframe_ == t) ChooseTrackingDepth(*pending, points, kf);

  // The factor that brings the steps of the frames tracked against the keyframe's source-based
  // depth to the window's scale, from the depth they are tracked against as decided above: the
  // source's map as it is ("source": keyframe_depth is it times window_scale when that is known)
  // or at the window's scale seen from the starting pose ("scaled_source": keyframe_depth). The
  // frames tracked against the window's own depth need none.
  if (tracking.rescale_source_steps && kf->tracking_depth != "window" && !points.empty() &&
      !pending->cameras.empty() && pending->keyframe_depth.num_levels() > 0) {
    const double ratio = WindowToSourceScale(points, pending->keyframe_depth.levels[0],
                                             pending->cameras[0], tracking.min_window_points);
    const bool raw_source = kf->tracking_depth == "source" && kf->window_scale > 0.0;
    if (ratio > 0.0) {
      kf->step_scale = ratio * (raw_source ? kf->window_scale : 1.0);
      // Frames tracked before the solve was applied (backend thread) against the depth the
      // frames after it are tracked against take the same factor.
      poses_.SetWindowedStepScale(t, kf->step_scale,
                                  kf->tracking_depth == pending->submitted_depth);
    }
  }
  return t;
}

void Odometry::ChooseTrackingDepth(const PendingSolve& pending,
                                   const std::vector<Eigen::Vector3d>& points, KeyframeRecord* kf) {
  const TrackingDepthOptions& tracking = options_.tracking;
  const int t = pending.frame_index;
  const auto set_depth = [&](const DepthPyramid& depth, const char* name) {
    if (!frontend_->SetReferenceDepth(t, depth)) return false;
    kf->tracking_depth = reference_depth_ = name;
    return true;
  };
  if (kf->window.optimized && !points.empty()) {
    const TrackingDepth depth =
        BuildTrackingDepth(pending.keyframe_depth, pending.cameras, points, tracking);
    kf->tracking_window_points = depth.num_points;
    if (depth.from_window) {
      if (set_depth(depth.depth, "window")) {
        const std::vector<Eigen::Vector2i> selected = frontend_->tracker().reference_points(0);
        int covered = 0;
        const int width = pending.cameras[0].width;
        for (const Eigen::Vector2i& p : selected) {
          covered += depth.covered[static_cast<size_t>(p.y()) * width + p.x()] ? 1 : 0;
        }
        kf->tracking_covered = selected.empty() ? 0.0 : double(covered) / selected.size();
        return;
      }
      kf->tracking_depth_note = "the window depth selects too few tracker points";
    } else {
      kf->tracking_depth_note = depth.note;
    }
  } else {
    kf->tracking_depth_note = !kf->window.optimized ? "no window solve at this keyframe"
                                                    : "the keyframe has no window points";
  }
  // Fallback: the source's depth at the window's scale (when the window had points to tell it).
  if (kf->tracking_depth != "scaled_source" && kf->window_scale > 0.0) {
    set_depth(pending.keyframe_depth, "scaled_source");
  }
}

int Odometry::Flush() {
  const int solved = ApplyPendingSolve(/*wait=*/true);
  if (window_) {
    for (const auto& [index, pose] : window_->KeyframePoses()) {
      const int at = FindKeyframeRecord(keyframes_, index);
      if (at >= 0) keyframes_[at].settled_points = window_->HostedPoints(index);
    }
  }
  return solved;
}

}  // namespace dfo
