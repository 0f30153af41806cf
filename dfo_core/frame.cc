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

}  // namespace dfo
