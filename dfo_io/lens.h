// Lens distortion of camera.yaml files and the undistortion of images to a pinhole camera.
//
// Models (OpenCV's conventions; x, y normalised image coordinates of a ray, r^2 = x^2 + y^2):
//  - pinhole:     no distortion (rectified images).
//  - radtan:      radial-tangential (Brown-Conrady, cv::initUndistortRectifyMap with the
//                 coefficient vector k1 k2 p1 p2 k3):
//                   x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)
//                   y_d = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y
//  - equidistant: OpenCV's fisheye model (cv::fisheye, Kannala-Brandt with four coefficients):
//                   theta = atan(r), theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6
//                   + k4 theta^8), (x_d, y_d) = theta_d / r (x, y)
// and the distorted pixel is (fx x_d + cx, fy y_d + cy).
//
// Undistortion target: a pinhole camera with the same fx, fy, cx, cy and image size as the
// distorted camera (not cv::getOptimalNewCameraMatrix): the calibration's intrinsics stay the
// intrinsics of the images dfo works on, and for the usual barrel and fisheye lenses every output
// pixel has a source pixel (the outer field of view is cropped instead of leaving black borders).
// The remap maps are computed once per sequence (Undistorter) and applied to every frame before it
// is resized to the output size.
#ifndef DFO_IO_LENS_H_
#define DFO_IO_LENS_H_

#include <Eigen/Core>
#include <memory>
#include <string>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"

namespace dfo::io {

enum class LensModel { kPinhole, kRadtan, kEquidistant };

// "pinhole", "radtan" or "equidistant" (the camera.yaml `model` values).
const char* LensModelName(LensModel model);

// A lens model and its coefficients (those a model does not use stay 0).
struct LensDistortion {
  LensModel model = LensModel::kPinhole;
  double k1 = 0.0;  // radial (radtan: of r^2; equidistant: of theta^2)
  double k2 = 0.0;  // radial (r^4 / theta^4)
  double k3 = 0.0;  // radial (r^6 / theta^6); radtan: optional in camera.yaml, default 0
  double k4 = 0.0;  // radial theta^8, equidistant only
  double p1 = 0.0;  // tangential, radtan only
  double p2 = 0.0;  // tangential, radtan only

  // True when images need no undistortion: pinhole, or radtan with every coefficient 0
  // (equidistant with zero coefficients is still a fisheye projection, r_d = f theta).
  bool IsIdentity() const;
};

// Undistortion of the images of one camera to the pinhole camera with the same intrinsics (see the
// file comment). Output pixels whose source lies outside the distorted image are 0.
class Undistorter {
 public:
  // Computes the maps for images of camera.width x camera.height. Throws InputError naming `what`
  // (the camera file) when more than half of the output pixels would have no source pixel
  // ("undistortion would leave 63 % of the output image empty") or a map is not finite.
  Undistorter(const PinholeCamera& camera, const LensDistortion& lens, const std::string& what);
  ~Undistorter();
  Undistorter(const Undistorter&) = delete;
  Undistorter& operator=(const Undistorter&) = delete;

  const PinholeCamera& camera() const { return camera_; }
  const LensDistortion& lens() const { return lens_; }
  // Fraction of output pixels without a source pixel, in [0, 0.5].
  double empty_fraction() const { return empty_fraction_; }

  // Undistorted image (bilinear interpolation; 1 or 3 channels). The input must have the camera's
  // size (checked).
  ImageU8 Apply(const ImageU8& distorted) const;
  // Undistorted depth map (metres, 0 = invalid): nearest source pixel, so that depths of different
  // surfaces are never mixed.
  ImageF ApplyDepth(const ImageF& distorted) const;
  // Position in the distorted image (pixel centres at integers) that output pixel (u, v) samples.
  Eigen::Vector2d SourcePixel(int u, int v) const;

 private:
  struct Maps;
  PinholeCamera camera_;
  LensDistortion lens_;
  double empty_fraction_ = 0.0;
  std::unique_ptr<Maps> maps_;
};

// The Undistorter of a camera and lens, or nullptr when lens.IsIdentity(). Throws as the
// Undistorter constructor.
std::shared_ptr<const Undistorter> MakeUndistorter(const PinholeCamera& camera,
                                                   const LensDistortion& lens,
                                                   const std::string& what);

}  // namespace dfo::io

#endif  // DFO_IO_LENS_H_
