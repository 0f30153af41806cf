#include "dfo_frontend/depth_source.h"

#include <cmath>
#include <sstream>

#include "dfo_core/error.h"

namespace dfo {

void GroundTruthDepthSource::Check(const Frame& frame, int num_levels) const {
  DFO_CHECK(num_levels >= 1) << num_levels;
  if (frame.depth_m.empty()) {
    throw InputError("frame " + std::to_string(frame.index) +
                     ": depth source 'gt' needs a ground-truth depth map (Frame::depth_m), "
                     "but the frame has none");
  }
  if (frame.depth_m.channels() != 1 || frame.depth_m.width() != frame.image.width() ||
      frame.depth_m.height() != frame.image.height()) {
    std::ostringstream msg;
    msg << "frame " << frame.index << ": depth map is " << frame.depth_m.width() << "x"
        << frame.depth_m.height() << "x" << frame.depth_m.channels() << " but the image is "
        << frame.image.width() << "x" << frame.image.height()
        << "; expected a 1-channel depth map of the image's size";
    throw InputError(msg.str());
  }
  int width = frame.depth_m.width(), height = frame.depth_m.height();
  for (int l = 1; l < num_levels; ++l) {
    if (width < 2 || height < 2) {
      std::ostringstream msg;
      msg << "frame " << frame.index << ": a " << frame.depth_m.width() << "x"
          << frame.depth_m.height() << " depth map cannot have " << num_levels << " levels";
      throw InputError(msg.str());
    }
    width /= 2;
    height /= 2;
  }
}

DepthPyramid GroundTruthDepthSource::Compute(const Frame& frame, int num_levels) {
  Check(frame, num_levels);
  DepthPyramid out;
  ImageF level0 = frame.depth_m;
  for (float& d : level0.vector()) {
    if (!std::isfinite(d) || d < 0.0f) d = 0.0f;
  }
  out.levels.push_back(std::move(level0));
  for (int l = 1; l < num_levels; ++l) out.levels.push_back(DownsampleDepthHalf(out.levels.back()));
  return out;
}

std::unique_ptr<DepthSource> MakeDepthSource(const std::string& name) {
  if (name == "gt") return std::make_unique<GroundTruthDepthSource>();
  if (name == "learned") {
    // See MakeFeatureSource: the depth network needs a model loaded by the application.
    throw ConfigError(
        "frontend.depth = learned: the learned depth source comes from a model file loaded by "
        "the application (learned.model; dfo_run and dfo_bench do this), not from "
        "MakeDepthSource");
  }
  throw ConfigError("frontend.depth = " + name + " violates one of {gt, learned}");
}

}  // namespace dfo
