// An estimate of a run's peak memory from its frame size and options, made before the first
// frame, so that a size the machine cannot hold is refused up front instead of swapping or being
// killed half-way (dfo_run compares it with run.memory_limit_mb).
//
//   MemoryEstimate m = EstimatePeakMemory({width, height, channels, network_pixels}, odometry);
//   if (m.total_mib > limit) ... m.Describe() ...
//
// The estimate adds what grows with the frame size to the process's fixed part (libraries, a
// model):
//   frames    the frontend's working frames, feature and depth pyramids, reference maps and the
//             keyframe data handed to the window: (57 + 44 C) bytes a pixel, C = feature channels
//             (fitted to dfo_run's peak resident memory with 1, 3 and 5 hand-made channels);
//   window    max_keyframes + 1 keyframes, each with its features and depth at the window's
//             pyramid level, its zoom-blurred copies (window.zoom_blur_sigma_px) and its coarse
//             level (window.coarse_iterations): 4 (C (1 + zooms) + 1) bytes a pixel there;
//   stereo    the keyframe stereo (stereo.views > 0): its cost volume, 4 bytes a pixel and depth
//             sample (stereo.depth_samples), and 8 bytes a pixel a view (measured together: 219
//             bytes a pixel with 3 views and 64 samples, 256 + 24 estimated);
//   network   the activations of a network run on network_pixels pixels a frame: 220 bytes a
//             pixel (measured with models/kitti.dfo's depth network at 416 x 128 to 1664 x 512);
// each of these times 1.2, plus 210 MiB (dfo_run at 416 x 128 peaks at 205-220 MiB). Measured with `tools/memory_check.sh` (configs/demo.yaml,
// configs/kitti.yaml, 416 x 128 to 3328 x 1024, 11 settings): the peak resident memory stays below
// the estimate, which is 1.1 to 1.6 times the peak (the most for a frontend-only run and for a
// network run at the frame size).
#ifndef DFO_BACKEND_MEMORY_ESTIMATE_H_
#define DFO_BACKEND_MEMORY_ESTIMATE_H_

#include <cstdint>
#include <string>

#include "dfo_backend/odometry.h"

namespace dfo {

// What the run processes.
struct MemoryEstimateInput {
  int width = 0;                // frames as processed (pixels)
  int height = 0;               //
  int feature_channels = 3;     // channels of the finest feature level (hand-made: 1, 3 or 5)
  int64_t network_pixels = 0;   // pixels a network runs on per frame; 0 = no network
};

// Peak resident memory in MiB, in parts (each part includes its share of the 1.2 margin).
struct MemoryEstimate {
  double fixed_mib = 0.0;
  double frames_mib = 0.0;
  double window_mib = 0.0;
  double stereo_mib = 0.0;
  double network_mib = 0.0;
  double total_mib = 0.0;
  // "3400 MiB: 175 fixed + 900 frames + 2100 window (8 keyframes) + ..." (the non-zero parts).
  std::string Describe() const;
};

MemoryEstimate EstimatePeakMemory(const MemoryEstimateInput& input,
                                  const OdometryOptions& odometry);

}  // namespace dfo

#endif  // DFO_BACKEND_MEMORY_ESTIMATE_H_
