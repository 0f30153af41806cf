#include "dfo_core/synthetic/renderer.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/parallel.h"
#include "dfo_core/synthetic/noise.h"

namespace dfo::synthetic {

namespace {

using Eigen::Vector3d;

constexpr int kTile = 16;
constexpr double kNearM = 0.05;
constexpr double kMaxRangeM = 700.0;  // boxes farther than this are not drawn (fogged away)
constexpr double kFogDistanceM = 900.0;
constexpr int kSky = -2;
constexpr int kGround = -1;

const Vector3d kHorizon(0.80, 0.83, 0.88);
const Vector3d kZenith(0.33, 0.52, 0.84);
const Vector3d kGrass(0.28, 0.36, 0.19);
const Vector3d kDirt(0.42, 0.37, 0.29);

// A box ready for ray tests in this view.
struct ViewBox {
  int index;  // into world.boxes
  Eigen::Matrix3d box_from_map;
  Vector3d origin_in_box;  // camera centre in box coordinates (relative to the box centre)
  Vector3d half;
};

// Nearest surface along a ray.
struct Hit {
  double t = 0.0;  // ray parameter; the ray's z in the camera is 1, so t is the z-depth
  int id = kSky;   // box index, kGround or kSky
  int axis = 0;    // box face: local axis and sign of its outward normal
  double sign = 1.0;
};

double Clamp01(double v) { return v < 0.0 ? 0.0 : (v > 1.0 ? 1.0 : v); }

// Fraction of the filter interval [c - w/2, c + w/2] inside [a, b] (point test for tiny w).
double BandWeight(double c, double w, double a, double b) {
  if (w < 1e-9) return (c >= a && c < b) ? 1.0 : 0.0;
  return Overlap(c - 0.5 * w, c + 0.5 * w, a, b) / w;
}

// Box filter of a random tint that is constant on the cells [i, i+1) x [j, j+1) of (u, v) (row j
// shifted by shift(j) along u), over the footprint [u +- wu/2] x [v +- wv/2] in cell units: the
// exact area-weighted mean of the covered cells, so the tint does not change with the level of
// detail. Footprints of many cells average to about 0 and are faded out.
template <typename ShiftFn>
double FilteredCellTint(double u, double v, double wu, double wv, uint32_t seed, int32_t salt,
                        ShiftFn shift) {
  const double cells = std::max(wu, wv);
  if (cells >= 6.0) return 0.0;
  const double fade = std::min(1.0, (6.0 - cells) / 2.0);
  auto tint = [&](int32_t i, int32_t j) { return HashUnit(i, j, salt, seed) - 0.5; };
  wu = std::max(wu, 1e-6);
  wv = std::max(wv, 1e-6);
  const double v0 = v - 0.5 * wv, v1 = v + 0.5 * wv;
  double sum = 0.0;
  for (int32_t j = static_cast<int32_t>(std::floor(v0)); j <= static_cast<int32_t>(std::floor(v1));
       ++j) {
    const double wj = Overlap(v0, v1, j, j + 1.0) / wv;
    const double su = u + shift(j), u0 = su - 0.5 * wu, u1 = su + 0.5 * wu;
    for (int32_t i = static_cast<int32_t>(std::floor(u0));
         i <= static_cast<int32_t>(std::floor(u1)); ++i) {
      sum += wj * Overlap(u0, u1, i, i + 1.0) / wu * tint(i, j);
    }
  }
  return fade * sum;
}

double NoShift(int32_t) { return 0.0; }

// Fractal noise at (x, y) filtered over the pixel footprint spanned by fu and fv (texture units
// per pixel step in u and v), anisotropically as GPUs do: at grazing angles the footprint is long
// and thin, and several taps along the long axis, each band-limited for the thin width, follow it.
// An isotropic filter of the long width would blur more, and differently at every distance,
// than the pixel integral does, which breaks the warping consistency between frames.
double AnisotropicNoise(double x, double y, const Eigen::Vector2d& fu, const Eigen::Vector2d& fv,
                        double base_frequency, int octaves, double gain, uint32_t seed) {
  const bool u_major = fu.squaredNorm() >= fv.squaredNorm();
  const Eigen::Vector2d& major = u_major ? fu : fv;
  const double major_len = major.norm();
  const double minor_len = (u_major ? fv : fu).norm();
  constexpr double kLacunarity = 2.17;  // as FilteredNoise2
  constexpr int kMaxTaps = 6;
  double sum = 0.0, amplitude = 1.0, frequency = base_frequency;
  for (int o = 0; o < octaves; ++o) {
    // Taps only where this octave needs them: none when it is smooth over the long axis, and the
    // octave is dropped once it is above Nyquist even across the thin axis.
    const double cycles_major = frequency * major_len;
    int taps = 1;
    if (cycles_major > 0.15) {
      taps = std::min(kMaxTaps, static_cast<int>(std::ceil(cycles_major / 0.15)));
    }
    const double width = std::max(minor_len, major_len / taps);
    const double w = BandLimit(frequency, width);
    if (w <= 0.0) break;
    const uint32_t octave_seed = seed + 7919u * o;
    double octave = 0.0;
    if (taps == 1) {
      octave = ValueNoise2(x * frequency, y * frequency, octave_seed);
    } else {
      for (int k = 0; k < taps; ++k) {
        const double a = (k + 0.5) / taps - 0.5;
        octave += ValueNoise2((x + a * major.x()) * frequency, (y + a * major.y()) * frequency,
                              octave_seed);
      }
      octave /= taps;
    }
    sum += w * amplitude * octave;
    amplitude *= gain;
    frequency *= kLacunarity;
  }
  return sum;
}

class ViewRenderer {
 public:
  ViewRenderer(const SyntheticWorld& world, const PinholeCamera& camera, const SE3d& map_from_cam,
               const SyntheticOptions& options)
      : world_(world), camera_(camera), options_(options) {
    R_ = map_from_cam.rotationMatrix();
    o_ = map_from_cam.translation();
    du_ = R_.col(0) / camera.fx;
    dv_ = R_.col(1) / camera.fy;
    tiles_x_ = (camera.width + kTile - 1) / kTile;
    tiles_y_ = (camera.height + kTile - 1) / kTile;
    tiles_.assign(static_cast<size_t>(tiles_x_) * tiles_y_, {});
    PrepareBoxes();
  }

  // Ray direction (map frame, camera z component 1) through continuous pixel (u, v).
  Vector3d Ray(double u, double v) const {
    return R_ * Vector3d((u - camera_.cx) / camera_.fx, (v - camera_.cy) / camera_.fy, 1.0);
  }

  Hit Trace(const Vector3d& dir, int tile) const {
    Hit hit;
    hit.t = 1e300;
    if (dir.y() > 1e-12) {  // y is down: the ray meets the road plane y = 0 ahead
      hit.t = -o_.y() / dir.y();
      hit.id = kGround;
    }
    for (int k : tiles_[tile]) {
      const ViewBox& b = boxes_[k];
      const Vector3d d = b.box_from_map * dir;
      double t_near = -1e300, t_far = 1e300;
      int axis = 0;
      bool miss = false;
      for (int a = 0; a < 3; ++a) {
        const double o = b.origin_in_box[a], h = b.half[a];
        if (std::abs(d[a]) < 1e-15) {
          if (o < -h || o > h) {
            miss = true;
            break;
          }
          continue;
        }
        const double inv = 1.0 / d[a];
        double t0 = (-h - o) * inv, t1 = (h - o) * inv;
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > t_near) {
          t_near = t0;
          axis = a;
        }
        t_far = std::min(t_far, t1);
        if (t_near > t_far) {
          miss = true;
          break;
        }
      }
      if (miss || t_near <= 1e-9 || t_near >= hit.t) continue;
      hit.t = t_near;
      hit.id = b.index;
      hit.axis = axis;
      hit.sign = d[axis] > 0 ? -1.0 : 1.0;
    }
    if (hit.id == kSky) hit.t = 0.0;
    return hit;
  }

  // Colour of the surface hit by ray `dir`; *label receives its class.
  Vector3d Shade(const Hit& hit, const Vector3d& dir, uint8_t* label) const {
    if (hit.id == kSky) {
      *label = static_cast<uint8_t>(SurfaceClass::kSky);
      return Sky(dir);
    }
    const Vector3d p = o_ + hit.t * dir;
    Vector3d n;
    if (hit.id == kGround) {
      n = Vector3d(0, -1, 0);
    } else {
      n = world_.boxes[hit.id].MapFromBox().col(hit.axis) * hit.sign;
    }
    // Ray differentials: how the hit point moves per pixel in u and v on the plane with normal n.
    const double nd = n.dot(dir);
    const Vector3d dpdu = hit.t * (du_ - dir * (n.dot(du_) / nd));
    const Vector3d dpdv = hit.t * (dv_ - dir * (n.dot(dv_) / nd));
    Vector3d colour;
    if (hit.id == kGround) {
      colour = Ground(p, dpdu, dpdv, label);
    } else {
      const SceneBox& box = world_.boxes[hit.id];
      colour = box.kind == BoxKind::kBuilding ? Facade(box, hit, p, n, dpdu, dpdv, label)
                                              : Car(box, hit, p, n, dpdu, dpdv, label);
    }
    const double fog = 1.0 - std::exp(-(hit.t * dir).norm() / kFogDistanceM);
    return colour + fog * (kHorizon - colour);
  }

  void RenderPass(int first_row, int row_step, RenderedView* view, std::vector<int>* ids) const {
    for (int y = first_row; y < camera_.height; y += row_step) {
      for (int x = 0; x < camera_.width; ++x) {
        const Vector3d dir = Ray(x, y);
        const Hit hit = Trace(dir, TileOf(x, y));
        uint8_t label = 0;
        const Vector3d c = Shade(hit, dir, &label);
        Store(view, x, y, c);
        view->labels(x, y) = label;
        (*ids)[static_cast<size_t>(y) * camera_.width + x] = hit.id;
        const bool has_depth = hit.id != kSky && hit.t <= options_.max_depth_m;
        view->depth(x, y) = has_depth ? static_cast<float>(hit.t) : 0.f;
      }
    }
  }

  // Re-shades silhouette pixels (a 4-neighbour sees another surface) as the mean of 3 x 3
  // samples, i.e. box-filters the geometric edges as the textures are.
  void AntialiasPass(int first_row, int row_step, const std::vector<int>& ids,
                     RenderedView* view) const {
    const int w = camera_.width, h = camera_.height;
    for (int y = first_row; y < h; y += row_step) {
      for (int x = 0; x < w; ++x) {
        const int id = ids[static_cast<size_t>(y) * w + x];
        bool edge = false;
        if (x > 0 && ids[static_cast<size_t>(y) * w + x - 1] != id) edge = true;
        if (x + 1 < w && ids[static_cast<size_t>(y) * w + x + 1] != id) edge = true;
        if (y > 0 && ids[static_cast<size_t>(y - 1) * w + x] != id) edge = true;
        if (y + 1 < h && ids[static_cast<size_t>(y + 1) * w + x] != id) edge = true;
        if (!edge) continue;
        Vector3d sum = Vector3d::Zero();
        const int tile = TileOf(x, y);
        // Sample offsets cover the same width as the texture filter (texture_filter_scale px).
        const double spread = std::min(2.0, options_.texture_filter_scale) / 3.0;
        for (int j = -1; j <= 1; ++j) {
          for (int i = -1; i <= 1; ++i) {
            const Vector3d dir = Ray(x + i * spread, y + j * spread);
            uint8_t label = 0;
            sum += Shade(Trace(dir, tile), dir, &label);
          }
        }
        Store(view, x, y, sum / 9.0);
      }
    }
  }

 private:
  int TileOf(int x, int y) const { return (y / kTile) * tiles_x_ + x / kTile; }

  static void Store(RenderedView* view, int x, int y, const Vector3d& c) {
    const double r = Clamp01(c.x()), g = Clamp01(c.y()), b = Clamp01(c.z());
    view->rgb(x, y, 0) = static_cast<uint8_t>(r * 255.0 + 0.5);
    view->rgb(x, y, 1) = static_cast<uint8_t>(g * 255.0 + 0.5);
    view->rgb(x, y, 2) = static_cast<uint8_t>(b * 255.0 + 0.5);
    // ITU-R BT.601 luma, as OpenCV's RGB2GRAY and KITTI's grey camera approximately.
    view->gray(x, y) = static_cast<uint8_t>((0.299 * r + 0.587 * g + 0.114 * b) * 255.0 + 0.5);
  }

  void PrepareBoxes() {
    const Eigen::Matrix3d cam_from_map = R_.transpose();
    const int w = camera_.width, h = camera_.height;
    for (size_t i = 0; i < world_.boxes.size(); ++i) {
      const SceneBox& box = world_.boxes[i];
      const double radius = box.half_size.norm();
      const Vector3d rel = box.center - o_;
      if (rel.norm() - radius > kMaxRangeM) continue;
      const Eigen::Matrix3d map_from_box = box.MapFromBox();
      int behind = 0;
      double umin = 1e300, umax = -1e300, vmin = 1e300, vmax = -1e300;
      for (int c = 0; c < 8; ++c) {
        const Vector3d corner_in_box((c & 1 ? 1 : -1) * box.half_size.x(),
                                     (c & 2 ? 1 : -1) * box.half_size.y(),
                                     (c & 4 ? 1 : -1) * box.half_size.z());
        const Vector3d pc = cam_from_map * (rel + map_from_box * corner_in_box);
        if (pc.z() < kNearM) {
          ++behind;
          continue;
        }
        const double u = camera_.fx * pc.x() / pc.z() + camera_.cx;
        const double v = camera_.fy * pc.y() / pc.z() + camera_.cy;
        umin = std::min(umin, u);
        umax = std::max(umax, u);
        vmin = std::min(vmin, v);
        vmax = std::max(vmax, v);
      }
      if (behind == 8) continue;
      int x0 = 0, x1 = w - 1, y0 = 0, y1 = h - 1;
      if (behind == 0) {
        // Conservative: one pixel of margin for the supersampling offsets and round-off.
        if (umax < -2 || vmax < -2 || umin > w + 1 || vmin > h + 1) continue;
        x0 = std::max(0, static_cast<int>(std::floor(umin)) - 1);
        x1 = std::min(w - 1, static_cast<int>(std::ceil(umax)) + 1);
        y0 = std::max(0, static_cast<int>(std::floor(vmin)) - 1);
        y1 = std::min(h - 1, static_cast<int>(std::ceil(vmax)) + 1);
      }
      ViewBox vb;
      vb.index = static_cast<int>(i);
      vb.box_from_map = map_from_box.transpose();
      vb.origin_in_box = vb.box_from_map * (o_ - box.center);
      vb.half = box.half_size;
      const int k = static_cast<int>(boxes_.size());
      boxes_.push_back(vb);
      for (int ty = y0 / kTile; ty <= y1 / kTile; ++ty) {
        for (int tx = x0 / kTile; tx <= x1 / kTile; ++tx) tiles_[ty * tiles_x_ + tx].push_back(k);
      }
    }
  }

  // Sky at infinity: depends on the ray direction only. Horizon-to-zenith gradient, a glow around
  // the sun and soft clouds from 3D noise on the direction sphere (low angular frequencies only).
  Vector3d Sky(const Vector3d& dir) const {
    const Vector3d d = dir.normalized();
    const double up = -d.y();
    const double e = std::sqrt(std::max(0.0, up));
    Vector3d c = kHorizon + e * (kZenith - kHorizon);
    const double sun = std::max(0.0, d.dot(world_.sun_direction));
    c += Vector3d(0.18, 0.15, 0.08) * std::pow(sun, 24.0);
    const uint32_t seed = world_.texture_seed + 17u;
    double cloud = 0.6 * ValueNoise3(d.x() * 3.0, d.y() * 3.0, d.z() * 3.0, seed) +
                   0.3 * ValueNoise3(d.x() * 7.0, d.y() * 7.0, d.z() * 7.0, seed + 1) +
                   0.15 * ValueNoise3(d.x() * 16.0, d.y() * 16.0, d.z() * 16.0, seed + 2);
    cloud = Clamp01((cloud - 0.05) * 1.6) * Clamp01(up * 6.0 + 0.3);
    return c + cloud * (Vector3d(0.93, 0.93, 0.95) - c);
  }

  // Road plane: asphalt with lane markings, parking lanes, kerbs, sidewalks, verges. Material
  // boundaries are box-filtered across the footprint, textures are band-limited.
  Vector3d Ground(const Vector3d& p, const Vector3d& dpdu, const Vector3d& dpdv,
                  uint8_t* label) const {
    const double scale = options_.texture_filter_scale;
    const double x = p.x(), z = p.z();
    const Eigen::Vector2d fu = scale * Eigen::Vector2d(dpdu.x(), dpdu.z());
    const Eigen::Vector2d fv = scale * Eigen::Vector2d(dpdv.x(), dpdv.z());
    auto noise = [&](double base_frequency, int octaves, double gain, uint32_t nseed) {
      return AnisotropicNoise(x, z, fu, fv, base_frequency, octaves, gain, nseed);
    };
    const uint32_t seed = world_.texture_seed;

    double s = 0, l = 0, heading = 0;
    const bool near_road = world_.road.Lookup(x, z, &s, &l, &heading);
    // Verge: grass and soil, strong noise at several scales.
    auto verge = [&]() {
      const double n1 = noise(0.05, 9, 0.55, seed + 101);
      const double n2 = noise(0.7, 4, 0.5, seed + 151);
      const double soil = Clamp01(0.5 + 0.7 * n1);
      return (kGrass + soil * (kDirt - kGrass)) * (1.0 + 0.25 * n2);
    };
    if (!near_road) {
      *label = static_cast<uint8_t>(SurfaceClass::kVerge);
      return verge();
    }
    const Vector3d t(std::sin(heading), 0.0, std::cos(heading));
    const Vector3d r(std::cos(heading), 0.0, -std::sin(heading));
    const double ws = scale * (std::abs(dpdu.dot(t)) + std::abs(dpdv.dot(t)));
    const double wq = scale * (std::abs(dpdu.dot(r)) + std::abs(dpdv.dot(r)));
    const double q = l + kLaneOffsetM;
    const double aq = std::abs(q);
    *label = static_cast<uint8_t>(aq < kKerbInnerM       ? SurfaceClass::kRoad
                                  : aq < kSidewalkOuterM ? SurfaceClass::kSidewalk
                                                         : SurfaceClass::kVerge);
    // Weights of the bands across the street under the filter.
    const double w_road = BandWeight(q, wq, -kKerbInnerM, kKerbInnerM);
    const double w_kerb =
        BandWeight(q, wq, kKerbInnerM, kKerbOuterM) + BandWeight(q, wq, -kKerbOuterM, -kKerbInnerM);
    const double w_walk = BandWeight(q, wq, kKerbOuterM, kSidewalkOuterM) +
                          BandWeight(q, wq, -kSidewalkOuterM, -kKerbOuterM);
    const double w_verge = std::max(0.0, 1.0 - w_road - w_kerb - w_walk);
    Vector3d colour = Vector3d::Zero();
    if (w_road > 0) {
      // Asphalt: grey with noise from 12 m patches down to millimetre grain, darker tyre tracks.
      const double n = noise(0.08, 9, 0.55, seed + 1);
      double tracks = 0.0;
      for (double centre : {-2.65, -0.95, 0.95, 2.65}) {
        tracks += BandWeight(q, wq, centre - 0.3, centre + 0.3);
      }
      const double b = 0.30 * (1.0 + 0.35 * n) * (1.0 - 0.12 * tracks);
      Vector3d asphalt(b, b, b * 1.04);
      // Dashed centre line (3 m dash, 9 m period), solid lane edges, parking bay ticks.
      const double centre_line =
          BandWeight(q, wq, -0.075, 0.075) * FilteredPulseTrain(s / 9.0, 3.0 / 9.0, ws / 9.0);
      const double edges = BandWeight(q, wq, kLaneEdgeM - 0.075, kLaneEdgeM + 0.075) +
                           BandWeight(q, wq, -kLaneEdgeM - 0.075, -kLaneEdgeM + 0.075);
      const double bays = (BandWeight(q, wq, kLaneEdgeM, kKerbInnerM) +
                           BandWeight(q, wq, -kKerbInnerM, -kLaneEdgeM)) *
                          FilteredPulseTrain(s / 6.0 + 0.3, 0.12 / 6.0, ws / 6.0);
      const double m = Clamp01(centre_line + edges + bays);
      if (m > 0.0) {
        const double wear = 0.9 + 0.1 * noise(1.5, 5, 0.6, seed + 3);
        asphalt += m * (Vector3d(0.86, 0.86, 0.80) * wear - asphalt);
      }
      colour += w_road * asphalt;
    }
    if (w_kerb > 0) {
      const double joints = FilteredPulseTrain(s / 1.0, 0.96, ws);
      const double n = noise(0.5, 5, 0.6, seed + 5);
      colour += w_kerb * Vector3d(0.68, 0.67, 0.64) * (0.7 + 0.3 * joints) * (1.0 + 0.12 * n);
    }
    if (w_walk > 0) {
      // Paving slabs of 0.9 m with dark joints and a per-slab tint (faded when slabs shrink to
      // a pixel), over noise.
      const double slab_u = s / 0.9, slab_v = (aq - kKerbOuterM) / 0.9;
      const double joints =
          FilteredPulseTrain(slab_u, 0.96, ws / 0.9) * FilteredPulseTrain(slab_v, 0.96, wq / 0.9);
      const double tint = 0.16 * FilteredCellTint(slab_u, slab_v, ws / 0.9, wq / 0.9, seed + 7,
                                                  q > 0 ? 1 : 2, NoShift);
      const double n = noise(0.2, 8, 0.55, seed + 9);
      const double b = (1.0 + tint) * (0.75 + 0.25 * joints) * (1.0 + 0.15 * n);
      colour += w_walk * Vector3d(0.60, 0.58, 0.55) * b;
    }
    if (w_verge > 0) colour += w_verge * verge();
    return colour;
  }

  // Diffuse sunlight plus sky light, from the surface normal.
  double Lighting(const Vector3d& n) const {
    return 0.62 + 0.5 * std::max(0.0, n.dot(world_.sun_direction)) - 0.08 * std::max(0.0, n.y());
  }

  // Facade coordinates of a hit on a vertical face: u along the face, v height above the road,
  // and the filter widths along them.
  void FaceCoordinates(const SceneBox& box, const Hit& hit, const Vector3d& p, const Vector3d& dpdu,
                       const Vector3d& dpdv, double* u, double* v, double* wu, double* wv,
                       Eigen::Vector2d* fu, Eigen::Vector2d* fv) const {
    const Eigen::Matrix3d map_from_box = box.MapFromBox();
    const Vector3d local = map_from_box.transpose() * (p - box.center);
    const int along = hit.axis == 0 ? 2 : 0;
    *u = local[along] + box.half_size[along];
    *v = -p.y();
    const Vector3d axis_u = map_from_box.col(along);
    const double scale = options_.texture_filter_scale;
    *wu = scale * (std::abs(dpdu.dot(axis_u)) + std::abs(dpdv.dot(axis_u)));
    *wv = scale * (std::abs(dpdu.y()) + std::abs(dpdv.y()));
    *fu = scale * Eigen::Vector2d(dpdu.dot(axis_u), -dpdu.y());
    *fv = scale * Eigen::Vector2d(dpdv.dot(axis_u), -dpdv.y());
  }

  Vector3d Facade(const SceneBox& box, const Hit& hit, const Vector3d& p, const Vector3d& n,
                  const Vector3d& dpdu, const Vector3d& dpdv, uint8_t* label) const {
    *label = static_cast<uint8_t>(SurfaceClass::kBuilding);
    const uint32_t seed = box.texture_seed;
    const double light = Lighting(n);
    if (hit.axis == 1) {  // roof
      const double w =
          std::abs(dpdu.x()) + std::abs(dpdv.x()) + std::abs(dpdu.z()) + std::abs(dpdv.z());
      const double noise = FilteredNoise2(p.x(), p.z(), 0.2, 8, 0.6, w, seed);
      return Vector3d(0.42, 0.40, 0.40) * light * (1.0 + 0.2 * noise);
    }
    double u, v, wu, wv;
    Eigen::Vector2d fu, fv;
    FaceCoordinates(box, hit, p, dpdu, dpdv, &u, &v, &wu, &wv, &fu, &fv);
    const double height = 2.0 * box.half_size.y();

    // Wall material.
    Vector3d wall = box.colour;
    if (box.pattern == FacadePattern::kBrick) {
      // Bricks 0.24 x 0.075 m in running bond with light mortar; per-brick tint.
      const double row = v / 0.075;
      const double shift = (static_cast<int64_t>(std::floor(row)) & 1) ? 0.5 : 0.0;
      const double col = u / 0.24 + shift;
      const double brick =
          FilteredPulseTrain(row, 0.86, wv / 0.075) * FilteredPulseTrain(col, 0.93, wu / 0.24);
      const double tint = 0.22 * FilteredCellTint(u / 0.24, row, wu / 0.24, wv / 0.075, seed, 3,
                                                  [](int32_t j) { return (j & 1) ? 0.5 : 0.0; });
      wall = wall * (1.0 + tint) * (0.55 + 0.45 * brick) +
             0.45 * Vector3d(0.74, 0.72, 0.68) * (1.0 - brick);
    } else if (box.pattern == FacadePattern::kPanels) {
      // Panels of 1.5 m by half a storey, dark joints, per-panel tint.
      const double pu = u / 1.5, pv = v / (0.5 * box.floor_height_m);
      const double panel = FilteredPulseTrain(pu, 0.985, wu / 1.5) *
                           FilteredPulseTrain(pv, 0.975, wv / (0.5 * box.floor_height_m));
      const double tint = 0.12 * FilteredCellTint(pu, pv, wu / 1.5, wv / (0.5 * box.floor_height_m),
                                                  seed, 5, NoShift);
      wall = wall * (1.0 + tint) * (0.55 + 0.45 * panel);
    }
    // Plaster grain and weathering at all scales (every pattern).
    const double grain = AnisotropicNoise(u, v, fu, fv, 0.15, 9, 0.55, seed + 11);
    wall *= 1.0 + (box.pattern == FacadePattern::kPlaster ? 0.22 : 0.12) * grain;
    // Plinth and cornice bands.
    wall *= 1.0 - 0.25 * BandWeight(v, wv, 0.0, 0.45) -
            0.3 * BandWeight(v, wv, height - 0.5, height + 1.0);

    // Windows: upper storeys on a grid, shop windows and doors on the ground floor.
    const double pitch = box.window_pitch_m, storey = box.floor_height_m;
    const double col = u / pitch - 0.5 * (1.0 - box.window_width_frac);
    const double row = v / storey - 0.55 * (1.0 - box.window_height_frac);
    const double upper = FilteredPulseTrain(col, box.window_width_frac, wu / pitch) *
                         FilteredPulseTrain(row, box.window_height_frac, wv / storey) *
                         BandWeight(v, wv, storey, height - 0.9);
    const double shop = FilteredPulseTrain(u / pitch - 0.08, 0.84, wu / pitch) *
                        BandWeight(v, wv, 0.55, std::min(storey - 0.5, 2.7));
    const double glass_mask = Clamp01(upper + shop);
    Vector3d colour = wall * light;
    if (glass_mask > 0.0) {
      // The panes reflect the sky unevenly: a smooth field over the facade (a random value per
      // pane would change with the level of detail and break the warping consistency).
      const double reflect =
          0.05 + 0.32 * (0.5 + 0.5 * ValueNoise2(u / (2.3 * pitch), v / (1.7 * storey), seed + 13));
      const Vector3d glass = Vector3d(0.10, 0.12, 0.16) + reflect * Vector3d(0.45, 0.5, 0.58);
      // Window frames: a light mullion in the middle of each opening.
      const double frame = 1.0 - FilteredPulseTrain(col / box.window_width_frac * 2.0 - 0.5, 0.92,
                                                    wu / pitch / box.window_width_frac * 2.0);
      const Vector3d pane_colour = glass + 0.35 * frame * (Vector3d(0.8, 0.8, 0.78) - glass);
      colour += glass_mask * (pane_colour * (0.75 + 0.25 * light) - colour);
    }
    return colour;
  }

  Vector3d Car(const SceneBox& box, const Hit& hit, const Vector3d& p, const Vector3d& n,
               const Vector3d& dpdu, const Vector3d& dpdv, uint8_t* label) const {
    *label = static_cast<uint8_t>(SurfaceClass::kCar);
    const double light = Lighting(n);
    if (hit.axis == 1) {  // roof
      const double w =
          std::abs(dpdu.x()) + std::abs(dpdv.x()) + std::abs(dpdu.z()) + std::abs(dpdv.z());
      const double noise = FilteredNoise2(p.x(), p.z(), 1.0, 5, 0.6, w, box.texture_seed);
      return box.colour * light * (0.9 + 0.08 * noise);
    }
    double u, v, wu, wv;
    Eigen::Vector2d fu, fv;
    FaceCoordinates(box, hit, p, dpdu, dpdv, &u, &v, &wu, &wv, &fu, &fv);
    const double length = 2.0 * box.half_size[hit.axis == 0 ? 2 : 0];
    const double bottom = -(box.center.y() + box.half_size.y());  // heights above the road
    const double top = -(box.center.y() - box.half_size.y());
    Vector3d colour = box.colour * light *
                      (1.0 + 0.06 * AnisotropicNoise(u, v, fu, fv, 2.0, 5, 0.6, box.texture_seed));
    const Vector3d glass_colour =
        Vector3d(0.08, 0.10, 0.13) + 0.2 * Vector3d(0.5, 0.55, 0.6) * light;
    if (box.kind == BoxKind::kCarCabin) {
      // Side windows split by a pillar, windscreen and rear window on the ends.
      double glass = BandWeight(v, wv, bottom + 0.04, top - 0.07) *
                     BandWeight(u, wu, 0.07 * length, 0.93 * length);
      if (hit.axis == 0) glass *= 1.0 - BandWeight(u, wu, 0.47 * length, 0.53 * length);
      colour += glass * (glass_colour - colour);
      return colour;
    }
    if (top - bottom > 1.2) {  // a van: one box with a band of windows
      const double glass = BandWeight(v, wv, 0.58 * top, 0.93 * top) *
                           BandWeight(u, wu, 0.12 * length, 0.88 * length);
      colour += glass * (glass_colour - colour);
    }
    // Bumpers, wheels (long sides), lights (ends).
    const double bumper = BandWeight(v, wv, 0.25, 0.42);
    colour += bumper * 0.6 * (Vector3d(0.1, 0.1, 0.1) - colour);
    if (hit.axis == 0) {
      const double wheels =
          BandWeight(v, wv, 0.0, 0.62) *
          (BandWeight(u, wu, 0.5, 1.2) + BandWeight(u, wu, length - 1.2, length - 0.5));
      colour += wheels * (Vector3d(0.05, 0.05, 0.05) - colour);
    } else {
      const double lights =
          BandWeight(v, wv, 0.5, 0.7) *
          (BandWeight(u, wu, 0.1, 0.4) + BandWeight(u, wu, length - 0.4, length - 0.1));
      colour += lights * (Vector3d(0.85, 0.75, 0.6) - colour);
    }
    return colour;
  }

  const SyntheticWorld& world_;
  const PinholeCamera& camera_;
  const SyntheticOptions& options_;
  Eigen::Matrix3d R_;
  Vector3d o_, du_, dv_;
  int tiles_x_ = 0, tiles_y_ = 0;
  std::vector<ViewBox> boxes_;
  std::vector<std::vector<int>> tiles_;
};

}  // namespace

RenderedView RenderView(const SyntheticWorld& world, const PinholeCamera& camera,
                        const SE3d& map_from_cam, const SyntheticOptions& options,
                        int num_threads) {
  DFO_CHECK(num_threads >= 1) << "num_threads = " << num_threads;
  camera.Check();
  const ViewRenderer renderer(world, camera, map_from_cam, options);
  RenderedView view;
  view.rgb = ImageU8(camera.width, camera.height, 3);
  view.gray = ImageU8(camera.width, camera.height, 1);
  view.depth = ImageF(camera.width, camera.height, 1);
  view.labels = ImageU8(camera.width, camera.height, 1);
  std::vector<int> ids(static_cast<size_t>(camera.width) * camera.height, kSky);
  const int threads = std::min(num_threads, camera.height);
  RunOnThreads(threads, [&](int k) { renderer.RenderPass(k, threads, &view, &ids); });
  if (options.antialias_edges) {
    RunOnThreads(threads, [&](int k) { renderer.AntialiasPass(k, threads, ids, &view); });
  }
  return view;
}

}  // namespace dfo::synthetic
