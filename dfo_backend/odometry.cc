#include "dfo_backend/odometry.h"

#include <chrono>
#include <utility>

#include "dfo_core/error.h"

namespace dfo {
namespace {

bool IsFinitePose(const SE3d& pose) {
  return pose.translation().allFinite() && pose.quaternion().coeffs().allFinite();
}

double MsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

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
  if (has_window()) window.Check();
}

Odometry::Odometry(const FrontendOptions& frontend_options, const OdometryOptions& options,
                   std::unique_ptr<FeatureSource> features, std::unique_ptr<DepthSource> depth)
    : options_((options.Check(), options)),
      frontend_(std::make_unique<Frontend>(frontend_options, std::move(features),
                                           std::move(depth))),
      manager_(options.keyframe),
      external_(frontend_options.reference.policy == "external") {
  if (options_.has_window()) {
    const int levels = frontend_options.tracker.num_levels;
    if (options_.window.pyramid_level >= levels) {
      throw ConfigError("window.pyramid_level = " + std::to_string(options_.window.pyramid_level) +
                        " violates < tracker.num_levels (" + std::to_string(levels) + ")");
    }
    if (options_.window.coarse_iterations > 0 && options_.window.pyramid_level + 1 >= levels) {
      throw ConfigError("window.coarse_iterations = " +
                        std::to_string(options_.window.coarse_iterations) +
                        " needs window.pyramid_level + 1 < tracker.num_levels (" +
                        std::to_string(levels) +
                        "); set window.coarse_iterations=0 or use more tracker levels");
    }
    window_ = std::make_unique<WindowOptimizer>(options_.window);
  }
}

Odometry::~Odometry() = default;

OdometryFrame Odometry::Process(const Frame& frame) {
  OdometryFrame out;
  const bool tracked_against_reference = frontend_->tracker().has_reference();
  const std::string tracked_depth = reference_depth_;
  out.tracked = frontend_->Process(frame);  // throws on bad input: nothing booked
  out.timings = frontend_->last_timings();
  const TrackedFrame& t = out.tracked;
  if (t.status != TrackingStatus::kReference && tracked_against_reference) {
    out.tracking_depth = tracked_depth;
  }
  const auto finish = [&]() {
    out.frontend_world_from_cam = poses_.FrontendPose(t.index);
    out.windowed_world_from_cam = poses_.WindowedPose(t.index);
    return out;
  };
  const KeyframeDecision decision = manager_.Decide(t);
  if (t.status == TrackingStatus::kReference) {
    // First frame or restart after a loss: a keyframe by itself, related to the previous
    // keyframe only through the frontend's poses.
    poses_.AddKeyframe(t.index, t.timestamp_ns, t.world_from_cam);
    out.kf_from_cam = t.world_from_cam;
    reference_depth_ = "source";
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
  poses_.AddFrame(t.index, t.timestamp_ns, out.pose_keyframe_index, out.kf_from_cam);
  if (t.status == TrackingStatus::kLost) return finish();
  bool switched = false;
  if (external_) {
    switched = decision.new_keyframe && frontend_->MakeLastFrameReference(nullptr);
  } else {
    switched = t.is_new_reference;  // the frontend switched by its own rule
  }
  if (switched) {
    poses_.PromoteToKeyframe(t.index);
    reference_depth_ = "source";
    BecomeKeyframe(t, external_ ? decision.reason : KeyframeReason::kNone, &out);
  }
  return finish();
}

void Odometry::BecomeKeyframe(const TrackedFrame& t, KeyframeReason reason, OdometryFrame* out) {
  manager_.AcceptKeyframe(t.index);
  last_keyframe_ = t.index;
  out->keyframe = true;
  out->keyframe_reason = reason;
  KeyframeRecord kf;
  kf.frame_index = t.index;
  kf.reason = reason;
  if (window_) {
    const auto start = std::chrono::steady_clock::now();
    AddToWindow(t, &kf);
    kf.backend_ms = MsSince(start);
    out->backend_ms = kf.backend_ms;
  }
  reference_depth_ = kf.tracking_depth;
  keyframes_.push_back(std::move(kf));
}

void Odometry::AddToWindow(const TrackedFrame& t, KeyframeRecord* kf) {
  KeyframeData data;
  const bool ok = frontend_->MakeLastFrameReference(&data);
  DFO_CHECK(ok) << "frame " << t.index << " is the reference but has no keyframe data";
  // The window works in the windowed trajectory's frame: the keyframe starts at its keyframe's
  // bundle-adjusted pose composed with the tracked relative pose.
  data.world_from_cam = poses_.WindowedPose(t.index);
  std::vector<PinholeCamera> cameras;
  for (const FeatureLevel& level : data.features.levels) cameras.push_back(level.camera);
  const TrackingDepthOptions& tracking = options_.tracking;
  // The new points start at the window's scale, not at the image's own (network) scale.
  if (tracking.initial_depth_scale == "window" && window_->num_keyframes() > 0 &&
      data.depth.num_levels() > 0 && !cameras.empty()) {
    const double scale =
        WindowToSourceScale(window_->PointsInCamera(data.world_from_cam), data.depth.levels[0],
                            cameras[0], tracking.min_window_points);
    if (scale > 0.0) {
      data.initial_depth_scale = scale;  // the depth prior stays toward the source's own depth
      kf->initial_depth_scale = scale;
    }
  }
  DepthPyramid keyframe_depth = data.depth;  // the source's, brought to the window's scale
  ScaleDepthPyramid(&keyframe_depth, kf->initial_depth_scale);
  if (options_.keyframe_filter) options_.keyframe_filter(&data);
  kf->window = window_->AddKeyframe(std::move(data));
  kf->ba_ran = true;
  bool finite = true;
  for (const auto& [index, pose] : kf->window.keyframe_poses) finite &= IsFinitePose(pose);
  if (kf->window.optimized && finite) {
    for (const auto& [index, pose] : kf->window.keyframe_poses) poses_.SetWindowedPose(index, pose);
    if (kf->window.marginalized_frame_index >= 0 && IsFinitePose(kf->window.marginalized_pose)) {
      poses_.SetWindowedPose(kf->window.marginalized_frame_index, kf->window.marginalized_pose);
    }
  } else if (kf->window.optimized) {
    kf->window.optimized = false;
    kf->window.message = "non-finite keyframe pose after the solve; poses not taken";
  }

  // What the next frames are tracked against.
  if (tracking.depth != "window") return;
  const bool in_window = !window_->PointsInKeyframe(t.index).empty();
  if (kf->window.optimized && in_window) {
    const TrackingDepth depth =
        BuildTrackingDepth(keyframe_depth, cameras, window_->PointsInKeyframe(t.index), tracking);
    kf->tracking_window_points = depth.num_points;
    if (depth.from_window) {
      if (frontend_->SetReferenceDepth(t.index, depth.depth)) {
        kf->tracking_depth = "window";
        const std::vector<Eigen::Vector2i> points = frontend_->tracker().reference_points(0);
        int covered = 0;
        const int width = cameras[0].width;
        for (const Eigen::Vector2i& p : points) {
          covered += depth.covered[static_cast<size_t>(p.y()) * width + p.x()] ? 1 : 0;
        }
        kf->tracking_covered = points.empty() ? 0.0 : double(covered) / points.size();
        return;
      }
      kf->tracking_depth_note = "the window depth selects too few tracker points";
    } else {
      kf->tracking_depth_note = depth.note;
    }
  } else {
    kf->tracking_depth_note = !kf->window.optimized
                                  ? "no window solve at this keyframe"
                                  : "the keyframe has no window points";
  }
  // Fallback: the source's depth at the window's scale (when it was rescaled).
  if (kf->initial_depth_scale != 1.0 && frontend_->SetReferenceDepth(t.index, keyframe_depth)) {
    kf->tracking_depth = "scaled_source";
  }
}

}  // namespace dfo
