// dfo's procedural synthetic street sequence: a KITTI-like drive through a textured street world,
// rendered in memory by the project itself, with exact ground-truth poses and depth.
//
//   SyntheticOptions options;           // 500 frames of 416 x 128, seed 1
//   options.num_frames = 20;
//   SyntheticSequence sequence(options);
//   SyntheticFrame frame = sequence.RenderFrame(3);  // gray, rgb, depth, pose of frame 3
//
// Frames (conventions of KITTI odometry): camera frame x right, y down, z forward; the world frame
// is the first camera's, so WorldFromCam(0) is the identity; timestamps are k * frame_interval_s.
// The path, the poses and the scene are generated in the constructor (about 50 ms for 500 frames);
// each frame is rendered on demand (about 40 ms on one core at 416 x 128, measured on the 2-core
// development machine), so tests can render just the frames they need.
#ifndef DFO_CORE_SYNTHETIC_SYNTHETIC_SEQUENCE_H_
#define DFO_CORE_SYNTHETIC_SYNTHETIC_SEQUENCE_H_

#include <cstdint>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"
#include "dfo_core/lie.h"
#include "dfo_core/synthetic/options.h"
#include "dfo_core/synthetic/renderer.h"
#include "dfo_core/synthetic/world.h"
#include "dfo_core/trajectory.h"

namespace dfo {

// One rendered frame with its ground truth.
struct SyntheticFrame {
  int index = 0;             // frame number, 0-based
  int64_t timestamp_ns = 0;  // index * frame_interval_s
  SE3d world_from_cam;       // ground-truth pose (camera-to-world, world = first camera)
  ImageU8 gray;              // 8-bit grey (KITTI image_0)
  ImageU8 rgb;               // 8-bit RGB (KITTI image_2; rendered from the same pose as gray)
  ImageF depth;              // z-depth in metres, 0 = no depth (sky, beyond max_depth_m)
  ImageU8 labels;            // synthetic::SurfaceClass of every pixel
};

// The sequence: options, camera, path, scene and ground truth, and the renderer.
class SyntheticSequence {
 public:
  // Builds the world and the drive. Throws dfo::ConfigError when options.Check() fails.
  explicit SyntheticSequence(const SyntheticOptions& options);

  const SyntheticOptions& options() const { return options_; }
  int num_frames() const { return options_.num_frames; }
  // Intrinsics of every frame (options.Camera()).
  const PinholeCamera& camera() const { return camera_; }
  // Ground-truth pose of frame i (0 <= i < num_frames), camera-to-world.
  const SE3d& WorldFromCam(int i) const;
  // Timestamp of frame i in nanoseconds.
  int64_t TimestampNs(int i) const;
  // All ground-truth poses with their timestamps.
  Trajectory GroundTruth() const;
  // Renders frame i with `num_threads` threads (the pixels do not depend on the count).
  SyntheticFrame RenderFrame(int i, int num_threads = 1) const;
  // Renders the view of an arbitrary pose world_from_cam (e.g. between frames, or a perturbed
  // pose for tests), with the sequence's camera.
  synthetic::RenderedView RenderPose(const SE3d& world_from_cam, int num_threads = 1) const;

  // The generated world (map frame) and the transform from the world frame to it.
  const synthetic::SyntheticWorld& world() const { return world_; }
  const SE3d& map_from_world() const { return map_from_world_; }

 private:
  SyntheticOptions options_;
  PinholeCamera camera_;
  synthetic::SyntheticWorld world_;
  SE3d map_from_world_;
  std::vector<SE3d> world_from_cam_;
};

}  // namespace dfo

#endif  // DFO_CORE_SYNTHETIC_SYNTHETIC_SEQUENCE_H_
