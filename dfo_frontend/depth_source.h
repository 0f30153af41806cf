// Depth pyramids for direct alignment, and the sources that compute them.
//
// A DepthSource gives, per pyramid level, a depth map in metres (0 = invalid) aligned with the
// feature level of the same index. Now: ground truth (Frame::depth_m, e.g. the synthetic depth_0
// or TUM depth PNGs); later the depth network plugs into the same interface.
#ifndef DFO_FRONTEND_DEPTH_SOURCE_H_
#define DFO_FRONTEND_DEPTH_SOURCE_H_

#include <memory>
#include <string>
#include <vector>

#include "dfo_core/feature_map.h"  // DepthPyramid
#include "dfo_core/frame.h"
#include "dfo_core/image.h"
#include "dfo_core/image_pyramid.h"

namespace dfo {

// DownsampleDepthHalf (validity-aware 2x2 averaging of depth maps): dfo_core/image_pyramid.h.

// Computes depth pyramids from frames. Implementations must be deterministic.
class DepthSource {
 public:
  virtual ~DepthSource() = default;
  // Short name used in configurations ("gt", ...).
  virtual std::string name() const = 0;
  // The depth pyramid of `frame` with `num_levels` levels. Throws InputError when the source
  // cannot produce depth for this frame (e.g. "gt" and a frame without depth, or a depth map
  // whose size differs from the image's). A map full of zeros or NaN is NOT an error: it gives
  // an all-invalid pyramid, and tracking reports the frame lost.
  virtual DepthPyramid Compute(const Frame& frame, int num_levels) = 0;
  // Throws the InputError that Compute would throw for this frame's input, without computing
  // the depth (Frontend::Process checks every frame, and computes the depth only for frames that
  // become references). The default checks nothing.
  virtual void Check(const Frame& frame, int num_levels) const {
    (void)frame;
    (void)num_levels;
  }
};

// Ground-truth depth: Frame::depth_m (non-finite and negative values become 0 = invalid), then
// DownsampleDepthHalf per level.
class GroundTruthDepthSource : public DepthSource {
 public:
  std::string name() const override { return "gt"; }
  DepthPyramid Compute(const Frame& frame, int num_levels) override;
  void Check(const Frame& frame, int num_levels) const override;
};

// Creates the depth source called `name` ("gt"). Throws ConfigError naming the value and the
// known names otherwise; for "learned" the ConfigError says that the learned source comes from a
// model file loaded by the application (MakeLearnedDepthSource in dfo::learned).
std::unique_ptr<DepthSource> MakeDepthSource(const std::string& name);

}  // namespace dfo

#endif  // DFO_FRONTEND_DEPTH_SOURCE_H_
