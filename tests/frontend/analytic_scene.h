// A tiny analytic scene for tracker tests: a box-shaped corridor (floor, ceiling, side walls and
// an end wall) with smooth procedural textures, rendered by exact ray-plane intersection with
// 3 x 3 supersampling. Unlike the street sequence its images have little energy near Nyquist, so
// bilinear warping of one view onto another is accurate and the tracker's own accuracy shows.
#ifndef DFO_TESTS_FRONTEND_ANALYTIC_SCENE_H_
#define DFO_TESTS_FRONTEND_ANALYTIC_SCENE_H_

#include <algorithm>
#include <cmath>
#include <limits>

#include "dfo_core/camera.h"
#include "dfo_core/frame.h"
#include "dfo_core/lie.h"

namespace dfo::test {

// Corridor: x in [-5, 5] (walls), y in [-3, 2] (ceiling above, floor 2 m below the camera),
// end wall at z = 14, in the world frame (x right, y down, z forward).
class AnalyticScene {
 public:
  // 416 x 128, 80 deg horizontal field of view as the street sequence.
  static PinholeCamera Camera() {
    const double fx = 0.5 * 416 / std::tan(40.0 * M_PI / 180.0);
    return PinholeCamera(fx, fx, 207.5, 63.5, 416, 128);
  }

  // Texture of a world point on the surface with normal axis `axis` (0: x wall, 1: floor or
  // ceiling, 2: end wall): a sum of sinusoids of 0.6-2.5 rad/m in the surface coordinates.
  static double Texture(const Eigen::Vector3d& p, int axis) {
    const double a = axis == 0 ? p.z() : p.x();
    const double b = axis == 1 ? p.z() : p.y();
    const double phase = 1.7 * axis;
    return 0.5 + 0.16 * std::sin(1.1 * a + phase) * std::cos(0.9 * b) +
           0.10 * std::sin(1.9 * a - 1.3 * b + phase) + 0.07 * std::cos(2.3 * b + 0.6 * a) +
           0.05 * std::sin(2.5 * a + 0.3);
  }

  // Depth along the optical axis and texture of the ray through pixel (u, v).
  // With plane_only, the scene is just the plane z = 10 (fronto-parallel to the first camera).
  static void Trace(const SE3d& world_from_cam, const PinholeCamera& cam, double u, double v,
                    bool plane_only, double* depth, double* intensity) {
    const Eigen::Vector3d ray_cam((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
    const Eigen::Vector3d origin = world_from_cam.translation();
    const Eigen::Vector3d dir = world_from_cam.so3() * ray_cam;
    double best = std::numeric_limits<double>::infinity();
    int best_axis = -1;
    const double bounds[3][2] = {{-5.0, 5.0}, {-3.0, 2.0}, {-100.0, plane_only ? 10.0 : 14.0}};
    for (int axis = plane_only ? 2 : 0; axis < 3; ++axis) {
      if (std::abs(dir(axis)) < 1e-12) continue;
      for (int side = 0; side < 2; ++side) {
        const double t = (bounds[axis][side] - origin(axis)) / dir(axis);
        if (t > 1e-6 && t < best) {
          best = t;
          best_axis = axis;
        }
      }
    }
    *depth = best;  // t along (x, y, 1) in the camera frame is the z-depth
    *intensity = Texture(origin + best * dir, best_axis);
  }

  // The frame seen from world_from_cam: 8-bit grey (3 x 3 supersampled) and exact depth.
  static Frame Render(const SE3d& world_from_cam, bool plane_only = false, int index = 0) {
    Frame frame;
    frame.index = index;
    frame.camera = Camera();
    const int w = frame.camera.width, h = frame.camera.height;
    frame.image = ImageU8(w, h, 1);
    frame.depth_m = ImageF(w, h, 1);
    for (int y = 0; y < h; ++y) {
      for (int x = 0; x < w; ++x) {
        double sum = 0.0, depth = 0.0, value = 0.0;
        for (int j = -1; j <= 1; ++j) {
          for (int i = -1; i <= 1; ++i) {
            Trace(world_from_cam, frame.camera, x + i / 3.0, y + j / 3.0, plane_only, &depth,
                  &value);
            sum += value;
          }
        }
        Trace(world_from_cam, frame.camera, x, y, plane_only, &depth, &value);
        frame.image(x, y) = static_cast<uint8_t>(std::clamp(sum / 9.0 * 255.0 + 0.5, 0.0, 255.0));
        frame.depth_m(x, y) = static_cast<float>(depth);
      }
    }
    return frame;
  }
};

}  // namespace dfo::test

#endif  // DFO_TESTS_FRONTEND_ANALYTIC_SCENE_H_
