#include "dfo_core/frame.h"

namespace dfo {

const char* TrackingStatusName(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kOk:
      return "ok";
    case TrackingStatus::kDegraded:
      return "degraded";
    case TrackingStatus::kLost:
      return "lost";
    case TrackingStatus::kReference:
      return "reference";
  }
  return "unknown";
}

const char* LostCauseName(LostCause cause) {
  switch (cause) {
    case LostCause::kNone:
      return "";
    case LostCause::kTracking:
      return "tracking";
    case LostCause::kNoDepth:
      return "no_depth";
    case LostCause::kFewPoints:
      return "few_points";
  }
  return "unknown";
}

}  // namespace dfo
