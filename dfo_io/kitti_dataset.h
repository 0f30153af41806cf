// KITTI odometry sequences (and dfo's synthetic sequences, written in the same layout).
//
//   <path>/sequences/<seq>/image_0/NNNNNN.png   left gray camera (camera 0)
//   <path>/sequences/<seq>/image_2/NNNNNN.png   left colour camera (camera 2), optional
//   <path>/sequences/<seq>/depth_0/NNNNNN.png   optional depth of camera 0, 16-bit, metres = v/256
//   <path>/sequences/<seq>/depth_2/NNNNNN.png   optional depth of camera 2
//   <path>/sequences/<seq>/calib.txt            rows "P0: <12 numbers>" .. "P3:", maybe "Tr:"
//   <path>/sequences/<seq>/times.txt            one time in seconds per image
//   <path>/poses/<seq>.txt                      optional ground truth of camera 0 (KITTI format)
//
// `path` may also be the sequence folder itself (the one holding calib.txt); the ground truth is
// then looked for in <path>/../../poses/<folder name>.txt.
//
// Camera choice: options.color selects image_2 with P2 when image_2 exists (else image_0's gray
// pixels replicated to RGB); gray selects image_0 with P0 (else image_2 converted to gray).
// Ground truth is given for camera 0; for camera 2 it is moved by camera 2's offset from the
// rectified projection row (t = K^-1 * P2.col(3): cam2_from_cam0 = [I | t]), so it is the pose of
// the camera whose images are loaded. Depth: depth_<cam> when present; for camera 2 without
// depth_2, depth_0 is used only when P2 and P0 have the same offset (same viewpoint, as in dfo's
// synthetic sequences).
#ifndef DFO_IO_KITTI_DATASET_H_
#define DFO_IO_KITTI_DATASET_H_

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/lie.h"
#include "dfo_io/dataset.h"

namespace dfo::io {

// The labelled rows of a KITTI calib.txt ("P0" -> 3x4 matrix, row-major in the file). Rows of
// other labels are kept when they have 12 numbers.
struct KittiCalibration {
  std::map<std::string, Matrix3x4d> rows;
};

// Reads calib.txt. InputError naming the file and line for a line without "LABEL:", a
// non-numeric value, or a P row without exactly 12 numbers; also when the file is missing.
KittiCalibration ReadKittiCalibration(const std::string& path);

// Intrinsics of projection row P = K [I | t] for an image of width x height (K from the left 3x3).
PinholeCamera CameraFromProjection(const Matrix3x4d& projection, int width, int height);

// Offset t of the camera of projection row P relative to the rectified reference camera 0:
// camera_from_cam0 = [I | t], t = K^-1 * P.col(3).
Eigen::Vector3d ProjectionOffset(const Matrix3x4d& projection);

// Reads times.txt (seconds, one per non-empty line) as nanoseconds. InputError naming file and
// line for a non-numeric value or a time not after the previous one ("timestamps going
// backwards").
std::vector<int64_t> ReadKittiTimes(const std::string& path);

// Opens a KITTI-layout sequence (see the file comment) as a Sequence.
Sequence OpenKittiSequence(const DatasetOptions& options);

}  // namespace dfo::io

#endif  // DFO_IO_KITTI_DATASET_H_
