// TUM RGB-D sequences (Sturm et al., IROS 2012).
//
//   <path>/rgb.txt          "timestamp filename" per line ('#' comments), times strictly increasing
//   <path>/depth.txt        same for the 16-bit depth PNGs (metres = value / depth_scale)
//   <path>/groundtruth.txt  optional, "timestamp tx ty tz qx qy qz qw" (world_from_cam)
//   <path>/camera.yaml      optional intrinsics and lens (dfo_io/camera_yaml.h; may set
//                           depth_scale); dataset.camera names another file (then required)
//
// Frames are the rgb.txt entries (all of them: a frame without a depth match has no depth).
// Depth association follows TUM's associate.py: all (rgb, depth) pairs closer than
// tum_max_depth_diff (strictly), taken greedily in order of increasing time difference, each
// stamp used once. Ground truth per frame (tum_gt_mode):
//  - interpolate: between the two ground-truth poses bracketing the frame time when they are at
//    most tum_max_gt_gap apart: linear in position, slerp in rotation; a frame outside the
//    ground truth's time span (or inside a larger gap) falls back to `nearest`.
//  - nearest: the ground-truth pose nearest in time when within tum_max_gt_diff.
// Frames the rule gives no pose have none (FrameInfo::world_from_cam empty).
//
// Intrinsics rule: dataset.camera when set, else camera.yaml in the folder when present (a lens
// with distortion: images and depth maps undistorted, dfo_io/lens.h); otherwise the TUM benchmark's
// calibrated colour intrinsics of the sensor named by the folder name (first match of "freiburg1",
// "freiburg2", "freiburg3" or "fr1", "fr2", "fr3", case-insensitive):
//   fr1: fx 517.3 fy 516.5 cx 318.6 cy 255.3   fr2: 520.9 521.0 325.1 249.7
//   fr3: 535.4 539.2 320.1 247.6               (640 x 480; depth scale 5000)
// fr1/fr2 images carry lens distortion that these defaults ignore (pinhole model): give a
// camera.yaml with `model: radtan` and the sensor's coefficients for accurate results. No
// camera.yaml and no such name: InputError.
#ifndef DFO_IO_TUM_DATASET_H_
#define DFO_IO_TUM_DATASET_H_

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/lie.h"
#include "dfo_core/trajectory.h"
#include "dfo_io/dataset.h"

namespace dfo::io {

// One line of rgb.txt / depth.txt.
struct TumListEntry {
  int64_t timestamp_ns = 0;
  std::string file;  // as written (relative to the sequence folder)
  int line = 0;      // 1-based line in the list file
};

// Reads rgb.txt / depth.txt. InputError naming file and line for a malformed line ("expected
// 'timestamp filename'"), a non-numeric time or a time not after the previous one ("timestamps
// going backwards"); also when the file is missing.
std::vector<TumListEntry> ReadTumFileList(const std::string& path);

// associate.py's matching of two increasing stamp lists: pairs (index in a, index in b) with
// |a - b| < max_diff_ns, chosen greedily by increasing difference, each index used at most once;
// returned sorted by the index in a.
std::vector<std::pair<size_t, size_t>> AssociateTumStamps(const std::vector<int64_t>& a,
                                                          const std::vector<int64_t>& b,
                                                          int64_t max_diff_ns);

// Pose at fraction alpha in [0, 1] between a (alpha 0) and b (alpha 1): positions linearly,
// rotations by quaternion slerp.
SE3d InterpolatePose(const SE3d& a, const SE3d& b, double alpha);

// Ground-truth pose at time t by the rule of the file comment (mode "interpolate" or "nearest";
// times in nanoseconds). `gt` must be in increasing time order. Empty when the rule finds none.
std::optional<SE3d> GroundTruthAt(const Trajectory& gt, int64_t t_ns, const std::string& mode,
                                  int64_t max_diff_ns, int64_t max_gap_ns);

// The folder-name rule of the file comment: true and the camera (640 x 480) when `folder`'s name
// names a freiburg sensor; `sensor` receives "fr1", "fr2" or "fr3".
bool TumDefaultCamera(const std::string& folder, PinholeCamera* camera, std::string* sensor);

// Opens a TUM RGB-D sequence folder (see the file comment) as a Sequence.
Sequence OpenTumSequence(const DatasetOptions& options);

}  // namespace dfo::io

#endif  // DFO_IO_TUM_DATASET_H_
