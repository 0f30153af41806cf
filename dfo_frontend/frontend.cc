#include "dfo_frontend/frontend.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <utility>

#include "dfo_core/error.h"
#include "dfo_core/timing.h"

namespace dfo {

// The frontend's reference (with the tracker, what a residual re-track may have to restore).
struct ReferenceState {
  bool has_reference = false;
  int reference_index = -1;
  SE3d world_from_ref;
  double reference_parallax_depth = 0.0;  // Tracker::reference_parallax_depth(0)
  int frames_since_reference = 0;
  double first_rmse = 0.0;  // RMSE of the first frame tracked against it; 0 before
  // The reference's features and its depth source's pyramid (for SetReferenceDepth).
  FeaturePyramid reference_features;
  DepthPyramid reference_depth;

  // The reference `tracker` was just given (Tracker::SetReference): frame `index` at
  // `world_from_ref`, with the features and depth it was given; nothing tracked against it yet.
  static ReferenceState Of(const Tracker& tracker, int index, const SE3d& world_from_ref,
                           const FeaturePyramid& features, const DepthPyramid& depth) {
    ReferenceState r;
    r.has_reference = true;
    r.reference_index = index;
    r.world_from_ref = world_from_ref;
    r.reference_parallax_depth = tracker.reference_parallax_depth(0);
    r.reference_features = features;
    r.reference_depth = depth;
    return r;
  }
};

// What the frontend remembers between frames.
struct Frontend::State {
  ReferenceState reference;
  // Last good pose (the pose of lost frames and of a restart reference) and the one before it,
  // for the constant-velocity motion model.
  SE3d world_from_last;
  bool has_motion = false;
  SE3d last_from_prev;  // last inter-frame motion (identity when unknown)
  // The last processed frame, for MakeLastFrameReference.
  bool has_last_frame = false;
  // Kept when the keyframes get their own features or the frame's depth was not computed.
  Frame last_input;
  TrackedFrame last_frame;
  FeaturePyramid last_features;
  DepthPyramid last_depth;
  bool last_depth_pending = false;  // last_depth not computed yet (from last_input when needed)
  // The keyframe data of the previous frame when the last Process call re-tracked against it.
  std::optional<KeyframeData> retrack_keyframe;
};

namespace {

bool IsFinite(const SE3d& pose) {
  return pose.translation().allFinite() && pose.quaternion().coeffs().allFinite();
}

// Fewest point pairs for a depth-scale estimate.
constexpr int kMinScalePairs = 20;

void CheckFrame(const Frame& frame) {
  std::ostringstream msg;
  msg << "frame " << frame.index << ": ";
  if (frame.image.empty()) {
    msg << "the image is empty";
    throw InputError(msg.str());
  }
  std::string why;
  if (!frame.camera.IsValid(&why)) {
    msg << "invalid camera: " << why;
    throw InputError(msg.str());
  }
  if (frame.image.width() != frame.camera.width || frame.image.height() != frame.camera.height) {
    msg << "image is " << frame.image.width() << "x" << frame.image.height()
        << " but the camera is " << frame.camera.width << "x" << frame.camera.height
        << "; they must be the same size";
    throw InputError(msg.str());
  }
  if (!frame.depth_m.empty() &&
      (frame.depth_m.width() != frame.image.width() ||
       frame.depth_m.height() != frame.image.height() || frame.depth_m.channels() != 1)) {
    msg << "depth map is " << frame.depth_m.width() << "x" << frame.depth_m.height() << "x"
        << frame.depth_m.channels() << " but the image is " << frame.image.width() << "x"
        << frame.image.height() << "; expected a 1-channel depth map of the image's size";
    throw InputError(msg.str());
  }
}

}  // namespace

Frontend::Frontend(const FrontendOptions& options) : Frontend(options, nullptr, nullptr) {}

Frontend::Frontend(const FrontendOptions& options, std::unique_ptr<FeatureSource> features,
                   std::unique_ptr<DepthSource> depth)
    : options_((options.Check(), options)),
      features_(features ? std::move(features)
                         : MakeFeatureSource(options.features, options.handmade)),
      depth_(depth ? std::move(depth) : MakeDepthSource(options.depth)),
      tracker_(options.tracker),
      state_(std::make_unique<State>()) {
  // Hand-made keyframe features with their own blur (HandmadeFeatureOptions).
  const HandmadeFeatureOptions& h = options_.handmade;
  if (!features && options_.features == "handmade" && h.keyframe_blur_sigma_px >= 0.0 &&
      h.keyframe_blur_sigma_px != h.blur_sigma_px) {
    HandmadeFeatureOptions keyframe = h;
    keyframe.blur_sigma_px = h.keyframe_blur_sigma_px;
    keyframe_features_ = std::make_unique<HandmadeFeatureSource>(keyframe);
  }
}

Frontend::~Frontend() = default;

const FrontendTimings& Frontend::last_timings() const { return timings_; }
const FrontendOptions& Frontend::options() const { return options_; }

void Frontend::Reset() {
  state_ = std::make_unique<State>();
  tracker_ = Tracker(options_.tracker);
}

TrackedFrame Frontend::Process(const Frame& frame) {
  CheckFrame(frame);
  timings_ = FrontendTimings();
  State& s = *state_;
  const int num_levels = options_.tracker.num_levels;

  auto start = std::chrono::steady_clock::now();
  FeaturePyramid features = features_->Compute(frame, num_levels);
  timings_.features_ms = MsSince(start);
  // The depth is needed only by a frame that becomes a reference (DSO, too, has depth only for
  // keyframes): it is computed then, here or in MakeLastFrameReference. Its input is checked
  // now, so that a bad frame still throws before anything is tracked.
  depth_->Check(frame, num_levels);
  DepthPyramid depth;
  bool have_depth = false;
  const auto need_depth = [&]() -> const DepthPyramid& {
    if (!have_depth) {
      depth = ComputeDepth(frame);
      have_depth = true;
    }
    return depth;
  };
  s.retrack_keyframe.reset();

  start = std::chrono::steady_clock::now();
  // Every return goes through `finish`: the frame's pyramids are kept for MakeLastFrameReference.
  auto finish = [&](const TrackedFrame& result) {
    // Depth computed during tracking (a new reference, a re-track) is the depth stage's time.
    timings_.tracking_ms = std::max(MsSince(start) - timings_.depth_ms, 0.0);
    s.has_last_frame = true;
    s.last_frame = result;
    s.last_features = std::move(features);
    s.last_depth_pending = !have_depth;
    s.last_depth = have_depth ? std::move(depth) : DepthPyramid();
    if (keyframe_features_ || s.last_depth_pending) s.last_input = frame;
    return result;
  };
  TrackedFrame out;
  out.index = frame.index;
  out.timestamp_ns = frame.timestamp_ns;

  // A reference needs enough points: at least min_inliers_lost patches at the finest level.
  const int min_points = MinReferencePoints();
  auto make_reference = [&](const SE3d& world_from_cam) {
    // A switch from a tracked reference carries its depth scale over
    // (FrontendOptions::depth_scale).
    need_depth();
    if (s.reference.has_reference && PropagatesDepthScale()) {
      const double scale = DepthScaleFromReference(
          depth, world_from_cam.Inverse() * s.reference.world_from_ref, features.levels[0].camera);
      if (scale > 0.0) depth.Scale(scale);
    }
    const int points = tracker_.SetReference(features, depth);
    if (points < min_points) {
      s.reference.has_reference = false;
      return false;
    }
    s.reference = ReferenceState::Of(tracker_, frame.index, world_from_cam, features, depth);
    return true;
  };

  if (!s.reference.has_reference) {
    // First frame, or restart after a loss: this frame becomes the reference at the last good
    // pose (the gap in the trajectory is the preceding lost frame(s)).
    out.world_from_cam = s.world_from_last;
    out.num_points = 0;
    if (make_reference(s.world_from_last)) {
      out.status = TrackingStatus::kReference;
      out.is_new_reference = true;
      out.reference_index = frame.index;
      out.num_points = tracker_.num_reference_points(0);
      out.num_inliers = out.num_points;
      out.reference_parallax_depth = s.reference.reference_parallax_depth;
    } else {
      out.status = TrackingStatus::kLost;
      out.lost_cause =
          depth.NumValid(0) < MinReferenceDepths() ? LostCause::kNoDepth : LostCause::kFewPoints;
    }
    s.has_motion = false;
    s.last_from_prev = SE3d();
    return finish(out);
  }

  // Hypotheses (DSO): constant velocity, zero, half, double motion from the last good frame.
  const SE3d last_from_ref = s.world_from_last.Inverse() * s.reference.world_from_ref;
  const SE3d motion = s.has_motion ? s.last_from_prev : SE3d();
  // A result is lost when the tracker says so or its pose (against the current reference) is not
  // finite.
  const auto lost = [&](const TrackResult& r) {
    return r.status == TrackingStatus::kLost ||
           !IsFinite(s.reference.world_from_ref * r.cur_from_ref.Inverse());
  };
  TrackResult result = tracker_.Track(features, tracker_.MakeHypotheses(last_from_ref, motion));
  // Lost against the reference (FrontendOptions::retrack_on_loss), or a residual grown past
  // retrack_residual_ratio times the first one after the reference: once more against the
  // previous frame, which becomes the reference when that result is kept (a kept loss retry, or
  // a residual retry that fits better). MakeLastFrameReference switches only to a tracked frame
  // with enough depth; the previous frame is the last good pose here.
  const bool retrack_lost = lost(result) && options_.retrack_on_loss;
  const bool retrack_residual =
      !lost(result) && options_.retrack_residual_ratio > 0.0 && s.reference.first_rmse > 0.0 &&
      result.rmse > options_.retrack_residual_ratio * s.reference.first_rmse;
  if ((retrack_lost || retrack_residual) && s.has_last_frame &&
      s.last_frame.status != TrackingStatus::kLost &&
      s.last_frame.index != s.reference.reference_index) {
    const int old_reference = s.reference.reference_index;
    // A residual retry that does not fit better goes back to the reference it left.
    std::optional<Tracker> saved_tracker;
    std::optional<ReferenceState> saved_reference;
    if (!retrack_lost) {
      saved_tracker = tracker_;
      saved_reference = s.reference;
    }
    KeyframeData keyframe;
    if (MakeLastFrameReference(&keyframe)) {
      TrackResult retry = tracker_.Track(features, tracker_.MakeHypotheses(SE3d(), motion));
      if (!lost(retry) && (retrack_lost || retry.rmse < result.rmse)) {
        result = std::move(retry);
        out.retracked_from = old_reference;
        s.retrack_keyframe = std::move(keyframe);
      } else if (!retrack_lost) {
        tracker_ = std::move(*saved_tracker);
        s.reference = std::move(*saved_reference);
      }
    }
  }
  out.reference_index = s.reference.reference_index;
  out.reference_parallax_depth = s.reference.reference_parallax_depth;
  out.num_points = result.num_points;
  out.num_inliers = result.num_inliers;
  out.rmse = result.rmse;
  out.iterations = result.iterations;
  const SE3d world_from_cam = s.reference.world_from_ref * result.cur_from_ref.Inverse();
  if (lost(result)) {
    out.status = TrackingStatus::kLost;
    out.lost_cause = LostCause::kTracking;
    out.world_from_cam = s.world_from_last;  // the gap: the last good pose
    out.ref_from_cam = s.reference.world_from_ref.Inverse() * s.world_from_last;
    s.reference.has_reference = false;  // the next frame starts a fresh reference
    s.has_motion = false;
    s.last_from_prev = SE3d();
    return finish(out);
  }
  out.status = result.status;
  out.world_from_cam = world_from_cam;
  out.ref_from_cam = result.cur_from_ref.Inverse();
  s.last_from_prev = world_from_cam.Inverse() * s.world_from_last;
  s.has_motion = true;
  s.world_from_last = world_from_cam;
  if (s.reference.frames_since_reference == 0) s.reference.first_rmse = result.rmse;
  ++s.reference.frames_since_reference;

  // Reference switch (ReferenceOptions, policy "internal"): distance relative to the parallax
  // depth, rotation, inlier ratio, interval. A frame whose own depth is too sparse cannot become a
  // reference. With policy "external" the caller switches (MakeLastFrameReference).
  if (options_.reference.policy != "internal") return finish(out);
  const ReferenceOptions& ro = options_.reference;
  const double distance_ratio =
      s.reference.reference_parallax_depth > 0.0
          ? out.ref_from_cam.translation().norm() / s.reference.reference_parallax_depth
          : 0.0;
  const double rotation_deg = out.ref_from_cam.so3().Angle() * 180.0 / M_PI;
  const bool switch_reference = distance_ratio > ro.translation_ratio ||
                                rotation_deg > ro.rotation_deg ||
                                result.inlier_ratio < ro.min_inlier_ratio ||
                                s.reference.frames_since_reference >= ro.max_interval;
  if (switch_reference && need_depth().NumValid(0) >= MinReferenceDepths()) {
    if (make_reference(world_from_cam)) {
      out.is_new_reference = true;
    }
    // else: the tracker has no usable reference now; the next frame restarts from itself.
  }
  return finish(out);
}

bool Frontend::PropagatesDepthScale() const { return options_.depth_scale == "propagate"; }

double Frontend::DepthScaleFromReference(const DepthPyramid& depth, const SE3d& cam_from_ref,
                                         const PinholeCamera& camera) const {
  if (depth.num_levels() == 0) return 0.0;
  const ImageF& map = depth.levels[0];
  const std::vector<Eigen::Vector2i> points = tracker_.reference_points(0);
  const std::vector<float> depths = tracker_.reference_depths(0);
  std::vector<double> ratios;
  ratios.reserve(points.size());
  for (size_t i = 0; i < points.size() && i < depths.size(); ++i) {
    if (!(depths[i] > 0.0f)) continue;
    const Eigen::Vector3d p_ref =
        camera.Unproject(Eigen::Vector2d(points[i].x(), points[i].y()), double(depths[i]));
    const Eigen::Vector3d p_cam = cam_from_ref * p_ref;
    if (!(p_cam.z() > 0.0)) continue;
    const Eigen::Vector2d uv = camera.Project(p_cam);
    if (!camera.IsInImage(uv, 1.0)) continue;
    const int x = static_cast<int>(std::lround(uv.x())), y = static_cast<int>(std::lround(uv.y()));
    if (!map.InBounds(x, y)) continue;
    const double d = map(x, y);
    if (d > 0.0 && std::isfinite(d)) ratios.push_back(p_cam.z() / d);
  }
  if (static_cast<int>(ratios.size()) < kMinScalePairs) return 0.0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  const double scale = ratios[ratios.size() / 2];
  return std::isfinite(scale) && scale > 0.0 ? scale : 0.0;
}

int Frontend::MinReferencePoints() const { return std::max(options_.tracker.min_inliers_lost, 12); }

DepthPyramid Frontend::ComputeDepth(const Frame& frame) {
  const auto start = std::chrono::steady_clock::now();
  DepthPyramid depth = depth_->Compute(frame, options_.tracker.num_levels);
  timings_.depth_ms += MsSince(start);
  return depth;
}

int Frontend::MinReferenceDepths() const {
  return MinReferencePoints() * options_.tracker.patch_size * options_.tracker.patch_size;
}

bool Frontend::MakeLastFrameReference(KeyframeData* keyframe) {
  State& s = *state_;
  if (!s.has_last_frame || s.last_frame.status == TrackingStatus::kLost) return false;
  const TrackedFrame& last = s.last_frame;
  const bool already = s.reference.has_reference && s.reference.reference_index == last.index;
  if (s.last_depth_pending) {
    s.last_depth = ComputeDepth(s.last_input);
    s.last_depth_pending = false;
  }
  if (!already) {
    if (s.last_depth.num_levels() == 0 || s.last_depth.NumValid(0) < MinReferenceDepths()) {
      return false;  // keep tracking against the current reference
    }
    if (s.reference.has_reference && PropagatesDepthScale() && !s.last_features.levels.empty()) {
      const double scale = DepthScaleFromReference(
          s.last_depth, last.world_from_cam.Inverse() * s.reference.world_from_ref,
          s.last_features.levels[0].camera);
      if (scale > 0.0) s.last_depth.Scale(scale);
    }
    const int points = tracker_.SetReference(s.last_features, s.last_depth);
    if (points < MinReferencePoints()) {
      // As the internal rule: the next frame restarts from itself.
      s.reference.has_reference = false;
      return false;
    }
    s.reference = ReferenceState::Of(tracker_, last.index, last.world_from_cam, s.last_features,
                                     s.last_depth);
  }
  if (keyframe != nullptr) {
    keyframe->frame_index = last.index;
    keyframe->timestamp_ns = last.timestamp_ns;
    keyframe->world_from_cam = last.world_from_cam;
    keyframe->features =
        keyframe_features_ ? keyframe_features_->Compute(s.last_input, options_.tracker.num_levels)
                           : s.last_features;
    keyframe->depth = s.last_depth;
  }
  return true;
}

bool Frontend::TakeRetrackKeyframe(KeyframeData* keyframe) {
  State& s = *state_;
  if (!s.retrack_keyframe) return false;
  *keyframe = std::move(*s.retrack_keyframe);
  s.retrack_keyframe.reset();
  return true;
}

bool Frontend::SetReferenceDepth(int frame_index, const DepthPyramid& depth) {
  State& s = *state_;
  if (!s.reference.has_reference || s.reference.reference_index != frame_index) return false;
  const int num_levels = options_.tracker.num_levels;
  if (depth.num_levels() < num_levels) {
    throw InputError("reference depth for frame " + std::to_string(frame_index) + ": " +
                     std::to_string(depth.num_levels()) + " levels given, the tracker uses " +
                     std::to_string(num_levels));
  }
  for (int l = 0; l < num_levels; ++l) {
    const ImageF& given = depth.levels[l];
    const ImageF& own = s.reference.reference_depth.levels[l];
    if (given.width() != own.width() || given.height() != own.height() || given.channels() != 1) {
      throw InputError("reference depth for frame " + std::to_string(frame_index) + ": level " +
                       std::to_string(l) + " is " + std::to_string(given.width()) + "x" +
                       std::to_string(given.height()) + "x" + std::to_string(given.channels()) +
                       ", the frame's depth is " + std::to_string(own.width()) + "x" +
                       std::to_string(own.height()) + "x1");
    }
  }
  if (depth.NumValid(0) < MinReferenceDepths() ||
      tracker_.SetReference(s.reference.reference_features, depth) < MinReferencePoints()) {
    // Back to the depth the reference had (the source's, which made a usable reference).
    tracker_.SetReference(s.reference.reference_features, s.reference.reference_depth);
    return false;
  }
  s.reference.reference_parallax_depth = tracker_.reference_parallax_depth(0);
  return true;
}

const DepthPyramid& Frontend::reference_source_depth() const {
  return state_->reference.reference_depth;
}

}  // namespace dfo
