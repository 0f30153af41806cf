// Camera description files (camera.yaml) for image folders, TUM RGB-D sequences and videos.
//
// Format (YAML mapping; the file shipped with dfo's TUM extract is an example):
//
//   model: pinhole        # optional: pinhole (default), radtan or equidistant (dfo_io/lens.h)
//   width: 640            # image size in pixels, > 0
//   height: 480
//   fx: 535.4             # focal lengths in pixels, > 0
//   fy: 539.2
//   cx: 320.1             # principal point in pixels (pixel centres at integers), inside the image
//   cy: 247.6
//   depth_scale: 5000.0   # optional: 16-bit depth PNG value per metre
//   fps: 10.0             # optional (image folders): frame rate when no timestamps file is given
//   timestamps: times.txt # optional (image folders): file of one time in seconds per image,
//                         # relative to the YAML file's folder
//   distortion: [0, 0, 0, 0, 0]  # optional; must be all zero (use a lens model for distortion)
//
// Lens coefficients (OpenCV's conventions, see dfo_io/lens.h), only with their model:
//
//   model: radtan         # radial-tangential: k1, k2, p1, p2 required, k3 optional (default 0)
//   k1: -0.28
//   k2: 0.07
//   p1: 0.0002
//   p2: -0.0001
//
//   model: equidistant    # OpenCV's fisheye model: k1, k2, k3, k4 required
//   k1: -0.013
//   k2: 0.02
//   k3: -0.018
//   k4: 0.005
//
// Unknown keys are errors (usually typos), as are missing or non-numeric values, an unknown model,
// a coefficient the model does not have and a missing one; every message names the file and the
// 1-based line.
#ifndef DFO_IO_CAMERA_YAML_H_
#define DFO_IO_CAMERA_YAML_H_

#include <optional>
#include <string>

#include "dfo_core/camera.h"
#include "dfo_io/lens.h"

namespace dfo::io {

// Contents of a camera.yaml file.
struct CameraYaml {
  PinholeCamera camera;               // intrinsics and image size (checked: CheckCalibration)
  LensDistortion lens;                // lens model and coefficients (pinhole when absent)
  std::optional<double> depth_scale;  // depth PNG value per metre, > 0
  std::optional<double> fps;          // frames per second, > 0
  std::string timestamps_path;        // absolute or relative to cwd (resolved); "" when absent
};

// Reads and checks a camera.yaml file. Throws dfo::InputError naming the file and line.
CameraYaml ReadCameraYaml(const std::string& path);

// Writes a camera.yaml file (parent folders created) that ReadCameraYaml reads back.
void WriteCameraYaml(const std::string& path, const CameraYaml& camera);

}  // namespace dfo::io

#endif  // DFO_IO_CAMERA_YAML_H_
