#include "apps/common/backend_config.h"

#include "dfo_core/error.h"

namespace dfo::apps {

const char* RunModeName(RunMode mode) {
  switch (mode) {
    case RunMode::kFrontend:
      return "frontend";
    case RunMode::kWindowed:
      return "windowed";
    case RunMode::kBoth:
      return "both";
  }
  return "unknown";
}

RunMode ParseRunMode(const std::string& value) {
  if (value == "frontend") return RunMode::kFrontend;
  if (value == "windowed") return RunMode::kWindowed;
  if (value == "both") return RunMode::kBoth;
  throw ConfigError("run.mode = " + value + " violates one of {frontend, windowed, both}");
}

RunMode RunModeFromConfig(const io::Config& config) {
  return ParseRunMode(config.GetString("run.mode"));
}

KeyframeOptions KeyframeOptionsFromConfig(const io::Config& config) {
  KeyframeOptions o;
  o.translation_ratio = config.GetDouble("keyframe.translation_ratio");
  o.rotation_deg = config.GetDouble("keyframe.rotation_deg");
  o.residual_ratio = config.GetDouble("keyframe.residual_ratio");
  o.min_inlier_ratio = config.GetDouble("keyframe.min_inlier_ratio");
  o.min_interval = config.GetInt("keyframe.min_interval");
  o.max_interval = config.GetInt("keyframe.max_interval");
  o.Check();
  return o;
}

std::string ReferencePolicyFromConfig(const io::Config& config) {
  return config.GetString("keyframe.decided_by") == "manager" ? "external" : "internal";
}

}  // namespace dfo::apps
