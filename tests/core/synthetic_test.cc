// Tests of the procedural synthetic sequence: options, determinism, the drive's statistics, depth
// coverage, and the honest check that ground-truth depth and poses explain the images (warping).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/noise.h"
#include "dfo_core/synthetic/synthetic_sequence.h"

namespace dfo {
namespace {

constexpr double kPi = 3.14159265358979323846;

SyntheticOptions ShortOptions(uint64_t seed, int frames) {
  SyntheticOptions options;
  options.seed = seed;
  options.num_frames = frames;
  return options;
}

// Heading of the camera's optical axis in the world x-z plane.
double Heading(const SE3d& world_from_cam) {
  const Eigen::Vector3d z = world_from_cam.rotationMatrix().col(2);
  return std::atan2(z.x(), z.z());
}

double WrapAngle(double a) {
  while (a > kPi) a -= 2 * kPi;
  while (a < -kPi) a += 2 * kPi;
  return a;
}

TEST(SyntheticOptionsTest, DefaultsAreValidAndKittiLike) {
  const SyntheticOptions options;
  EXPECT_NO_THROW(options.Check());
  const PinholeCamera camera = options.Camera();
  EXPECT_EQ(camera.width, 416);
  EXPECT_EQ(camera.height, 128);
  // fx = 0.5 * w / tan(40 deg).
  EXPECT_NEAR(camera.fx, 0.5 * 416 / std::tan(40.0 * kPi / 180.0), 1e-9);
  EXPECT_DOUBLE_EQ(camera.fx, camera.fy);
  EXPECT_DOUBLE_EQ(camera.cx, 207.5);
  EXPECT_DOUBLE_EQ(camera.cy, 63.5);
}

TEST(SyntheticOptionsTest, CheckNamesFieldValueAndRule) {
  SyntheticOptions options;
  options.num_frames = 0;
  try {
    options.Check();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("num_frames = 0"), std::string::npos) << what;
    EXPECT_NE(what.find(">= 1"), std::string::npos) << what;
  }
  options = SyntheticOptions();
  options.horizontal_fov_deg = 170.0;
  EXPECT_THROW(options.Check(), ConfigError);
  options = SyntheticOptions();
  options.width = 8;
  EXPECT_THROW(options.Check(), ConfigError);
  options = SyntheticOptions();
  options.max_depth_m = 300.0;
  EXPECT_THROW(options.Check(), ConfigError);
  options = SyntheticOptions();
  options.camera_height_m = -1.0;
  EXPECT_THROW(SyntheticSequence{options}, ConfigError);
}

TEST(SyntheticNoiseTest, FilteredPulseTrainAveragesToDutyWhenWide) {
  // Exact box filter: a filter of one whole period returns the duty cycle anywhere.
  for (double x : {0.0, 0.13, 0.5, 7.77}) {
    EXPECT_NEAR(synthetic::FilteredPulseTrain(x, 0.3, 1.0), 0.3, 1e-12);
    EXPECT_NEAR(synthetic::FilteredPulseTrain(x, 0.3, 5.0), 0.3, 1e-12);
  }
  EXPECT_DOUBLE_EQ(synthetic::FilteredPulseTrain(0.1, 0.3, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(synthetic::FilteredPulseTrain(0.5, 0.3, 0.0), 0.0);
  // Noise octaves above Nyquist for the footprint are removed.
  EXPECT_DOUBLE_EQ(synthetic::BandLimit(10.0, 0.1), 0.0);
  EXPECT_DOUBLE_EQ(synthetic::BandLimit(1.0, 0.1), 1.0);
}

TEST(SyntheticSequenceTest, FirstPoseIsIdentityAndTimesAreKitti) {
  const SyntheticSequence sequence(ShortOptions(1, 20));
  const SE3d& first = sequence.WorldFromCam(0);
  EXPECT_TRUE(first.rotationMatrix().isIdentity(0.0));
  EXPECT_EQ(first.translation().norm(), 0.0);
  EXPECT_EQ(sequence.TimestampNs(0), 0);
  EXPECT_EQ(sequence.TimestampNs(7), 700000000);
  EXPECT_EQ(sequence.GroundTruth().size(), 20u);
  EXPECT_THROW(sequence.WorldFromCam(20), InternalError);
}

// Statistics of the 500-frame drive, from the poses only (no rendering): about 1 m per frame
// with speed changes, turns, small pitch and roll, camera at its height above the road.
TEST(SyntheticSequenceTest, DriveHasKittiLikeMotion) {
  for (uint64_t seed : {1u, 2u, 3u, 7u, 1234u}) {
    const SyntheticSequence sequence(ShortOptions(seed, 500));
    const Trajectory truth = sequence.GroundTruth();
    double step_sum = 0, step_min = 1e9, step_max = 0, turn = 0, max_pitch = 0, max_roll = 0;
    for (size_t i = 1; i < truth.size(); ++i) {
      const double step =
          (truth[i].world_from_cam.translation() - truth[i - 1].world_from_cam.translation())
              .norm();
      step_sum += step;
      step_min = std::min(step_min, step);
      step_max = std::max(step_max, step);
      turn += std::abs(
          WrapAngle(Heading(truth[i].world_from_cam) - Heading(truth[i - 1].world_from_cam)));
    }
    for (const auto& f : sequence.world().frames) {
      max_pitch = std::max(max_pitch, std::abs(f.pitch_rad));
      max_roll = std::max(max_roll, std::abs(f.roll_rad));
    }
    const double mean_step = step_sum / (truth.size() - 1);
    SCOPED_TRACE("seed " + std::to_string(seed));
    EXPECT_GT(mean_step, 0.85);
    EXPECT_LT(mean_step, 1.2);
    EXPECT_GT(step_min, 0.5);
    EXPECT_LT(step_max, 1.5);
    EXPECT_GT(step_max - step_min, 0.5);  // the speed changes
    EXPECT_GT(turn * 180.0 / kPi, 60.0);
    EXPECT_GT(max_pitch * 180.0 / kPi, 0.1);
    EXPECT_LE(max_pitch * 180.0 / kPi, 1.0 + 1e-9);
    EXPECT_GT(max_roll * 180.0 / kPi, 0.1);
    EXPECT_LE(max_roll * 180.0 / kPi, 1.0 + 1e-9);
    // Camera height above the road plane (y = 0 in the map, y down).
    for (const auto& f : sequence.world().frames) {
      EXPECT_NEAR(-f.map_from_cam.translation().y(), 1.65, 0.02);
    }
  }
}

TEST(SyntheticSequenceTest, NoBoxOnTheDrivenRoad) {
  const SyntheticSequence sequence(ShortOptions(5, 500));
  ASSERT_GT(sequence.world().boxes.size(), 50u);
  for (const auto& f : sequence.world().frames) {
    const Eigen::Vector3d c = f.map_from_cam.translation();
    for (const auto& box : sequence.world().boxes) {
      ASSERT_GT(synthetic::DistanceToFootprint(box, c.x(), c.z()), 1.5);
    }
  }
}

TEST(SyntheticSequenceTest, SameSeedSamePixelsOtherSeedOtherWorld) {
  const SyntheticSequence a(ShortOptions(42, 12));
  const SyntheticSequence b(ShortOptions(42, 12));
  const SyntheticSequence c(ShortOptions(43, 12));
  for (int i : {0, 11}) {
    const SyntheticFrame fa = a.RenderFrame(i, 1);
    const SyntheticFrame fb = b.RenderFrame(i, 2);  // thread count does not matter either
    EXPECT_EQ(fa.gray.vector(), fb.gray.vector());
    EXPECT_EQ(fa.rgb.vector(), fb.rgb.vector());
    EXPECT_EQ(fa.depth.vector(), fb.depth.vector());
    const SyntheticFrame fc = c.RenderFrame(i, 1);
    EXPECT_NE(fa.gray.vector(), fc.gray.vector());
  }
  EXPECT_NE(a.WorldFromCam(11).translation(), c.WorldFromCam(11).translation());
}

TEST(SyntheticSequenceTest, ImagesAreTexturedAndDepthCoversTheScene) {
  const SyntheticSequence sequence(ShortOptions(3, 60));
  for (int i : {0, 30, 59}) {
    const SyntheticFrame frame = sequence.RenderFrame(i, 2);
    ASSERT_EQ(frame.gray.width(), 416);
    ASSERT_EQ(frame.gray.height(), 128);
    ASSERT_EQ(frame.rgb.channels(), 3);
    int non_sky = 0, with_depth = 0, sky_with_depth = 0;
    double sum = 0, sum_sq = 0;
    for (int y = 0; y < 128; ++y) {
      for (int x = 0; x < 416; ++x) {
        const bool sky = frame.labels(x, y) == static_cast<uint8_t>(synthetic::SurfaceClass::kSky);
        const float d = frame.depth(x, y);
        non_sky += !sky;
        with_depth += !sky && d > 0.f;
        sky_with_depth += sky && d > 0.f;
        sum += frame.gray(x, y);
        sum_sq += frame.gray(x, y) * frame.gray(x, y);
      }
    }
    const double n = 416.0 * 128.0;
    const double stddev = std::sqrt(sum_sq / n - (sum / n) * (sum / n));
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_GT(non_sky, 0.6 * n);            // a street, not an empty sky
    EXPECT_GT(with_depth, 0.97 * non_sky);  // only the far ground exceeds 255 m
    EXPECT_EQ(sky_with_depth, 0);
    EXPECT_GT(stddev, 20.0);  // textured, not flat
    // The road is about camera_height below: depth of the bottom centre pixel.
    const double v = 127.0, z = frame.depth(208, 127);
    const PinholeCamera& cam = sequence.camera();
    EXPECT_NEAR(z * (v - cam.cy) / cam.fy, 1.65, 0.15);
  }
}

// Inverse warp of frame k into frame k+1 with k+1's ground-truth depth and the ground-truth
// relative pose. Returns the mean absolute grey error over the valid pixels and, over the same
// pixels, the error of the identity warp.
struct WarpResult {
  double warp_error = 0;
  double identity_error = 0;
  int valid = 0;
};

WarpResult WarpError(const SyntheticSequence& sequence, int k, double depth_scale = 1.0) {
  const SyntheticFrame source = sequence.RenderFrame(k, 2);
  const SyntheticFrame target = sequence.RenderFrame(k + 1, 2);
  const PinholeCamera& cam = sequence.camera();
  const SE3d source_from_target = source.world_from_cam.Inverse() * target.world_from_cam;
  WarpResult r;
  double warp = 0, identity = 0;
  for (int y = 2; y < cam.height - 2; ++y) {
    for (int x = 2; x < cam.width - 2; ++x) {
      const float d = target.depth(x, y);
      if (!(d > 0.f)) continue;
      // Not on a depth edge of the target: every 3x3 neighbour within 5% (the pixel's colour
      // mixes surfaces there while its depth is the centre's).
      bool edge = false;
      for (int j = -1; j <= 1 && !edge; ++j) {
        for (int i = -1; i <= 1 && !edge; ++i) {
          const float dn = target.depth(x + i, y + j);
          edge = !(dn > 0.f) || std::abs(dn - d) > 0.05f * d;
        }
      }
      if (edge) continue;
      const Eigen::Vector3d p_in_source =
          source_from_target * cam.Unproject(Eigen::Vector2d(x, y), depth_scale * d);
      if (p_in_source.z() < 0.5) continue;
      const Eigen::Vector2d uv = cam.Project(p_in_source);
      if (!cam.IsInImage(uv, 1.0)) continue;
      // Depth consistency: the point is what the source sees (not occluded there), at all four
      // pixels around it.
      const int x0 = static_cast<int>(std::floor(uv.x())),
                y0 = static_cast<int>(std::floor(uv.y()));
      bool visible = true;
      for (int j = 0; j <= 1; ++j) {
        for (int i = 0; i <= 1; ++i) {
          const float ds = source.depth(x0 + i, y0 + j);
          visible = visible && ds > 0.f &&
                    std::abs(depth_scale * ds - p_in_source.z()) < 0.05 * p_in_source.z();
        }
      }
      if (!visible) continue;
      const double predicted = source.gray.Bilinear(uv.x(), uv.y());
      warp += std::abs(predicted - target.gray(x, y));
      identity += std::abs(static_cast<double>(source.gray(x, y)) - target.gray(x, y));
      ++r.valid;
    }
  }
  r.warp_error = warp / std::max(1, r.valid);
  r.identity_error = identity / std::max(1, r.valid);
  return r;
}

// THE HONEST CHECK: ground-truth depth and poses must explain the images. If the renderer's
// geometry, the pose convention, the depth convention or the texture filtering (aliasing) were
// wrong, the warped frame would not reproduce the next one.
TEST(SyntheticSequenceTest, GroundTruthWarpReproducesNextFrame) {
  const SyntheticSequence sequence(ShortOptions(1, 500));
  // The frame with the fastest turn, plus straight-driving frames.
  int turn_frame = 0;
  double best = 0;
  for (int k = 0; k + 1 < sequence.num_frames(); ++k) {
    const double rate = std::abs(
        WrapAngle(Heading(sequence.WorldFromCam(k + 1)) - Heading(sequence.WorldFromCam(k))));
    if (rate > best) {
      best = rate;
      turn_frame = k;
    }
  }
  ASSERT_GT(best * 180.0 / kPi, 2.0);
  for (int k : {0, 150, turn_frame, 420}) {
    const WarpResult r = WarpError(sequence, k);
    SCOPED_TRACE("frame " + std::to_string(k));
    std::printf(
        "warp %d -> %d: %d valid pixels, warp error %.2f, identity error %.2f (ratio %.3f)\n", k,
        k + 1, r.valid, r.warp_error, r.identity_error, r.warp_error / r.identity_error);
    EXPECT_GT(r.valid, 416 * 128 / 3);
    EXPECT_LT(r.warp_error, 0.25 * r.identity_error);
    EXPECT_LT(r.warp_error, 4.0);  // grey levels out of 255
  }
  // Control: the same warp with a wrong depth scale must be clearly worse, so the check above
  // can fail.
  const WarpResult right = WarpError(sequence, turn_frame);
  const WarpResult wrong = WarpError(sequence, turn_frame, 0.8);
  EXPECT_GT(wrong.warp_error, 2.0 * right.warp_error);
}

}  // namespace
}  // namespace dfo
