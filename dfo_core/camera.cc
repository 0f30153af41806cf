#include "dfo_core/camera.h"

#include <cmath>
#include <sstream>

#include "dfo_core/error.h"

namespace dfo {

bool PinholeCamera::IsValid(std::string* why) const {
  std::ostringstream msg;
  if (!std::isfinite(fx) || fx <= 0) {
    msg << "camera.fx = " << fx << " violates > 0";
  } else if (!std::isfinite(fy) || fy <= 0) {
    msg << "camera.fy = " << fy << " violates > 0";
  } else if (!std::isfinite(cx)) {
    msg << "camera.cx = " << cx << " is not finite";
  } else if (!std::isfinite(cy)) {
    msg << "camera.cy = " << cy << " is not finite";
  } else if (width <= 0) {
    msg << "camera.width = " << width << " violates > 0";
  } else if (height <= 0) {
    msg << "camera.height = " << height << " violates > 0";
  } else if (fx < 0.05 * width || fx > 100.0 * width) {
    msg << "camera.fx = " << fx << " is impossible for an image " << width
        << " pixels wide (expected 0.05 to 100 times the width)";
  } else if (fy < 0.05 * height || fy > 100.0 * height) {
    msg << "camera.fy = " << fy << " is impossible for an image " << height
        << " pixels high (expected 0.05 to 100 times the height)";
  } else if (fx / fy < 0.2 || fx / fy > 5.0) {
    msg << "camera.fx / camera.fy = " << fx / fy << " violates [0.2, 5]";
  } else {
    return true;
  }
  if (why != nullptr) *why = msg.str();
  return false;
}

void PinholeCamera::Check() const {
  std::string why;
  if (!IsValid(&why)) throw InputError("invalid camera intrinsics: " + why);
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d k;
  k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
  return k;
}

PinholeCamera PinholeCamera::Resized(int new_width, int new_height) const {
  DFO_CHECK(new_width > 0 && new_height > 0) << new_width << "x" << new_height;
  const double sx = static_cast<double>(new_width) / width;
  const double sy = static_cast<double>(new_height) / height;
  // Pixel centres at integers: continuous coordinate u maps to (u + 0.5) * s - 0.5.
  return PinholeCamera(fx * sx, fy * sy, (cx + 0.5) * sx - 0.5, (cy + 0.5) * sy - 0.5, new_width,
                       new_height);
}

PinholeCamera PinholeCamera::Cropped(int x0, int y0, int w, int h) const {
  DFO_CHECK(w > 0 && h > 0) << w << "x" << h;
  return PinholeCamera(fx, fy, cx - x0, cy - y0, w, h);
}

PinholeCamera PinholeCamera::PyramidLevel(int level) const {
  DFO_CHECK(level >= 0) << level;
  // 2x2 averaging maps pixels (2i, 2i+1) to i whatever the parity of the size (a last odd row or
  // column is dropped), so each level scales coordinates by exactly 1/2 about the pixel corner.
  PinholeCamera cam = *this;
  for (int l = 0; l < level; ++l) {
    cam = PinholeCamera(cam.fx * 0.5, cam.fy * 0.5, (cam.cx + 0.5) * 0.5 - 0.5,
                        (cam.cy + 0.5) * 0.5 - 0.5, cam.width / 2, cam.height / 2);
  }
  return cam;
}

}  // namespace dfo
