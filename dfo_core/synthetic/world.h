// The procedural street world of the synthetic sequence: the drive path, the vehicle states of
// every frame, the boxes (buildings, parked cars) and the road surface layout.
//
// Map frame: the frame the world is built in. Axes as KITTI's camera at heading 0: x right, y DOWN,
// z forward; the road is the plane y = 0, so a camera 1.65 m above it sits at y = -1.65. The
// sequence's "world" frame (first camera) is derived from it by SyntheticSequence.
//
// Street cross-section, by lateral offset l from the path (the trajectory of the car, positive to
// the right): the car drives in the right lane of a two-lane road whose centre line is
// kLaneOffsetM to its left, with a parking lane and a kerb on each side, then a sidewalk, then
// the buildings. Everything is laid out along the path, so the street bends where the path does.
#ifndef DFO_CORE_SYNTHETIC_WORLD_H_
#define DFO_CORE_SYNTHETIC_WORLD_H_

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "dfo_core/lie.h"
#include "dfo_core/synthetic/options.h"

namespace dfo::synthetic {

// Street cross-section (metres), as offsets q from the road centre line (q = l + kLaneOffsetM).
inline constexpr double kLaneOffsetM = 1.8;       // road centre is this far left of the path
inline constexpr double kLaneEdgeM = 3.6;         // |q| of the lane edge lines
inline constexpr double kKerbInnerM = 5.8;        // |q| where the parking lane meets the kerb
inline constexpr double kKerbOuterM = 6.05;       // |q| where the kerb meets the sidewalk
inline constexpr double kSidewalkOuterM = 9.2;    // |q| of the sidewalk's outer edge
inline constexpr double kPathSpacingM = 0.1;      // arc-length step of the sampled path
inline constexpr double kPathPrefixM = 40.0;      // path (and street) before frame 0
inline constexpr double kPathExtensionM = 160.0;  // street beyond the last frame's position

// One sample of the drive path, every kPathSpacingM metres of arc length.
struct PathSample {
  double s_m = 0.0;          // arc length; frame 0 is at s = 0, the path starts at -kPathPrefixM
  double x_m = 0.0;          // map x (right)
  double z_m = 0.0;          // map z (forward at heading 0)
  double heading_rad = 0.0;  // direction of travel (sin h, cos h) in (x, z); positive turns right
  double curvature = 0.0;    // d heading / ds in 1/m (positive: right turn)
  double speed = 0.0;        // planned speed in metres per frame
};

// The centre line of the drive: straights, 90-degree corners at intersections and gentle curves,
// with a speed profile (slow in corners, faster on straights, bounded acceleration).
class DrivePath {
 public:
  DrivePath() = default;
  // Generates a path at least `min_length_m` long after s = 0 (plus the prefix), from `seed`.
  // The heading stays within +-95 degrees of the start, so the path never comes back to itself.
  static DrivePath Generate(uint64_t seed, double min_length_m);

  const std::vector<PathSample>& samples() const { return samples_; }
  double start_s() const { return samples_.front().s_m; }
  double end_s() const { return samples_.back().s_m; }
  // Sample at arc length s, linearly interpolated (clamped to the path's ends).
  PathSample At(double s) const;

 private:
  std::vector<PathSample> samples_;
};

// State of the car and camera at one frame.
struct VehicleState {
  double s_m = 0.0;        // arc length of the camera along the path
  double speed = 0.0;      // metres travelled to the next frame
  double pitch_rad = 0.0;  // camera pitch (positive: looking up)
  double roll_rad = 0.0;   // camera roll about its optical axis
  SE3d map_from_cam;       // camera pose in the map frame
};

// Kind of a box in the scene. A parked car is a body box plus a narrower cabin box on top; a van
// (a body taller than 1.2 m) is one box that carries its windows itself.
enum class BoxKind : uint8_t { kBuilding = 0, kCar = 1, kCarCabin = 2 };
// Facade texture of a building.
enum class FacadePattern : uint8_t { kBrick = 0, kPanels = 1, kPlaster = 2 };

// An oriented box standing on the road plane: a building or a parked car.
struct SceneBox {
  BoxKind kind = BoxKind::kBuilding;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  // map frame; center.y() = -half_size.y()
  // Half extents along the box's local axes: x across the street, y height, z along the street.
  Eigen::Vector3d half_size = Eigen::Vector3d::Ones();
  double yaw_rad = 0.0;  // local z axis in the map is (sin yaw, 0, cos yaw); local y = map y
  Eigen::Vector3d colour = Eigen::Vector3d::Constant(0.5);  // base albedo, RGB in [0, 1]
  FacadePattern pattern = FacadePattern::kPlaster;
  double floor_height_m = 3.2;      // window grid: storey height
  double window_pitch_m = 2.5;      // window grid: horizontal spacing
  double window_width_frac = 0.5;   // window width / pitch
  double window_height_frac = 0.5;  // window height / storey height
  uint32_t texture_seed = 0;        // seed of this box's noise and window variation

  // Rotation map_from_box (about the map's y axis by yaw).
  Eigen::Matrix3d MapFromBox() const;
  // Footprint corners (x, z) in the map, counter-clockwise seen from above.
  std::vector<Eigen::Vector2d> FootprintCorners() const;
};

// Road coordinates (arc length s, lateral offset l, path heading) of the ground near the path,
// precomputed on a 0.5 m grid over the map so the renderer does not search the path per pixel.
class RoadGrid {
 public:
  RoadGrid() = default;
  // Builds the grid for the cells within kGridRadiusM of the path.
  explicit RoadGrid(const DrivePath& path);
  // Road coordinates at map point (x, z), bilinearly interpolated. False where the point is
  // farther than kGridRadiusM from the path (no street surface there).
  bool Lookup(double x, double z, double* s, double* l, double* heading) const;

  static constexpr double kCellM = 0.5;
  static constexpr double kGridRadiusM = 12.5;

 private:
  double x0_ = 0.0, z0_ = 0.0;
  int nx_ = 0, nz_ = 0;
  std::vector<float> s_, l_, heading_, dist_;  // dist_ < 0: cell not set
};

// The complete world: path, per-frame vehicle states, boxes, road grid, lighting.
struct SyntheticWorld {
  DrivePath path;
  std::vector<VehicleState> frames;  // one per frame of the sequence
  std::vector<SceneBox> boxes;
  RoadGrid road;
  Eigen::Vector3d sun_direction = Eigen::Vector3d(0.4, -0.7, 0.6).normalized();  // towards sun
  uint32_t texture_seed = 0;

  // Builds the world for `options` (options.Check() must pass).
  static SyntheticWorld Build(const SyntheticOptions& options);
};

// Distance from map point (x, z) to the footprint of `box` (0 inside).
double DistanceToFootprint(const SceneBox& box, double x, double z);

}  // namespace dfo::synthetic

#endif  // DFO_CORE_SYNTHETIC_WORLD_H_
