// Timestamped trajectories: one camera pose per frame, world_from_cam (camera-to-world), as in the
// KITTI and TUM file formats. Timestamps are int64 nanoseconds inside dfo; seconds only at file
// boundaries.
#ifndef DFO_CORE_TRAJECTORY_H_
#define DFO_CORE_TRAJECTORY_H_

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "dfo_core/lie.h"

namespace dfo {

// One pose of a trajectory.
struct StampedPose {
  int64_t timestamp_ns = 0;  // time of the frame in nanoseconds
  SE3d world_from_cam;       // camera-to-world transform
};

// |v| without overflow or underflow of the squares: sqrt(v.v) when the squares stay in the
// double range (then bit for bit Eigen's norm()), else the same on v scaled by a power of two
// (exact), e.g. for coordinates of 1e200. Not finite only when a coefficient is not finite or |v|
// exceeds the double range.
inline double RobustNorm(const Eigen::Vector3d& v) {
  const double squared = v.squaredNorm();
  if (std::isfinite(squared) && squared >= std::numeric_limits<double>::min()) {
    return std::sqrt(squared);
  }
  const double largest = v.cwiseAbs().maxCoeff();
  if (!(largest > 0.0) || !std::isfinite(largest)) return std::sqrt(squared);  // 0, inf or NaN
  int e = 0;
  std::frexp(largest, &e);
  const Eigen::Vector3d scaled(std::ldexp(v.x(), -e), std::ldexp(v.y(), -e), std::ldexp(v.z(), -e));
  return std::ldexp(scaled.norm(), e);
}

// A sequence of stamped poses in time order (not enforced here; readers check it).
class Trajectory {
 public:
  Trajectory() = default;
  explicit Trajectory(std::vector<StampedPose> poses) : poses_(std::move(poses)) {}

  void Add(int64_t timestamp_ns, const SE3d& world_from_cam) {
    poses_.push_back({timestamp_ns, world_from_cam});
  }
  size_t size() const { return poses_.size(); }
  bool empty() const { return poses_.empty(); }
  const StampedPose& operator[](size_t i) const { return poses_[i]; }
  StampedPose& operator[](size_t i) { return poses_[i]; }
  const std::vector<StampedPose>& poses() const { return poses_; }
  std::vector<StampedPose>& poses() { return poses_; }
  auto begin() const { return poses_.begin(); }
  auto end() const { return poses_.end(); }

  // Camera positions (translations of world_from_cam), one per pose.
  std::vector<Eigen::Vector3d> Positions() const {
    std::vector<Eigen::Vector3d> out;
    out.reserve(poses_.size());
    for (const auto& p : poses_) out.push_back(p.world_from_cam.translation());
    return out;
  }

  // Length of the path through all positions, in metres (world units).
  double PathLength() const {
    double length = 0.0;
    for (size_t i = 1; i < poses_.size(); ++i) {
      length += RobustNorm(poses_[i].world_from_cam.translation() -
                           poses_[i - 1].world_from_cam.translation());
    }
    return length;
  }

 private:
  std::vector<StampedPose> poses_;
};

// Seconds (file boundaries) <-> nanoseconds (inside dfo), rounded to the nearest nanosecond.
inline int64_t SecondsToNs(double seconds) {
  return static_cast<int64_t>(seconds * 1e9 + (seconds >= 0 ? 0.5 : -0.5));
}
inline double NsToSeconds(int64_t ns) { return static_cast<double>(ns) * 1e-9; }

}  // namespace dfo

#endif  // DFO_CORE_TRAJECTORY_H_
