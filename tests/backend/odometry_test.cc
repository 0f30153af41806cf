// dfo::Odometry, the system class, and the tracking depth built from the window
// (dfo_backend/tracking_depth.h): the depth that frames are tracked against after each window
// solve carries the window's scale, so a depth source whose maps each have their own scale (as a
// monocular network's) no longer makes the trajectory's scale swing.
#include "dfo_backend/odometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"

namespace dfo {
namespace {

// ---------------------------------------------------------------------------------------------
// BuildTrackingDepth / WindowToSourceScale on constructed data.

PinholeCamera Camera(int w, int h) {
  return PinholeCamera(w * 0.6, w * 0.6, w / 2.0, h / 2.0, w, h);
}

DepthPyramid ConstantPyramid(int w, int h, int levels, float depth) {
  DepthPyramid p;
  for (int l = 0; l < levels; ++l) p.levels.push_back(ImageF(w >> l, h >> l, 1, depth));
  return p;
}

std::vector<PinholeCamera> Cameras(int w, int h, int levels) {
  std::vector<PinholeCamera> c;
  for (int l = 0; l < levels; ++l) c.push_back(Camera(w, h).PyramidLevel(l));
  return c;
}

// Points at `depth` on a grid over the image of camera `c`.
std::vector<Eigen::Vector3d> GridPoints(const PinholeCamera& c, double depth, int step) {
  std::vector<Eigen::Vector3d> points;
  for (int y = 4; y < c.height - 4; y += step) {
    for (int x = 4; x < c.width - 4; x += step) {
      points.push_back(c.Unproject(Eigen::Vector2d(x, y), depth));
    }
  }
  return points;
}

TEST(TrackingDepth, WindowPointsSetTheScaleAndTheirPixels) {
  const int w = 64, h = 32, levels = 3;
  const DepthPyramid source = ConstantPyramid(w, h, levels, 5.0f);
  const std::vector<PinholeCamera> cameras = Cameras(w, h, levels);
  const std::vector<Eigen::Vector3d> points = GridPoints(cameras[0], 10.0, 8);
  TrackingDepthOptions options;
  options.min_window_points = 5;
  const TrackingDepth d = BuildTrackingDepth(source, cameras, points, options);
  ASSERT_TRUE(d.from_window) << d.note;
  EXPECT_EQ(d.num_points, static_cast<int>(points.size()));
  EXPECT_DOUBLE_EQ(d.scale, 2.0);  // window 10 m where the source says 5 m
  ASSERT_EQ(d.depth.num_levels(), levels);
  // Every valid pixel is at the window's scale: covered ones from the points, the rest filled
  // with the source times the scale.
  for (int l = 0; l < levels; ++l) {
    for (float v : d.depth.levels[l].vector()) EXPECT_FLOAT_EQ(v, 10.0f) << "level " << l;
  }
  // The points' 3 x 3 squares are marked covered at the finest level.
  int covered = 0;
  for (uint8_t c : d.covered) covered += c;
  EXPECT_EQ(covered, static_cast<int>(points.size()) * 9);
  EXPECT_DOUBLE_EQ(WindowToSourceScale(points, source.levels[0], cameras[0], 1), 2.0);
}

TEST(TrackingDepth, CoveredPixelsTakeTheWindowDepthAndFillNoneLeavesTheRestInvalid) {
  const int w = 64, h = 32, levels = 2;
  const DepthPyramid source = ConstantPyramid(w, h, levels, 4.0f);
  const std::vector<PinholeCamera> cameras = Cameras(w, h, levels);
  // Most points agree with the source at 2x; one point is far nearer.
  std::vector<Eigen::Vector3d> points = GridPoints(cameras[0], 8.0, 8);
  const Eigen::Vector3d near = cameras[0].Unproject(Eigen::Vector2d(30, 15), 1.0);
  points.push_back(near);
  TrackingDepthOptions options;
  options.min_window_points = 3;
  TrackingDepth d = BuildTrackingDepth(source, cameras, points, options);
  ASSERT_TRUE(d.from_window);
  EXPECT_DOUBLE_EQ(d.scale, 2.0);  // the median ignores the odd point
  EXPECT_FLOAT_EQ(d.depth.levels[0](30, 15), 1.0f);
  EXPECT_FLOAT_EQ(d.depth.levels[0](0, 0), 8.0f);  // filled: source x scale
  options.fill = "none";
  d = BuildTrackingDepth(source, cameras, points, options);
  ASSERT_TRUE(d.from_window);
  EXPECT_FLOAT_EQ(d.depth.levels[0](0, 0), 0.0f);  // no window point there
  EXPECT_FLOAT_EQ(d.depth.levels[0](4, 4), 8.0f);  // a grid point
}

TEST(TrackingDepth, TooFewPointsSaysWhy) {
  const DepthPyramid source = ConstantPyramid(32, 16, 1, 3.0f);
  const std::vector<PinholeCamera> cameras = Cameras(32, 16, 1);
  TrackingDepthOptions options;
  options.min_window_points = 50;
  const TrackingDepth d =
      BuildTrackingDepth(source, cameras, GridPoints(cameras[0], 3.0, 8), options);
  EXPECT_FALSE(d.from_window);
  EXPECT_NE(d.note.find("tracker.min_window_points"), std::string::npos) << d.note;
  // Points behind the camera or outside the image do not count.
  std::vector<Eigen::Vector3d> off = {Eigen::Vector3d(0, 0, -2), Eigen::Vector3d(100, 0, 1)};
  EXPECT_EQ(WindowToSourceScale(off, source.levels[0], cameras[0], 1), 0.0);
}

// ---------------------------------------------------------------------------------------------
// The system on synthetic frames.

// The default synthetic street (60 frames), rendered once, with its true poses.
struct Street {
  std::vector<Frame> frames;
  std::vector<SE3d> truth;
};

const Street& TheStreet() {
  static const Street* street = [] {
    SyntheticOptions o;
    o.num_frames = 60;
    const SyntheticSequence sequence(o);
    auto* out = new Street();
    for (int i = 0; i < o.num_frames; ++i) {
      SyntheticFrame f = sequence.RenderFrame(i, 2);
      Frame frame;
      frame.index = i;
      frame.timestamp_ns = f.timestamp_ns;
      frame.image = std::move(f.gray);
      frame.depth_m = std::move(f.depth);
      frame.camera = sequence.camera();
      out->frames.push_back(std::move(frame));
      out->truth.push_back(f.world_from_cam);
    }
    return out;
  }();
  return *street;
}

const std::vector<Frame>& Frames() { return TheStreet().frames; }
const std::vector<SE3d>& Truth() { return TheStreet().truth; }

// True depth times a factor per image drawn from a log-normal (sigma 0.2, seeded by the frame),
// as a monocular network gives each image its own scale.
class RandomScaleDepthSource : public DepthSource {
 public:
  std::string name() const override { return "gt"; }
  DepthPyramid Compute(const Frame& frame, int num_levels) override {
    DepthPyramid d = truth_.Compute(frame, num_levels);
    std::mt19937 rng(1000 + frame.index);
    std::normal_distribution<double> normal(0.0, 0.2);
    d.Scale(std::exp(normal(rng)));
    return d;
  }

 private:
  GroundTruthDepthSource truth_;
};

FrontendOptions External() {
  FrontendOptions o;
  o.reference.policy = "external";
  return o;
}

OdometryOptions Deterministic(OdometryMode mode) {
  OdometryOptions o;
  o.mode = mode;
  o.window.num_threads = 1;
  o.window.max_solver_time_s = 1e6;
  return o;
}

// Spread of the step-length ratio estimate / truth over the frames (coefficient of variation of
// |t_i - t_(i-1)| ratios, frames with a true step above 1 cm): 0 for a trajectory whose scale
// never changes, whatever its global scale.
double StepScaleSpread(const Trajectory& estimate) {
  std::vector<double> ratios;
  for (size_t i = 1; i < estimate.size(); ++i) {
    const double truth = (Truth()[i].translation() - Truth()[i - 1].translation()).norm();
    if (truth < 0.01) continue;
    ratios.push_back(
        (estimate[i].world_from_cam.translation() - estimate[i - 1].world_from_cam.translation())
            .norm() /
        truth);
  }
  double mean = 0.0, sq = 0.0;
  for (double r : ratios) mean += r;
  mean /= ratios.size();
  for (double r : ratios) sq += (r - mean) * (r - mean);
  return std::sqrt(sq / ratios.size()) / mean;
}

TEST(Odometry, ProcessesFramesOneAtATimeAndKeepsEveryPose) {
  Odometry odometry(External(), Deterministic(OdometryMode::kBoth));
  int keyframes = 0;
  for (int i = 0; i < 20; ++i) {
    const OdometryFrame out = odometry.Process(Frames()[i]);
    EXPECT_EQ(out.tracked.index, i);
    EXPECT_NE(out.tracked.status, TrackingStatus::kLost) << "frame " << i;
    EXPECT_TRUE(out.windowed_world_from_cam.translation().allFinite());
    keyframes += out.keyframe ? 1 : 0;
    if (i > 0) {
      EXPECT_FALSE(out.tracking_depth.empty()) << "frame " << i;
    }
  }
  EXPECT_EQ(odometry.poses().num_frames(), 20);
  EXPECT_EQ(odometry.WindowedTrajectory().size(), 20u);
  EXPECT_EQ(static_cast<int>(odometry.keyframes().size()), keyframes);
  EXPECT_GE(keyframes, 3);
  ASSERT_NE(odometry.window(), nullptr);
  // After the first solves the keyframes are tracked against the window.
  int window = 0;
  for (const KeyframeRecord& k : odometry.keyframes()) window += k.tracking_depth == "window";
  EXPECT_GE(window, keyframes - 2);
}

// A keyframe's reported pose follows the window's solves while it is one of the newest
// max_keyframes keyframes, then stays (odometry.h, "Reported poses"): rebuilt here from the
// solves' own results. The window's marginalisation rule keeps some keyframes longer on the
// street (far points stay in view), so the rule is exercised.
// The reporting rule replayed from the keyframe records: after each solve, a keyframe at most
// max_keyframes - 1 keyframes older than the solved one takes the window's pose; one that left the
// window then follows its neighbours in the window (odometry.h, "Reported poses").
TEST(Odometry, KeyframesAreReportedFromTheSolvesOfTheirFirstMaxKeyframesSteps) {
  OdometryOptions options = Deterministic(OdometryMode::kBoth);
  options.window.max_keyframes = 5;
  Odometry odometry(External(), options);
  for (int i = 0; i < 60; ++i) odometry.Process(Frames()[i]);
  const std::vector<KeyframeRecord>& records = odometry.keyframes();
  struct Follower {
    int index, older = -1, newer = -1;
    SE3d older_from_left, newer_from_left;
  };
  std::map<int, SE3d> reported;  // frame index -> reported windowed pose
  std::vector<Follower> followers;
  int outlived = 0, followed = 0;
  for (size_t r = 0; r < records.size(); ++r) {
    const WindowResult& w = records[r].window;
    if (!records[r].ba_ran || !w.optimized) continue;
    const auto young = [&](int index) {
      const int at = FindKeyframeRecord(records, index);
      return r - at < static_cast<size_t>(options.window.max_keyframes);
    };
    for (const auto& [index, pose] : w.keyframe_poses) {
      if (young(index)) {
        reported[index] = pose;
      } else {
        ++outlived;
      }
    }
    const int left = w.marginalized_frame_index;
    if (left >= 0 && young(left)) {
      reported[left] = w.marginalized_pose;
      Follower f{left};
      for (const auto& [index, pose] : w.keyframe_poses) {
        const SE3d rel = reported.at(index).Inverse() * w.marginalized_pose;
        if (index < left) {
          f.older = index;
          f.older_from_left = rel;
        } else if (f.newer < 0) {
          f.newer = index;
          f.newer_from_left = rel;
        }
      }
      followers.push_back(f);
    }
    std::vector<Follower> kept;
    for (const Follower& f : followers) {
      if (!young(f.index)) continue;
      kept.push_back(f);
      if (f.older < 0 && f.newer < 0) continue;
      const SE3d a = f.older >= 0 ? reported.at(f.older) * f.older_from_left
                                  : reported.at(f.newer) * f.newer_from_left;
      const SE3d b = f.newer >= 0 ? reported.at(f.newer) * f.newer_from_left : a;
      const double s =
          f.older >= 0 && f.newer >= 0 ? double(f.index - f.older) / (f.newer - f.older) : 0.0;
      const SE3d pose = a * SE3d::Exp(s * (a.Inverse() * b).Log());
      if ((pose.translation() - reported.at(f.index).translation()).norm() > 1e-9) ++followed;
      reported[f.index] = pose;
    }
    followers = kept;
  }
  for (const KeyframeRecord& record : records) {
    const int index = record.frame_index;
    ASSERT_EQ(reported.count(index), 1u) << "keyframe " << index;
    const SE3d got = odometry.poses().WindowedPose(index);
    EXPECT_LT((got.translation() - reported[index].translation()).norm(), 1e-12) << index;
    EXPECT_LT(got.quaternion().angularDistance(reported[index].quaternion()), 1e-12) << index;
  }
  EXPECT_GE(outlived, 1) << "no keyframe stayed in the window beyond max_keyframes steps";
  EXPECT_GE(followed, 1) << "no keyframe left the window early and then moved with it";
}

// Keyframe rules that keep the first keyframe until tracking against it fails.
OdometryOptions KeepTheFirstKeyframe() {
  OdometryOptions options = Deterministic(OdometryMode::kBoth);
  options.keyframe.translation_ratio = 100.0;
  options.keyframe.rotation_deg = 180.0;
  options.keyframe.residual_ratio = 100.0;
  options.keyframe.min_inlier_ratio = 0.0;
  options.keyframe.max_interval = 1000;
  return options;
}

// With those rules and every second frame, tracking against frame 0 fails: the lost frame is
// re-tracked against the previous frame, which the Odometry makes a keyframe (reason retrack)
// before booking the frame against it. Nothing is lost.
TEST(Odometry, AFrameLostAgainstTheKeyframeMakesThePreviousFrameAKeyframe) {
  OdometryOptions options = KeepTheFirstKeyframe();
  Odometry odometry(External(), options);
  int promoted = -1, previous = -1, retracked = -1;
  SE3d retracked_kf_from_cam;
  for (int i = 0; i < 60 && promoted < 0; i += 2) {
    const OdometryFrame out = odometry.Process(Frames()[i]);
    EXPECT_NE(out.tracked.status, TrackingStatus::kLost) << "frame " << i;
    if (out.promoted_keyframe >= 0) {
      promoted = out.promoted_keyframe;
      EXPECT_EQ(promoted, previous);
      EXPECT_EQ(out.tracked.retracked_from, 0);
      EXPECT_FALSE(out.keyframe);
      EXPECT_EQ(out.pose_keyframe_index, promoted);  // booked against the new keyframe
      EXPECT_EQ(out.solved_keyframe, promoted);      // which went through the window
      retracked = i;
      retracked_kf_from_cam = out.kf_from_cam;
    }
    previous = i;
  }
  ASSERT_GE(promoted, 0) << "tracking against frame 0 never failed";
  ASSERT_EQ(odometry.keyframes().size(), 2u);
  EXPECT_EQ(odometry.keyframes()[1].frame_index, promoted);
  EXPECT_EQ(odometry.keyframes()[1].reason, KeyframeReason::kRetrack);
  EXPECT_TRUE(odometry.keyframes()[1].ba_ran);
  EXPECT_TRUE(odometry.poses().IsKeyframe(promoted));
  // The re-tracked frame's pose relative to its new keyframe is the true one (true depth).
  const SE3d truth = Truth()[promoted].Inverse() * Truth()[retracked];
  const SE3d error = truth.Inverse() * retracked_kf_from_cam;
  EXPECT_LT(error.translation().norm(), 0.02) << "true step " << truth.translation().norm();
  EXPECT_LT(error.so3().Angle() * 180.0 / M_PI, 0.1);
}

// A re-track keyframe (the frame before the newest one) gets the keyframe stereo against the
// frames before it, as every other keyframe does: the frames tracked against it use its depth.
TEST(Odometry, ARetrackKeyframeGetsTheKeyframeStereo) {
  OdometryOptions options = KeepTheFirstKeyframe();
  options.stereo.views = 3;
  Odometry odometry(External(), options);
  int promoted = -1;
  for (int i = 0; i < 60 && promoted < 0; i += 2) {
    promoted = odometry.Process(Frames()[i]).promoted_keyframe;
  }
  ASSERT_GE(promoted, 0) << "tracking against frame 0 never failed";
  ASSERT_EQ(odometry.keyframes().size(), 2u);
  const KeyframeRecord& kf = odometry.keyframes()[1];
  ASSERT_EQ(kf.reason, KeyframeReason::kRetrack);
  ASSERT_GT(kf.window_scale, 0.0);
  EXPECT_EQ(kf.stereo.num_views, 3) << "keyframe " << promoted;
  EXPECT_GT(kf.stereo.num_replaced, 0) << "keyframe " << promoted;
}

TEST(Odometry, BadInputThrowsAndBooksNothing) {
  Odometry odometry(External(), Deterministic(OdometryMode::kBoth));
  odometry.Process(Frames()[0]);
  Frame broken = Frames()[1];
  broken.depth_m = ImageF(7, 5, 1, 1.0f);  // wrong size
  EXPECT_THROW(odometry.Process(broken), InputError);
  EXPECT_EQ(odometry.poses().num_frames(), 1);
  EXPECT_NO_THROW(odometry.Process(Frames()[1]));
  EXPECT_EQ(odometry.poses().num_frames(), 2);
}

TEST(Odometry, OptionsAreChecked) {
  OdometryOptions bad = Deterministic(OdometryMode::kBoth);
  bad.tracking.depth = "network";
  EXPECT_THROW(Odometry(External(), bad), ConfigError);
  bad = Deterministic(OdometryMode::kBoth);
  bad.window.pyramid_level = 4;  // the tracker has 4 levels: 0..3
  EXPECT_THROW(Odometry(External(), bad), ConfigError);
  // No window in mode frontend: its options are not even looked at.
  bad.mode = OdometryMode::kFrontend;
  Odometry frontend_only(External(), bad);
  EXPECT_EQ(frontend_only.window(), nullptr);
}

// The window on its own thread: every keyframe's solve is applied (on a later frame or at Flush),
// once each, and the trajectory is as good as the sequential one's up to timing.
TEST(Odometry, BackendThreadAppliesEverySolve) {
  double spread[2] = {0, 0};
  for (int threaded = 0; threaded < 2; ++threaded) {
    OdometryOptions o = Deterministic(OdometryMode::kBoth);
    o.backend_thread = threaded == 1;
    Odometry odometry(External(), o, nullptr, std::make_unique<RandomScaleDepthSource>());
    std::vector<int> solved;
    for (const Frame& f : Frames()) {
      const OdometryFrame out = odometry.Process(f);
      if (out.solved_keyframe >= 0) solved.push_back(out.solved_keyframe);
      if (!threaded && out.keyframe) {
        EXPECT_EQ(out.solved_keyframe, out.tracked.index);
      }
    }
    const int last = odometry.Flush();
    if (last >= 0) solved.push_back(last);
    EXPECT_EQ(odometry.Flush(), -1);  // nothing left
    ASSERT_EQ(solved.size(), odometry.keyframes().size());
    for (size_t i = 0; i < solved.size(); ++i) {
      EXPECT_EQ(solved[i], odometry.keyframes()[i].frame_index);
      EXPECT_TRUE(odometry.keyframes()[i].ba_ran);
    }
    const Trajectory windowed = odometry.WindowedTrajectory();
    ASSERT_EQ(windowed.size(), Frames().size());
    for (size_t i = 0; i < windowed.size(); ++i) {
      EXPECT_TRUE(windowed[i].world_from_cam.translation().allFinite()) << "frame " << i;
    }
    spread[threaded] = StepScaleSpread(windowed);
  }
  std::printf("[ figures  ] step-length ratio spread: sequential %.3f, backend thread %.3f\n",
              spread[0], spread[1]);
  // The threaded run tracks a few frames per keyframe against the scaled source depth; the scale
  // still holds (against 0.275 when tracking against the source alone).
  EXPECT_LT(spread[1], 0.1);
}

// Hand-made features that count the frames they were computed for, so that a solve can wait for
// the frontend to start the next frame.
class FrameCountingFeatures : public FeatureSource {
 public:
  std::string name() const override { return "handmade"; }
  FeaturePyramid Compute(const Frame& frame, int num_levels) override {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++count_;
    }
    changed_.notify_all();
    return handmade_.Compute(frame, num_levels);
  }
  int count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return count_;
  }
  // Until `count` frames were started or Finish was called.
  void WaitFor(int count) {
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return count_ >= count || finished_; });
  }
  // No more frames: releases every wait.
  void Finish() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      finished_ = true;
    }
    changed_.notify_all();
  }

 private:
  HandmadeFeatureSource handmade_;
  std::mutex mutex_;
  std::condition_variable changed_;
  int count_ = 0;
  bool finished_ = false;
};

// With the tracker on each keyframe's source depth (and the keyframe stereo, which reads the
// windowed poses of the frames before a keyframe) the backend thread gives the sequential run's
// trajectories, keyframes and step scales bit for bit. Each solve waits until the frontend has
// started the next frame, so that frames are tracked and booked before their keyframe's solve is
// applied (the step scale must reach them too).
TEST(Odometry, BackendThreadWithSourceDepthGivesTheSequentialResults) {
  Trajectory windowed[2], frontend[2];
  std::vector<double> step_scales[2];
  int booked_before_solve = 0;
  for (int threaded = 0; threaded < 2; ++threaded) {
    OdometryOptions o = Deterministic(OdometryMode::kBoth);
    o.tracking.depth = "source";
    o.stereo.views = 3;
    o.backend_thread = threaded == 1;
    auto features = std::make_unique<FrameCountingFeatures>();
    FrameCountingFeatures* counter = features.get();
    if (threaded) {
      // The frame count at the hand-over (on the frame thread; the next hand-over waits for this
      // solve), then the solve waits for one more frame.
      auto submitted = std::make_shared<int>(0);
      o.keyframe_filter = [counter, submitted](KeyframeData*) { *submitted = counter->count(); };
      o.before_solve = [counter, submitted](int) { counter->WaitFor(*submitted + 1); };
    }
    Odometry odometry(External(), o, std::move(features),
                      std::make_unique<RandomScaleDepthSource>());
    int pending = -1;
    for (const Frame& f : Frames()) {
      const OdometryFrame out = odometry.Process(f);
      if (out.solved_keyframe >= 0 && out.solved_keyframe == pending) pending = -1;
      if (pending >= 0 && !out.keyframe) ++booked_before_solve;
      if (out.keyframe && out.solved_keyframe != out.tracked.index) pending = out.tracked.index;
    }
    counter->Finish();  // a keyframe on the last frame: its solve waits for no further frame
    odometry.Flush();
    windowed[threaded] = odometry.WindowedTrajectory();
    frontend[threaded] = odometry.FrontendTrajectory();
    for (const KeyframeRecord& kf : odometry.keyframes()) {
      step_scales[threaded].push_back(kf.step_scale);
      EXPECT_TRUE(kf.ba_ran);
    }
  }
  std::printf("[ figures  ] frames booked before their keyframe's solve was applied: %d\n",
              booked_before_solve);
  EXPECT_GT(booked_before_solve, 0);
  EXPECT_EQ(step_scales[1], step_scales[0]);
  ASSERT_EQ(windowed[1].size(), windowed[0].size());
  for (size_t i = 0; i < windowed[0].size(); ++i) {
    EXPECT_EQ(windowed[1][i].world_from_cam.Matrix(), windowed[0][i].world_from_cam.Matrix())
        << "frame " << i;
    EXPECT_EQ(frontend[1][i].world_from_cam.Matrix(), frontend[0][i].world_from_cam.Matrix())
        << "frame " << i;
  }
}

// The capability: with a depth source whose every map has its own scale, tracking against the
// window keeps the trajectory's scale where tracking against the source does not. The steps of
// source-tracked frames are left as tracked, so that the comparison is of the tracking alone
// (rescaling them is RescaledSourceStepsFollowTheWindowsScale).
TEST(Odometry, TrackingAgainstTheWindowKeepsTheScaleOfAMonocularDepthSource) {
  double spread[2] = {0, 0};
  const char* depth[2] = {"source", "window"};
  for (int k = 0; k < 2; ++k) {
    OdometryOptions o = Deterministic(OdometryMode::kBoth);
    o.tracking.depth = depth[k];  // the rest as by default
    o.tracking.rescale_source_steps = false;
    Odometry odometry(External(), o, nullptr, std::make_unique<RandomScaleDepthSource>());
    for (const Frame& f : Frames()) odometry.Process(f);
    spread[k] = StepScaleSpread(odometry.WindowedTrajectory());
  }
  std::printf(
      "[ figures  ] step-length ratio spread: tracking against the source %.3f, against "
      "the window %.3f (60 frames, depth scale per image log-normal sigma 0.2)\n",
      spread[0], spread[1]);
  EXPECT_LT(spread[1], 0.5 * spread[0]);
}

// Tracking against the source with a depth source whose every map has its own scale: the frames
// between keyframes are tracked at their keyframe's source scale, the keyframes' windowed poses at
// the window's. Rescaling the frames' steps to the window's scale (the default) removes the
// zigzag this gives the windowed trajectory; the frontend-only one does not change.
TEST(Odometry, RescaledSourceStepsFollowTheWindowsScale) {
  double spread[2] = {0, 0};
  Trajectory frontend[2];
  for (int on = 0; on < 2; ++on) {
    OdometryOptions o = Deterministic(OdometryMode::kBoth);
    o.tracking.depth = "source";
    o.tracking.rescale_source_steps = on == 1;
    Odometry odometry(External(), o, nullptr, std::make_unique<RandomScaleDepthSource>());
    for (const Frame& f : Frames()) odometry.Process(f);
    spread[on] = StepScaleSpread(odometry.WindowedTrajectory());
    frontend[on] = odometry.FrontendTrajectory();
    int scaled = 0;
    for (const KeyframeRecord& kf : odometry.keyframes()) {
      if (on == 0) {
        EXPECT_EQ(kf.step_scale, 0.0) << "keyframe " << kf.frame_index;
      }
      scaled += kf.step_scale > 0.0 ? 1 : 0;
    }
    if (on == 1) {
      EXPECT_GE(scaled, static_cast<int>(odometry.keyframes().size()) - 1);
    }
  }
  std::printf(
      "[ figures  ] windowed step-length ratio spread, tracking against the source: steps as "
      "tracked %.3f, rescaled to the window's scale %.3f\n",
      spread[0], spread[1]);
  EXPECT_LT(spread[1], 0.7 * spread[0]);
  ASSERT_EQ(frontend[0].size(), frontend[1].size());
  for (size_t i = 0; i < frontend[0].size(); ++i) {
    EXPECT_EQ(frontend[0][i].world_from_cam.translation(),
              frontend[1][i].world_from_cam.translation())
        << "frame " << i;
  }
}

// window.source_scale: with run_median each keyframe's depth map enters the window at the median
// of the window-to-source ratios of the keyframes so far (itself included); with window at its
// own ratio; with raw at 1.
TEST(Odometry, RunMedianSourceScaleIsTheMedianOfTheWindowScalesSoFar) {
  for (const std::string mode : {"raw", "run_median", "window"}) {
    OdometryOptions o = Deterministic(OdometryMode::kBoth);
    o.tracking.depth = "source";
    o.tracking.source_scale = mode;
    Odometry odometry(External(), o, nullptr, std::make_unique<RandomScaleDepthSource>());
    for (const Frame& f : Frames()) odometry.Process(f);
    std::vector<double> scales;
    int checked = 0;
    for (const KeyframeRecord& kf : odometry.keyframes()) {
      if (kf.window_scale > 0.0) scales.push_back(kf.window_scale);
      double expected = 1.0;
      if (mode == "run_median" && kf.window_scale > 0.0) {
        std::vector<double> sorted = scales;
        std::sort(sorted.begin(), sorted.end());
        expected = sorted[sorted.size() / 2];
        ++checked;
      }
      if (mode == "window" && kf.window_scale > 0.0) expected = kf.window_scale;
      EXPECT_EQ(kf.source_scale, expected) << mode << ", keyframe " << kf.frame_index;
      EXPECT_EQ(kf.initial_depth_scale, expected) << mode << ", keyframe " << kf.frame_index;
    }
    if (mode == "run_median") {
      EXPECT_GE(checked, 5);
      // The random per-image scales make the ratios differ: the median is not just the last one.
      EXPECT_NE(odometry.keyframes().back().source_scale, odometry.keyframes().back().window_scale);
    }
  }
  OdometryOptions bad = Deterministic(OdometryMode::kBoth);
  bad.tracking.source_scale = "median";
  EXPECT_THROW(Odometry(External(), bad), ConfigError);
}

// The capability of window.source_scale "window": with a depth source whose every map has its
// own scale, tracked against each keyframe's source depth with the steps rescaled to the window's
// scale, the windowed trajectory keeps one scale (the window's, carried by the points that
// keyframes share) where the frontend-only one takes each keyframe's; with "raw" a depth prior
// (weight 2 here) pulls each keyframe's points toward its own map's scale.
TEST(Odometry, CarriedSourceScaleKeepsTheWindowsScaleAgainstPerImageScales) {
  double windowed[2] = {0, 0};
  double frontend = 0.0;
  const char* modes[2] = {"raw", "window"};
  for (int k = 0; k < 2; ++k) {
    OdometryOptions o = Deterministic(OdometryMode::kBoth);
    o.tracking.depth = "source";
    o.tracking.source_scale = modes[k];
    o.window.depth_prior_weight = 2.0;
    Odometry odometry(External(), o, nullptr, std::make_unique<RandomScaleDepthSource>());
    for (const Frame& f : Frames()) odometry.Process(f);
    windowed[k] = StepScaleSpread(odometry.WindowedTrajectory());
    frontend = StepScaleSpread(odometry.FrontendTrajectory());
  }
  std::printf(
      "[ figures  ] step-length ratio spread (60 frames, depth scale per image log-normal sigma "
      "0.2): frontend-only %.3f, windowed with source_scale raw %.3f, window %.3f\n",
      frontend, windowed[0], windowed[1]);
  EXPECT_LT(windowed[1], 0.5 * frontend);
  EXPECT_LE(windowed[1], windowed[0]);
}

// Tracking against the window with the steps rescaled (both defaults): the frames after a keyframe
// tracked against the window's own depth are in the window's scale already, so such a keyframe
// carries no step factor; only one whose frames fell back to the source's depth does.
TEST(Odometry, KeyframesTrackedAgainstTheWindowHaveNoStepFactor) {
  OdometryOptions o = Deterministic(OdometryMode::kBoth);
  o.tracking.depth = "window";
  o.tracking.rescale_source_steps = true;
  Odometry odometry(External(), o, nullptr, std::make_unique<RandomScaleDepthSource>());
  for (const Frame& f : Frames()) odometry.Process(f);
  int window = 0;
  for (const KeyframeRecord& kf : odometry.keyframes()) {
    if (kf.tracking_depth == "window") {
      ++window;
      EXPECT_EQ(kf.step_scale, 0.0) << "keyframe " << kf.frame_index;
    }
  }
  EXPECT_GT(window, 0);
}

}  // namespace
}  // namespace dfo
