// Options of dfo's procedural synthetic street sequence (the embedded default data set).
#ifndef DFO_CORE_SYNTHETIC_OPTIONS_H_
#define DFO_CORE_SYNTHETIC_OPTIONS_H_

#include <cstdint>

#include "dfo_core/camera.h"

namespace dfo {

// Everything that defines a synthetic sequence. Two sequences built from equal options are
// identical pixel for pixel; the seed alone changes the world and the drive (use different seeds
// for training and test sequences).
struct SyntheticOptions {
  // Seed of the world layout, the path, the speed profile and the textures. Any value.
  uint64_t seed = 1;
  // Number of frames, >= 1.
  int num_frames = 500;
  // Image size in pixels, each in [16, 4096]. Default 416 x 128 as the KITTI-trained networks.
  int width = 416;
  int height = 128;
  // Horizontal field of view in degrees, in (10, 150). 80 deg is KITTI's left camera (about 81).
  // fx = fy = 0.5 * width / tan(fov / 2); principal point at the image centre.
  double horizontal_fov_deg = 80.0;
  // Height of the camera above the road in metres, in [0.3, 5] (KITTI: 1.65).
  double camera_height_m = 1.65;
  // Time between frames in seconds, > 0 (KITTI: 0.1).
  double frame_interval_s = 0.1;
  // Baseline of the virtual right camera written to calib.txt (P1, P3) in metres, >= 0
  // (KITTI: 0.54). Only calibration; the right images are not rendered.
  double stereo_baseline_m = 0.54;
  // Depths beyond this distance (metres) are reported as 0 = "no depth", in (1, 255.99]; the
  // 16-bit depth PNG (metres * 256) cannot hold more than 255.99 m.
  double max_depth_m = 255.0;
  // Supersample (3 x 3) the pixels on silhouettes between surfaces, so that geometric edges are
  // anti-aliased like the textures. Off gives hard, aliased edges (slightly faster).
  bool antialias_edges = true;
  // Width of the texture filter in pixels (1 = a box over the pixel footprint), in [0.5, 4].
  // Larger is blurrier. 1.5 mimics a real lens's blur a little and keeps sharp pattern edges
  // (markings, window frames) smooth enough for bilinear image warping, as tracking does.
  double texture_filter_scale = 1.5;

  // Throws dfo::ConfigError naming the field, its value and the violated rule.
  void Check() const;
  // The pinhole camera these options describe.
  PinholeCamera Camera() const;
};

}  // namespace dfo

#endif  // DFO_CORE_SYNTHETIC_OPTIONS_H_
