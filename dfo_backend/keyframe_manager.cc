#include "dfo_backend/keyframe_manager.h"

#include <cmath>
#include <sstream>
#include <string>

#include "dfo_core/error.h"

namespace dfo {
namespace {

// Throws ConfigError "keyframe.<field> = <value> violates <rule>" unless ok.
template <typename T>
void CheckKey(bool ok, const char* field, const T& value, const std::string& rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << "keyframe." << field << " = " << value << " violates " << rule;
  throw ConfigError(msg.str());
}

}  // namespace

void KeyframeOptions::Check() const {
  CheckKey(std::isfinite(translation_ratio) && translation_ratio > 0.0, "translation_ratio",
           translation_ratio, "> 0");
  CheckKey(std::isfinite(rotation_deg) && rotation_deg > 0.0 && rotation_deg <= 180.0,
           "rotation_deg", rotation_deg, "in (0, 180]");
  CheckKey(std::isfinite(residual_ratio) && residual_ratio >= 1.0, "residual_ratio", residual_ratio,
           ">= 1");
  CheckKey(std::isfinite(min_inlier_ratio) && min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0,
           "min_inlier_ratio", min_inlier_ratio, "in [0, 1]");
  CheckKey(min_interval >= 1, "min_interval", min_interval, ">= 1");
  CheckKey(max_interval >= 1, "max_interval", max_interval, ">= 1");
  CheckKey(min_interval <= max_interval, "min_interval", min_interval,
           "<= keyframe.max_interval (" + std::to_string(max_interval) + ")");
}

const char* KeyframeReasonName(KeyframeReason reason) {
  switch (reason) {
    case KeyframeReason::kNone:
      return "none";
    case KeyframeReason::kRestart:
      return "restart";
    case KeyframeReason::kTranslation:
      return "translation";
    case KeyframeReason::kRotation:
      return "rotation";
    case KeyframeReason::kResidual:
      return "residual";
    case KeyframeReason::kInlierRatio:
      return "inlier_ratio";
    case KeyframeReason::kMaxInterval:
      return "max_interval";
    case KeyframeReason::kRetrack:
      return "retrack";
  }
  return "unknown";
}

KeyframeManager::KeyframeManager(const KeyframeOptions& options)
    : options_((options.Check(), options)) {}

KeyframeDecision KeyframeManager::Decide(const TrackedFrame& frame) {
  KeyframeDecision d;
  if (frame.status == TrackingStatus::kReference) {
    // The frontend made this frame its reference by itself (first frame, restart after a loss):
    // it is a keyframe whatever min_interval says.
    d.new_keyframe = true;
    d.reason = KeyframeReason::kRestart;
    return d;
  }
  if (frame.reference_index != keyframe_index_ && frame.reference_index >= 0) {
    // Tracked against a reference this manager did not choose: count from there.
    keyframe_index_ = frame.reference_index;
    frames_since_keyframe_ = 0;
    first_rmse_ = -1.0;
  }
  ++frames_since_keyframe_;
  d.frames_since_keyframe = frames_since_keyframe_;
  if (frame.status == TrackingStatus::kLost) {
    return d;  // never a keyframe; the frontend restarts from the next frame
  }

  d.translation_ratio = frame.reference_parallax_depth > 0.0
                            ? frame.ref_from_cam.translation().norm() / frame.reference_parallax_depth
                            : 0.0;
  d.rotation_deg = frame.ref_from_cam.so3().Angle() * 180.0 / M_PI;
  d.inlier_ratio =
      frame.num_points > 0 ? static_cast<double>(frame.num_inliers) / frame.num_points : 1.0;
  if (first_rmse_ < 0.0) {
    first_rmse_ = frame.rmse;  // DSO: the residual of the first frame after the keyframe
  }
  d.residual_ratio = first_rmse_ > 0.0 ? frame.rmse / first_rmse_ : 0.0;

  if (frames_since_keyframe_ < options_.min_interval) return d;
  if (d.translation_ratio > options_.translation_ratio) {
    d.reason = KeyframeReason::kTranslation;
  } else if (d.rotation_deg > options_.rotation_deg) {
    d.reason = KeyframeReason::kRotation;
  } else if (first_rmse_ > 0.0 && d.residual_ratio > options_.residual_ratio) {
    d.reason = KeyframeReason::kResidual;
  } else if (d.inlier_ratio < options_.min_inlier_ratio) {
    d.reason = KeyframeReason::kInlierRatio;
  } else if (frames_since_keyframe_ >= options_.max_interval) {
    d.reason = KeyframeReason::kMaxInterval;
  }
  d.new_keyframe = d.reason != KeyframeReason::kNone;
  return d;
}

void KeyframeManager::AcceptKeyframe(int frame_index) {
  keyframe_index_ = frame_index;
  ++num_keyframes_;
  frames_since_keyframe_ = 0;
  first_rmse_ = -1.0;
}

}  // namespace dfo
