// Writes a synthetic sequence to disk in the KITTI odometry layout, so every dataset tool of dfo
// (and any KITTI tool) reads it like the real thing:
//
//   <output_dir>/sequences/<NN>/image_0/000000.png   8-bit grey (left camera)
//   <output_dir>/sequences/<NN>/image_2/000000.png   8-bit RGB (same pose as image_0)
//   <output_dir>/sequences/<NN>/depth_0/000000.png   16-bit z-depth of image_0, metres = value/256,
//                                                    0 = no depth (sky, beyond max_depth_m)
//   <output_dir>/sequences/<NN>/calib.txt            rows "P0:" .. "P3:", 12 numbers each
//   <output_dir>/sequences/<NN>/times.txt            seconds, one line per frame
//   <output_dir>/poses/<NN>.txt                      KITTI poses, world_from_cam, first identity
//
// calib.txt follows KITTI: P0 = K [I | 0] (grey left), P1 = K [I | -b e_x] (virtual right camera
// at baseline b, 4th entry -fx * b), P2 = P0 (the colour images are rendered from camera 0's
// pose, unlike KITTI's separate colour camera), P3 = P1.
#ifndef DFO_IO_SYNTH_WRITER_H_
#define DFO_IO_SYNTH_WRITER_H_

#include <functional>
#include <string>

#include "dfo_core/camera.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_core/trajectory.h"

namespace dfo::io {

// Where and how to write a synthetic sequence.
struct SynthWriteOptions {
  // Root of the KITTI-style tree; created when missing.
  std::string output_dir;
  // Sequence name, the <NN> of the layout: 1 to 16 characters of [0-9A-Za-z_-] (KITTI: "00").
  std::string sequence = "00";
  // Frames rendered and written in parallel, >= 1 (each thread renders whole frames).
  int num_threads = 2;
  // Write image_2 (RGB) and depth_0 as well as image_0.
  bool write_rgb = true;
  bool write_depth = true;

  // Throws dfo::ConfigError naming the field, its value and the rule.
  void Check() const;
};

// Progress report, given to the callback while frames are written.
struct SynthWriteProgress {
  int frames_done = 0;        // frames completely written
  int num_frames = 0;         // frames in total
  double elapsed_s = 0.0;     // wall time since the start
  double frames_per_s = 0.0;  // frames_done / elapsed_s
  double eta_s = 0.0;         // estimated seconds left
};

// What was written.
struct SynthWriteSummary {
  int num_frames = 0;
  double seconds = 0.0;      // wall time of rendering and writing
  std::string sequence_dir;  // <output_dir>/sequences/<NN>
  std::string poses_path;    // <output_dir>/poses/<NN>.txt
};

// Renders every frame of `sequence` and writes the tree above. `progress` (optional) is called
// from the calling thread about every `progress_interval_s` seconds and once at the end. Throws
// dfo::InputError naming the path when something cannot be written.
SynthWriteSummary WriteSyntheticSequence(
    const SyntheticSequence& sequence, const SynthWriteOptions& options,
    const std::function<void(const SynthWriteProgress&)>& progress = {},
    double progress_interval_s = 1.0);

// Writes a KITTI calib.txt for `camera` with the rows described above (P0..P3).
void WriteKittiCalibration(const std::string& path, const PinholeCamera& camera,
                           double stereo_baseline_m);

// Writes a KITTI times.txt: one line per pose, its timestamp in seconds.
void WriteKittiTimes(const std::string& path, const Trajectory& trajectory);

// File name of frame i in the KITTI layout: "000042.png".
std::string KittiFrameName(int i);

}  // namespace dfo::io

#endif  // DFO_IO_SYNTH_WRITER_H_
