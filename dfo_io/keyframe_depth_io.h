// Keyframe depth folders: the depth each keyframe's window points settled on, with their
// confidence and the keyframes' windowed poses, as dfo_run writes them (run.write_keyframe_depth)
// for training a depth network on the system's own geometry. A folder holds
//
//   keyframe_depth.txt   what the run was: "format dfo_keyframe_depth 1", "sequence NAME",
//                        "image_size W H" (the frames the run processed), "camera fx fy cx cy"
//                        (their intrinsics; pixel centres at integers)
//   keyframes.txt        one line per keyframe, oldest first: "frame timestamp_s tx ty tz qx qy
//                        qz qw points image": the frame's number in the recording, its time, its
//                        windowed pose world_from_cam (TUM order), the number of lines of its
//                        points file and its image as the rest of the line (a file path, or
//                        "VIDEO#n": frame n of the video file VIDEO; "-": none)
//   points/FRAME.txt     one line per point (FRAME: the frame number, 6 digits): "u v depth_m
//                        start_depth_m observations rms_residual": pixel at image_size, the
//                        window's depth and the depth it started at (metres at the run's scale,
//                        one scale for the whole run), the keyframes it was compared in and its
//                        RMS feature residual (z-score units)
//
// Lines starting with '#' and blank lines are skipped. The depths carry the run's arbitrary
// monocular scale (drifting slowly along a run); a reader fits its own scale.
#ifndef DFO_IO_KEYFRAME_DEPTH_IO_H_
#define DFO_IO_KEYFRAME_DEPTH_IO_H_

#include <cstdint>
#include <string>
#include <vector>

#include "dfo_core/lie.h"

namespace dfo::io {

struct KeyframeDepthPoint {
  double u = 0.0, v = 0.0;
  double depth_m = 0.0;
  double start_depth_m = 0.0;
  int observations = 0;
  double rms_residual = 0.0;
};

struct KeyframeDepthEntry {
  int frame = 0;  // number in the recording
  int64_t timestamp_ns = 0;
  SE3d world_from_cam;
  std::string image;  // image file, "VIDEO#n" (frame n of a video file) or "-" (none)
  std::vector<KeyframeDepthPoint> points;
};

struct KeyframeDepthFolder {
  std::string sequence;  // e.g. "KITTI 03"
  int image_width = 0, image_height = 0;
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  std::vector<KeyframeDepthEntry> keyframes;
};

// Writes the folder (created when missing; files of an earlier folder replaced, stale point
// files removed). Throws InputError naming the file that cannot be written.
void WriteKeyframeDepthFolder(const std::string& folder, const KeyframeDepthFolder& data);

// Reads and checks a folder: every file present, numbers finite, image size and camera positive,
// frames strictly increasing, quaternions of unit norm, each points file with the announced
// number of lines, points inside the image, depths > 0, observations >= 0. Throws InputError
// naming the file (and line) of the first problem.
KeyframeDepthFolder ReadKeyframeDepthFolder(const std::string& folder);

}  // namespace dfo::io

#endif  // DFO_IO_KEYFRAME_DEPTH_IO_H_
