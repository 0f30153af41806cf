// Pinhole camera model (no distortion: images are rectified, as KITTI's and the synthetic ones).
#ifndef DFO_CORE_CAMERA_H_
#define DFO_CORE_CAMERA_H_

#include <Eigen/Core>
#include <string>

namespace dfo {

// Intrinsics of a pinhole camera for an image of width x height pixels. Pixel centres are at
// integer coordinates: the top-left pixel's centre is (0, 0), its area spans [-0.5, 0.5]^2.
struct PinholeCamera {
  double fx = 0.0;  // focal length in pixels, > 0
  double fy = 0.0;  // focal length in pixels, > 0
  double cx = 0.0;  // principal point in pixels
  double cy = 0.0;  // principal point in pixels
  int width = 0;    // image width in pixels, > 0
  int height = 0;   // image height in pixels, > 0

  PinholeCamera() = default;
  PinholeCamera(double fx_, double fy_, double cx_, double cy_, int width_, int height_)
      : fx(fx_), fy(fy_), cx(cx_), cy(cy_), width(width_), height(height_) {}

  // Throws dfo::InputError naming the field, value and rule when the intrinsics are unusable:
  // non-finite, a non-positive focal length or size, or physically impossible for a pinhole
  // image: a focal length outside [0.05, 100] times the image side (fields of view from ~169 down
  // to ~0.6 degrees) or fx / fy outside [0.2, 5]. (The loaders also check that the principal
  // point lies in the image.)
  void Check() const;
  // Same test without throwing; the reason goes to *why when given.
  bool IsValid(std::string* why = nullptr) const;

  // 3x3 calibration matrix.
  Eigen::Matrix3d K() const;

  // Pixel of a point in the camera frame (z must be > 0 for a meaningful result).
  template <typename T>
  Eigen::Matrix<T, 2, 1> Project(const Eigen::Matrix<T, 3, 1>& p_in_cam) const {
    return Eigen::Matrix<T, 2, 1>(T(fx) * p_in_cam.x() / p_in_cam.z() + T(cx),
                                  T(fy) * p_in_cam.y() / p_in_cam.z() + T(cy));
  }
  // Jacobian of Project at p_in_cam (2x3, z != 0), d(u, v) / d(x, y, z):
  //   [fx / z, 0, -fx x / z^2; 0, fy / z, -fy y / z^2].
  // Chain it with SE3::ActionJacobianLeft/Right for the derivative of a pixel w.r.t. a pose.
  template <typename T>
  Eigen::Matrix<T, 2, 3> ProjectJacobian(const Eigen::Matrix<T, 3, 1>& p_in_cam) const {
    const T z_inv = T(1) / p_in_cam.z();
    const T fx_z = T(fx) * z_inv, fy_z = T(fy) * z_inv;
    Eigen::Matrix<T, 2, 3> jac;
    jac << fx_z, T(0), -fx_z * p_in_cam.x() * z_inv, T(0), fy_z, -fy_z * p_in_cam.y() * z_inv;
    return jac;
  }
  // Point at depth z (along the optical axis) seen at pixel uv.
  template <typename T>
  Eigen::Matrix<T, 3, 1> Unproject(const Eigen::Matrix<T, 2, 1>& uv, T z) const {
    return Eigen::Matrix<T, 3, 1>((uv.x() - T(cx)) / T(fx) * z, (uv.y() - T(cy)) / T(fy) * z, z);
  }
  // Ray direction (x, y, 1) through pixel uv.
  template <typename T>
  Eigen::Matrix<T, 3, 1> Ray(const Eigen::Matrix<T, 2, 1>& uv) const {
    return Unproject(uv, T(1));
  }
  // Whether uv lies inside the image with a border of `border` pixels.
  template <typename T>
  bool IsInImage(const Eigen::Matrix<T, 2, 1>& uv, T border = T(0)) const {
    return uv.x() >= border && uv.y() >= border && uv.x() <= T(width - 1) - border &&
           uv.y() <= T(height - 1) - border;
  }

  // Intrinsics of the same camera for the whole image resized to new_width x new_height
  // (each axis scaled independently; pixel-centre convention kept).
  PinholeCamera Resized(int new_width, int new_height) const;
  // Intrinsics after cropping the region [x0, x0 + w) x [y0, y0 + h) of this image.
  PinholeCamera Cropped(int x0, int y0, int w, int h) const;
  // Intrinsics of pyramid level `level` (each level halves width and height, 2x2 averaging).
  PinholeCamera PyramidLevel(int level) const;
};

}  // namespace dfo

#endif  // DFO_CORE_CAMERA_H_
