#include "dfo_core/synthetic/world.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/noise.h"

namespace dfo {

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;

template <typename T>
void ThrowOption(const char* field, const T& value, const char* rule) {
  std::ostringstream out;
  out << "SyntheticOptions." << field << " = " << value << " violates " << rule;
  throw ConfigError(out.str());
}
}  // namespace

void SyntheticOptions::Check() const {
  if (num_frames < 1) ThrowOption("num_frames", num_frames, ">= 1");
  if (width < 16 || width > 4096) ThrowOption("width", width, "in [16, 4096]");
  if (height < 16 || height > 4096) ThrowOption("height", height, "in [16, 4096]");
  if (!(horizontal_fov_deg > 10.0 && horizontal_fov_deg < 150.0)) {
    ThrowOption("horizontal_fov_deg", horizontal_fov_deg, "in (10, 150)");
  }
  if (!(camera_height_m >= 0.3 && camera_height_m <= 5.0)) {
    ThrowOption("camera_height_m", camera_height_m, "in [0.3, 5]");
  }
  if (!(frame_interval_s > 0.0 && std::isfinite(frame_interval_s))) {
    ThrowOption("frame_interval_s", frame_interval_s, "> 0");
  }
  if (!(stereo_baseline_m >= 0.0 && std::isfinite(stereo_baseline_m))) {
    ThrowOption("stereo_baseline_m", stereo_baseline_m, ">= 0");
  }
  if (!(max_depth_m > 1.0 && max_depth_m <= 255.99)) {
    ThrowOption("max_depth_m", max_depth_m, "in (1, 255.99]");
  }
  if (!(texture_filter_scale >= 0.5 && texture_filter_scale <= 4.0)) {
    ThrowOption("texture_filter_scale", texture_filter_scale, "in [0.5, 4]");
  }
}

PinholeCamera SyntheticOptions::Camera() const {
  const double f = 0.5 * width / std::tan(0.5 * horizontal_fov_deg * kDegToRad);
  return PinholeCamera(f, f, 0.5 * (width - 1), 0.5 * (height - 1), width, height);
}

namespace synthetic {

namespace {

// A stretch of the path plan: constant curvature and target speed.
struct Piece {
  double length_m;
  double curvature;
  double speed;  // metres per frame
};

// Rotation about the map's y axis taking local z to (sin yaw, 0, cos yaw).
Eigen::Matrix3d RotY(double a) {
  Eigen::Matrix3d r;
  r << std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a);
  return r;
}
Eigen::Matrix3d RotX(double a) {
  Eigen::Matrix3d r;
  r << 1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a);
  return r;
}
Eigen::Matrix3d RotZ(double a) {
  Eigen::Matrix3d r;
  r << std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1;
  return r;
}

// Moving average with a window of 2 * half + 1 samples (edges use the available samples); it keeps
// the integral of the signal, so smoothing the curvature keeps every turn's total angle.
std::vector<double> BoxFilter(const std::vector<double>& in, int half) {
  const int n = static_cast<int>(in.size());
  std::vector<double> prefix(n + 1, 0.0);
  for (int i = 0; i < n; ++i) prefix[i + 1] = prefix[i] + in[i];
  std::vector<double> out(n);
  for (int i = 0; i < n; ++i) {
    const int a = std::max(0, i - half), b = std::min(n - 1, i + half);
    out[i] = (prefix[b + 1] - prefix[a]) / (b - a + 1);
  }
  return out;
}

// Separating-axis test of two footprints (convex quadrilaterals), with a margin in metres.
bool FootprintsOverlap(const SceneBox& a, const SceneBox& b, double margin) {
  const auto ca = a.FootprintCorners(), cb = b.FootprintCorners();
  for (const auto* box : {&a, &b}) {
    const double yaw = box->yaw_rad;
    const std::array<Eigen::Vector2d, 2> axes = {Eigen::Vector2d(std::cos(yaw), -std::sin(yaw)),
                                                 Eigen::Vector2d(std::sin(yaw), std::cos(yaw))};
    for (const auto& axis : axes) {
      double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300;
      for (const auto& c : ca) {
        amin = std::min(amin, c.dot(axis));
        amax = std::max(amax, c.dot(axis));
      }
      for (const auto& c : cb) {
        bmin = std::min(bmin, c.dot(axis));
        bmax = std::max(bmax, c.dot(axis));
      }
      if (amax + margin < bmin || bmax + margin < amin) return false;
    }
  }
  return true;
}

// Right-hand normal (x, z) of the direction of travel at heading h.
Eigen::Vector2d RightOf(double heading) {
  return Eigen::Vector2d(std::cos(heading), -std::sin(heading));
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Path

DrivePath DrivePath::Generate(uint64_t seed, double min_length_m) {
  SplitMix64 rng(seed * 0x2545F4914F6CDD1Dull + 0x1234567ull);
  std::vector<Piece> pieces;
  const double max_heading = 95.0 * kDegToRad;
  double heading = 0.0, total = 0.0;
  bool first = true;
  while (total < kPathPrefixM + min_length_m + 30.0) {
    // A straight stretch of street at a cruising speed of its own.
    const double straight =
        first ? kPathPrefixM + rng.Uniform(25.0, 55.0) : rng.Uniform(35.0, 110.0);
    const double cruise = rng.Uniform(1.05, 1.45);
    pieces.push_back({straight, 0.0, cruise});
    total += straight;
    // Then a 90-degree corner at an intersection (always first, so every sequence turns early)
    // or a gentle bend. The sign is chosen to keep the heading within +-95 degrees.
    const bool corner = first || rng.Bernoulli(0.55);
    double sign = rng.Bernoulli(0.5) ? 1.0 : -1.0;
    if (corner) {
      const double radius = rng.Uniform(14.0, 18.0);
      const double angle = 0.5 * kPi;
      if (std::abs(heading + sign * angle) > max_heading) sign = -sign;
      pieces.push_back({radius * angle, sign / radius, 0.6});
      heading += sign * angle;
      total += radius * angle;
    } else {
      const double radius = rng.Uniform(70.0, 160.0);
      const double angle = rng.Uniform(12.0, 35.0) * kDegToRad;
      if (std::abs(heading + sign * angle) > max_heading) sign = -sign;
      pieces.push_back({radius * angle, sign / radius, std::min(cruise, 1.15)});
      heading += sign * angle;
      total += radius * angle;
    }
    first = false;
  }

  // Sample curvature and target speed, smooth the curvature (two box filters of 5 m: a C1 ramp
  // into and out of every turn, like a clothoid) and integrate heading and position.
  const int n = static_cast<int>(std::ceil(total / kPathSpacingM)) + 1;
  std::vector<double> curvature(n), target(n);
  {
    size_t piece = 0;
    double piece_end = pieces[0].length_m;
    for (int i = 0; i < n; ++i) {
      const double s = i * kPathSpacingM;
      while (s > piece_end && piece + 1 < pieces.size()) piece_end += pieces[++piece].length_m;
      curvature[i] = pieces[piece].curvature;
      target[i] = pieces[piece].speed;
    }
  }
  const int half = static_cast<int>(std::lround(2.5 / kPathSpacingM));
  curvature = BoxFilter(BoxFilter(curvature, half), half);

  // Speed profile v(s) in metres per frame with |acceleration| <= a (m / frame^2): the classic
  // forward/backward pass, v(s)^2 <= v(s - ds)^2 + 2 a ds. a = 0.025 m/frame^2 = 2.5 m/s^2 at 10
  // Hz.
  const double accel = 0.025;
  std::vector<double> speed = target;
  for (int i = 1; i < n; ++i) {
    speed[i] =
        std::min(speed[i], std::sqrt(speed[i - 1] * speed[i - 1] + 2 * accel * kPathSpacingM));
  }
  for (int i = n - 2; i >= 0; --i) {
    speed[i] =
        std::min(speed[i], std::sqrt(speed[i + 1] * speed[i + 1] + 2 * accel * kPathSpacingM));
  }

  DrivePath path;
  path.samples_.resize(n);
  double h = 0.0, x = 0.0, z = 0.0;
  for (int i = 0; i < n; ++i) {
    PathSample& p = path.samples_[i];
    p.s_m = i * kPathSpacingM - kPathPrefixM;
    p.x_m = x;
    p.z_m = z;
    p.heading_rad = h;
    p.curvature = curvature[i];
    p.speed = speed[i];
    // Midpoint rule for the position.
    const double h_mid = h + 0.5 * curvature[i] * kPathSpacingM;
    x += std::sin(h_mid) * kPathSpacingM;
    z += std::cos(h_mid) * kPathSpacingM;
    h += curvature[i] * kPathSpacingM;
  }
  // Put frame 0 (s = 0) at the map origin.
  const PathSample origin = path.At(0.0);
  for (auto& p : path.samples_) {
    p.x_m -= origin.x_m;
    p.z_m -= origin.z_m;
  }
  return path;
}

PathSample DrivePath::At(double s) const {
  const double f = (s - samples_.front().s_m) / kPathSpacingM;
  if (f <= 0.0) return samples_.front();
  const int i = static_cast<int>(f);
  if (i + 1 >= static_cast<int>(samples_.size())) return samples_.back();
  const double a = f - i;
  const PathSample& p = samples_[i];
  const PathSample& q = samples_[i + 1];
  PathSample r;
  r.s_m = s;
  r.x_m = p.x_m + a * (q.x_m - p.x_m);
  r.z_m = p.z_m + a * (q.z_m - p.z_m);
  r.heading_rad = p.heading_rad + a * (q.heading_rad - p.heading_rad);
  r.curvature = p.curvature + a * (q.curvature - p.curvature);
  r.speed = p.speed + a * (q.speed - p.speed);
  return r;
}

// ---------------------------------------------------------------------------------------------
// Boxes

Eigen::Matrix3d SceneBox::MapFromBox() const { return RotY(yaw_rad); }

std::vector<Eigen::Vector2d> SceneBox::FootprintCorners() const {
  const Eigen::Vector2d across(std::cos(yaw_rad), -std::sin(yaw_rad));  // local x in (x, z)
  const Eigen::Vector2d along(std::sin(yaw_rad), std::cos(yaw_rad));    // local z in (x, z)
  const Eigen::Vector2d c(center.x(), center.z());
  const double a = half_size.x(), b = half_size.z();
  return {c - a * across - b * along, c + a * across - b * along, c + a * across + b * along,
          c - a * across + b * along};
}

double DistanceToFootprint(const SceneBox& box, double x, double z) {
  const Eigen::Vector2d d(x - box.center.x(), z - box.center.z());
  const double u = std::abs(d.dot(Eigen::Vector2d(std::cos(box.yaw_rad), -std::sin(box.yaw_rad))));
  const double v = std::abs(d.dot(Eigen::Vector2d(std::sin(box.yaw_rad), std::cos(box.yaw_rad))));
  const double du = std::max(0.0, u - box.half_size.x()), dv = std::max(0.0, v - box.half_size.z());
  return std::sqrt(du * du + dv * dv);
}

// ---------------------------------------------------------------------------------------------
// Road grid

RoadGrid::RoadGrid(const DrivePath& path) {
  double xmin = 1e300, xmax = -1e300, zmin = 1e300, zmax = -1e300;
  for (const auto& p : path.samples()) {
    xmin = std::min(xmin, p.x_m);
    xmax = std::max(xmax, p.x_m);
    zmin = std::min(zmin, p.z_m);
    zmax = std::max(zmax, p.z_m);
  }
  const double margin = kGridRadiusM + 2.0 * kCellM;
  x0_ = xmin - margin;
  z0_ = zmin - margin;
  nx_ = static_cast<int>(std::ceil((xmax + margin - x0_) / kCellM)) + 1;
  nz_ = static_cast<int>(std::ceil((zmax + margin - z0_) / kCellM)) + 1;
  const size_t cells = static_cast<size_t>(nx_) * nz_;
  s_.assign(cells, 0.f);
  l_.assign(cells, 0.f);
  heading_.assign(cells, 0.f);
  dist_.assign(cells, -1.f);
  // Splat every path sample onto the cells around it; each cell keeps its nearest sample and the
  // projection onto that sample's tangent (exact road coordinates on a locally straight path).
  const int reach = static_cast<int>(std::ceil(kGridRadiusM / kCellM));
  const auto& samples = path.samples();
  for (size_t k = 0; k < samples.size(); k += 2) {
    const PathSample& p = samples[k];
    const Eigen::Vector2d t(std::sin(p.heading_rad), std::cos(p.heading_rad));
    const Eigen::Vector2d r = RightOf(p.heading_rad);
    const int ci = static_cast<int>(std::lround((p.x_m - x0_) / kCellM));
    const int cj = static_cast<int>(std::lround((p.z_m - z0_) / kCellM));
    for (int j = std::max(0, cj - reach); j <= std::min(nz_ - 1, cj + reach); ++j) {
      for (int i = std::max(0, ci - reach); i <= std::min(nx_ - 1, ci + reach); ++i) {
        const Eigen::Vector2d d(x0_ + i * kCellM - p.x_m, z0_ + j * kCellM - p.z_m);
        const double dist = d.norm();
        if (dist > kGridRadiusM) continue;
        const size_t idx = static_cast<size_t>(j) * nx_ + i;
        if (dist_[idx] >= 0.f && dist_[idx] <= dist) continue;
        dist_[idx] = static_cast<float>(dist);
        s_[idx] = static_cast<float>(p.s_m + d.dot(t));
        l_[idx] = static_cast<float>(d.dot(r));
        heading_[idx] = static_cast<float>(p.heading_rad);
      }
    }
  }
}

bool RoadGrid::Lookup(double x, double z, double* s, double* l, double* heading) const {
  const double fx = (x - x0_) / kCellM, fz = (z - z0_) / kCellM;
  if (!(fx >= 0.0 && fz >= 0.0)) return false;
  const int i = static_cast<int>(fx), j = static_cast<int>(fz);
  if (i + 1 >= nx_ || j + 1 >= nz_) return false;
  const size_t i00 = static_cast<size_t>(j) * nx_ + i, i10 = i00 + 1, i01 = i00 + nx_,
               i11 = i01 + 1;
  if (dist_[i00] < 0.f || dist_[i10] < 0.f || dist_[i01] < 0.f || dist_[i11] < 0.f) return false;
  const double a = fx - i, b = fz - j;
  auto lerp = [a, b](const std::vector<float>& v, size_t k00, size_t k10, size_t k01, size_t k11) {
    return (1 - b) * ((1 - a) * v[k00] + a * v[k10]) + b * ((1 - a) * v[k01] + a * v[k11]);
  };
  *s = lerp(s_, i00, i10, i01, i11);
  *l = lerp(l_, i00, i10, i01, i11);
  *heading = lerp(heading_, i00, i10, i01, i11);
  return true;
}

// ---------------------------------------------------------------------------------------------
// World

namespace {

// Vehicle states of every frame: arc length from the speed profile, pitch from braking and a slow
// oscillation, roll from the lateral acceleration in turns and a slow oscillation.
std::vector<VehicleState> PlanFrames(const DrivePath& path, const SyntheticOptions& options) {
  SplitMix64 rng(options.seed * 0x9E3779B97F4A7C15ull + 0xD1B54A32D192ED03ull);
  const int n = options.num_frames;
  std::vector<VehicleState> frames(n);
  std::vector<double> long_acc(n, 0.0), lat_acc(n, 0.0);
  double s = 0.0;
  for (int k = 0; k < n; ++k) {
    const PathSample p = path.At(s);
    frames[k].s_m = s;
    frames[k].speed = p.speed;
    lat_acc[k] = p.speed * p.speed * p.curvature;  // m / frame^2
    s += p.speed;
  }
  for (int k = 0; k < n; ++k) {
    const double v_prev = k > 0 ? frames[k - 1].speed : frames[k].speed;
    long_acc[k] = frames[k].speed - v_prev;
  }
  // Smooth the accelerations over +-4 frames (suspension response).
  long_acc = BoxFilter(BoxFilter(long_acc, 4), 4);
  lat_acc = BoxFilter(BoxFilter(lat_acc, 4), 4);
  const double p1 = rng.Uniform(35.0, 60.0), p2 = rng.Uniform(13.0, 23.0);
  const double r1 = rng.Uniform(45.0, 80.0), r2 = rng.Uniform(17.0, 29.0);
  const double ph[4] = {rng.Uniform(0, 2 * kPi), rng.Uniform(0, 2 * kPi), rng.Uniform(0, 2 * kPi),
                        rng.Uniform(0, 2 * kPi)};
  const double hb = rng.Uniform(9.0, 15.0), hph = rng.Uniform(0, 2 * kPi);
  for (int k = 0; k < n; ++k) {
    // Braking (negative acceleration) dips the nose: about 0.3 deg at 2 m/s^2.
    double pitch = 0.25 * std::sin(2 * kPi * k / p1 + ph[0]) +
                   0.1 * std::sin(2 * kPi * k / p2 + ph[1]) + 15.0 * long_acc[k];
    // The body rolls outwards in a turn: about 0.6 deg at 2.6 m/s^2.
    double roll = 0.2 * std::sin(2 * kPi * k / r1 + ph[2]) +
                  0.08 * std::sin(2 * kPi * k / r2 + ph[3]) - 23.0 * lat_acc[k];
    pitch = std::clamp(pitch, -1.0, 1.0) * kDegToRad;
    roll = std::clamp(roll, -1.0, 1.0) * kDegToRad;
    const PathSample p = path.At(frames[k].s_m);
    const double height = options.camera_height_m + 0.01 * std::sin(2 * kPi * k / hb + hph);
    frames[k].pitch_rad = pitch;
    frames[k].roll_rad = roll;
    const Eigen::Matrix3d R = RotY(p.heading_rad) * RotX(pitch) * RotZ(roll);
    frames[k].map_from_cam = SE3d(SO3d::FromMatrix(R), Eigen::Vector3d(p.x_m, -height, p.z_m));
  }
  return frames;
}

const Eigen::Vector3d kFacadeColours[] = {
    {0.56, 0.31, 0.24}, {0.64, 0.40, 0.30}, {0.76, 0.69, 0.56}, {0.62, 0.62, 0.64},
    {0.83, 0.81, 0.76}, {0.40, 0.38, 0.37}, {0.70, 0.60, 0.45}, {0.52, 0.56, 0.60},
    {0.80, 0.74, 0.62}, {0.46, 0.36, 0.30}};
const Eigen::Vector3d kCarColours[] = {{0.75, 0.08, 0.07}, {0.10, 0.16, 0.42}, {0.85, 0.85, 0.84},
                                       {0.12, 0.12, 0.13}, {0.55, 0.56, 0.58}, {0.20, 0.35, 0.22},
                                       {0.80, 0.65, 0.15}, {0.35, 0.35, 0.40}};

// Every point of the road centre line (1 m apart), for clearance checks.
std::vector<Eigen::Vector2d> CentreLine(const DrivePath& path, double lateral) {
  std::vector<Eigen::Vector2d> out;
  const int step = static_cast<int>(std::lround(1.0 / kPathSpacingM));
  for (size_t k = 0; k < path.samples().size(); k += step) {
    const PathSample& p = path.samples()[k];
    out.push_back(Eigen::Vector2d(p.x_m, p.z_m) + lateral * RightOf(p.heading_rad));
  }
  return out;
}

double MinDistance(const SceneBox& box, const std::vector<Eigen::Vector2d>& points) {
  double best = 1e300;
  for (const auto& q : points) best = std::min(best, DistanceToFootprint(box, q.x(), q.y()));
  return best;
}

bool OverlapsAny(const SceneBox& box, const std::vector<SceneBox>& boxes, double margin) {
  for (const auto& other : boxes) {
    const double reach =
        box.half_size.x() + box.half_size.z() + other.half_size.x() + other.half_size.z() + margin;
    if (std::abs(other.center.x() - box.center.x()) > reach ||
        std::abs(other.center.z() - box.center.z()) > reach) {
      continue;
    }
    if (FootprintsOverlap(box, other, margin)) return true;
  }
  return false;
}

// Gives a building box its facade: colour, pattern, floor and window sizes, texture seed. The
// draws from `rng` are in a fixed order, so a seed gives the same world.
void DressBuilding(SceneBox* box, SplitMix64* rng) {
  box->kind = BoxKind::kBuilding;
  box->colour = kFacadeColours[rng->UniformInt(0, 9)] * rng->Uniform(0.85, 1.12);
  box->pattern = static_cast<FacadePattern>(rng->UniformInt(0, 2));
  box->floor_height_m = rng->Uniform(2.9, 3.6);
  box->window_pitch_m = rng->Uniform(1.8, 3.2);
  box->window_width_frac = rng->Uniform(0.35, 0.62);
  box->window_height_frac = rng->Uniform(0.4, 0.6);
  box->texture_seed = static_cast<uint32_t>(rng->Next());
}

// A box of the given size whose near long side is at lateral offset l_near of the path at arc
// length s_mid (side +1: right of the path, -1: left), aligned with the path there.
SceneBox PlaceBox(const DrivePath& path, double s_mid, double l_near, int side, double depth,
                  double length, double height) {
  const PathSample p = path.At(s_mid);
  const double l_centre = l_near + side * 0.5 * depth;
  const Eigen::Vector2d c = Eigen::Vector2d(p.x_m, p.z_m) + l_centre * RightOf(p.heading_rad);
  SceneBox box;
  box.center = Eigen::Vector3d(c.x(), -0.5 * height, c.y());
  box.half_size = Eigen::Vector3d(0.5 * depth, 0.5 * height, 0.5 * length);
  box.yaw_rad = p.heading_rad;
  return box;
}

}  // namespace

SyntheticWorld SyntheticWorld::Build(const SyntheticOptions& options) {
  options.Check();
  SyntheticWorld world;
  // Long enough for the fastest possible drive plus the street beyond the last frame.
  world.path = DrivePath::Generate(options.seed, options.num_frames * 1.46 + kPathExtensionM);
  world.frames = PlanFrames(world.path, options);
  world.road = RoadGrid(world.path);
  world.texture_seed = static_cast<uint32_t>(options.seed * 2654435761u) ^ 0xA511E9B3u;
  {
    SplitMix64 rng(options.seed ^ 0x5A17D1C3B00Cull);
    const double azimuth = rng.Uniform(0.0, 2.0 * kPi);
    const double elevation = rng.Uniform(25.0, 55.0) * kDegToRad;
    world.sun_direction =
        Eigen::Vector3d(std::cos(elevation) * std::sin(azimuth), -std::sin(elevation),
                        std::cos(elevation) * std::cos(azimuth));
  }

  // Clearance checks run against the whole road, so a street that passes near another part of the
  // drive never gets a building on it.
  const std::vector<Eigen::Vector2d> road_centre = CentreLine(world.path, -kLaneOffsetM);
  const std::vector<Eigen::Vector2d> car_path = CentreLine(world.path, 0.0);
  const double s_begin = world.path.start_s() + 1.0, s_end = world.path.end_s() - 1.0;

  // Buildings on both sides, each side from its own random stream so that the layout near the
  // start does not depend on the sequence length.
  for (int side : {1, -1}) {
    SplitMix64 rng(options.seed * 0xBF58476D1CE4E5B9ull + (side > 0 ? 11u : 29u));
    double cursor = s_begin + rng.Uniform(0.0, 4.0);
    while (cursor < s_end) {
      const double length = rng.Uniform(6.0, 22.0);
      const double depth = rng.Uniform(8.0, 20.0);
      const double height = rng.Bernoulli(0.2) ? rng.Uniform(18.0, 32.0) : rng.Uniform(6.0, 18.0);
      const double setback = rng.Bernoulli(0.6) ? rng.Uniform(0.0, 0.6) : rng.Uniform(0.6, 3.0);
      const double gap = rng.Bernoulli(0.15) ? rng.Uniform(6.0, 14.0) : rng.Uniform(0.2, 2.5);
      const double q_near = kSidewalkOuterM + setback;
      const double l_near = side > 0 ? q_near - kLaneOffsetM : -q_near - kLaneOffsetM;
      SceneBox box =
          PlaceBox(world.path, cursor + 0.5 * length, l_near, side, depth, length, height);
      DressBuilding(&box, &rng);
      if (MinDistance(box, road_centre) >= kSidewalkOuterM - 0.4 &&
          !OverlapsAny(box, world.boxes, 0.05)) {
        world.boxes.push_back(box);
      }
      cursor += length + gap;
    }
  }

  // A second row of taller blocks behind the street front, for the skyline and the view into
  // cross streets and across open corners.
  for (int side : {1, -1}) {
    SplitMix64 rng(options.seed * 0xD6E8FEB86659FD93ull + (side > 0 ? 41u : 43u));
    double cursor = s_begin + rng.Uniform(0.0, 20.0);
    while (cursor < s_end) {
      const double length = rng.Uniform(15.0, 40.0);
      const double depth = rng.Uniform(12.0, 25.0);
      const double height = rng.Uniform(12.0, 38.0);
      const double gap = rng.Uniform(5.0, 30.0);
      const double q_near = kSidewalkOuterM + rng.Uniform(22.0, 45.0);
      const double l_near = side > 0 ? q_near - kLaneOffsetM : -q_near - kLaneOffsetM;
      SceneBox box =
          PlaceBox(world.path, cursor + 0.5 * length, l_near, side, depth, length, height);
      DressBuilding(&box, &rng);
      if (MinDistance(box, road_centre) >= kSidewalkOuterM + 2.0 &&
          !OverlapsAny(box, world.boxes, 1.0)) {
        world.boxes.push_back(box);
      }
      cursor += length + gap;
    }
  }

  // Parked cars in both parking lanes, not in corners.
  for (int side : {1, -1}) {
    SplitMix64 rng(options.seed * 0x94D049BB133111EBull + (side > 0 ? 101u : 211u));
    const double q_lane = 0.5 * (kLaneEdgeM + kKerbInnerM);
    const double l_mid = side > 0 ? q_lane - kLaneOffsetM : -q_lane - kLaneOffsetM;
    double cursor = s_begin + rng.Uniform(0.0, 10.0);
    while (cursor < s_end) {
      const bool van = rng.Bernoulli(0.15);
      const double length = van ? rng.Uniform(4.8, 5.6) : rng.Uniform(3.8, 4.8);
      const double width = rng.Uniform(1.7, 1.95);
      const double height = van ? rng.Uniform(1.9, 2.3) : rng.Uniform(1.35, 1.6);
      const double gap = rng.Bernoulli(0.3) ? rng.Uniform(10.0, 35.0) : rng.Uniform(0.8, 6.0);
      const int colour = rng.UniformInt(0, 7);
      const uint32_t tex = static_cast<uint32_t>(rng.Next());
      const double cabin_frac = rng.Uniform(0.45, 0.6);
      const double cabin_shift = rng.Uniform(-0.08, 0.08);
      const double s_mid = cursor + 0.5 * length;
      cursor += length + gap;
      bool in_turn = false;
      for (double ds = -12.0; ds <= 12.0; ds += 1.0) {
        if (std::abs(world.path.At(s_mid + ds).curvature) > 0.012) in_turn = true;
      }
      if (in_turn) continue;
      // Sedans: a body of 55% of the height and a cabin over the middle of it. Vans: one box.
      const double body_height = van ? height : 0.55 * height;
      SceneBox box =
          PlaceBox(world.path, s_mid, l_mid - side * 0.5 * width, side, width, length, body_height);
      box.kind = BoxKind::kCar;
      box.colour = kCarColours[colour];
      box.texture_seed = tex;
      if (MinDistance(box, car_path) >= 1.6 && !OverlapsAny(box, world.boxes, 0.3)) {
        world.boxes.push_back(box);
        if (!van) {
          SceneBox cabin = box;
          cabin.kind = BoxKind::kCarCabin;
          cabin.half_size = Eigen::Vector3d(0.5 * width - 0.08, 0.5 * (height - body_height),
                                            0.5 * cabin_frac * length);
          const Eigen::Vector3d along(std::sin(box.yaw_rad), 0.0, std::cos(box.yaw_rad));
          cabin.center = box.center + cabin_shift * length * along;
          cabin.center.y() = -body_height - cabin.half_size.y();
          world.boxes.push_back(cabin);
        }
      }
    }
  }
  return world;
}

}  // namespace synthetic
}  // namespace dfo
