// The sliding window inside the sequence runner: both trajectories from one frontend pass,
// keyframes driven by the keyframe manager, a failing bundle adjustment that must not stop the
// run, byte-identical deterministic output, bounded window state over a long run.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "apps/common/sequence_runner.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

// The default synthetic street, rendered once into memory.
class CachedProvider : public apps::FrameProvider {
 public:
  explicit CachedProvider(int frames) {
    SyntheticOptions o;
    o.num_frames = frames;
    const SyntheticSequence sequence(o);
    for (int i = 0; i < frames; ++i) {
      const SyntheticFrame f = sequence.RenderFrame(i, 2);
      io::LoadedFrame loaded;
      loaded.index = i;
      loaded.timestamp_ns = f.timestamp_ns;
      loaded.image = f.gray;
      loaded.depth_m = f.depth;
      loaded.camera = sequence.camera();
      loaded.world_from_cam = f.world_from_cam;
      frames_.push_back(loaded);
    }
  }
  std::string name() const override { return "cached synthetic"; }
  size_t size() const override { return frames_.size(); }
  io::LoadedFrame Load(size_t i) const override { return frames_[i]; }

 private:
  std::vector<io::LoadedFrame> frames_;
};

const CachedProvider& Provider() {
  static const CachedProvider* provider = new CachedProvider(40);
  return *provider;
}

apps::SequenceRunOptions Quiet() {
  apps::SequenceRunOptions o;
  o.progress_stream = nullptr;
  o.log_stream = nullptr;
  return o;
}

OdometryOptions BothOptions() {
  OdometryOptions o;
  o.mode = apps::RunMode::kBoth;
  // Deterministic (as run.deterministic): one thread, no wall-clock limit on a solve.
  o.window.num_threads = 1;
  o.window.max_solver_time_s = apps::kDeterministicSolverTimeS;
  o.window.points_per_keyframe = 150;
  return o;
}

FrontendOptions ExternalFrontend() {
  FrontendOptions o;
  o.reference.policy = "external";
  return o;
}

bool Finite(const SE3d& p) {
  return p.translation().allFinite() && p.quaternion().coeffs().allFinite();
}

std::string ReadFile(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST(WindowedRun, BothTrajectoriesFromOneFrontendPass) {
  Odometry odometry(ExternalFrontend(), BothOptions());
  const apps::SequenceRunResult r = apps::RunSequence(Provider(), &odometry, Quiet());
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.frames.size(), Provider().size());
  EXPECT_EQ(r.poses.num_frames(), static_cast<int>(r.frames.size()));
  ASSERT_GE(r.keyframes.size(), 3u);
  EXPECT_EQ(r.poses.num_keyframes(), static_cast<int>(r.keyframes.size()));
  EXPECT_EQ(r.keyframes.front().reason, KeyframeReason::kRestart);
  const Trajectory frontend_only = r.Estimate(), windowed = r.WindowedEstimate();
  ASSERT_EQ(frontend_only.size(), r.frames.size());
  ASSERT_EQ(windowed.size(), r.frames.size());
  for (size_t i = 0; i < r.frames.size(); ++i) {
    const apps::FrameRecord& f = r.frames[i];
    // The frontend-only trajectory is the frontend's own estimate (relative poses composed on
    // the frontend's keyframe poses give it back up to rounding).
    EXPECT_TRUE(
        frontend_only[i].world_from_cam.Matrix().isApprox(f.tracked.world_from_cam.Matrix(), 1e-9))
        << "frame " << i;
    EXPECT_TRUE(Finite(windowed[i].world_from_cam)) << "frame " << i;
  }
  // Tracking against the newest keyframe: each frame's reference is the last keyframe before it.
  int newest = -1;
  for (const apps::FrameRecord& f : r.frames) {
    if (f.tracked.status != TrackingStatus::kReference) {
      EXPECT_EQ(f.tracked.reference_index, newest) << "frame " << f.tracked.index;
    }
    if (f.keyframe) newest = f.tracked.index;
  }
  int ba_ran = 0;
  for (const apps::KeyframeRecord& k : r.keyframes) ba_ran += k.ba_ran ? 1 : 0;
  EXPECT_EQ(ba_ran, static_cast<int>(r.keyframes.size()));

  const std::string out = test::MakeTempDir("windowed_run_files");
  const apps::RunOutputs o = apps::WriteRunOutputs(r, out, /*plot=*/true);
  for (const char* name :
       {"frontend_kitti.txt", "frontend_tum.txt", "windowed_kitti.txt", "windowed_tum.txt",
        "keyframes_tum.txt", "frames.csv", "summary.json", "comparison_trajectory.png",
        "scale_along_the_run.png"}) {
    EXPECT_FALSE(ReadFile(out + "/" + name).empty()) << name;
  }
  const io::JsonValue& s = o.summary;
  EXPECT_EQ(s["mode"].AsString(), "both");
  ASSERT_FALSE(s["frontend"].IsNull());
  ASSERT_FALSE(s["windowed"].IsNull());
  for (const auto& [key, value] : s["frontend"].members()) {
    EXPECT_TRUE(s["windowed"].Has(key)) << key;
  }
  EXPECT_EQ(s["keyframes"]["count"].AsInt(), static_cast<int64_t>(r.keyframes.size()));
  EXPECT_FALSE(s["timing_ms"]["backend_per_keyframe"].IsNull());
}

TEST(WindowedRun, FrontendModeWritesNoWindowedFiles) {
  OdometryOptions o = BothOptions();
  o.mode = apps::RunMode::kFrontend;
  Odometry odometry(ExternalFrontend(), o);
  const apps::SequenceRunResult r = apps::RunSequence(Provider(), &odometry, Quiet());
  ASSERT_TRUE(r.error.empty()) << r.error;
  for (const apps::KeyframeRecord& k : r.keyframes) EXPECT_FALSE(k.ba_ran);
  const std::string out = test::MakeTempDir("windowed_run_frontend_mode");
  const apps::RunOutputs outputs = apps::WriteRunOutputs(r, out, /*plot=*/false);
  EXPECT_FALSE(ReadFile(out + "/frontend_kitti.txt").empty());
  EXPECT_TRUE(ReadFile(out + "/windowed_kitti.txt").empty());
  EXPECT_FALSE(outputs.summary.Has("windowed"));
}

// Injected NaN depth and NaN features in some keyframes: a bundle adjustment that fails or
// diverges keeps the previous window state, the run logs why and goes on to the last frame with
// finite poses everywhere.
TEST(WindowedRun, NanKeyframeDataDoesNotStopTheRun) {
  OdometryOptions o = BothOptions();
  apps::SequenceRunOptions run = Quiet();
  const std::string log_path = test::MakeTempDir("windowed_run_nan") + "/log.txt";
  std::FILE* log = std::fopen(log_path.c_str(), "w");
  ASSERT_NE(log, nullptr);
  run.log_stream = log;
  int count = 0;
  o.keyframe_filter = [&count](KeyframeData* kf) {
    ++count;
    if (count % 3 != 0) return;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (ImageF& level : kf->depth.levels) {
      for (int y = 0; y < level.height(); y += 2) {
        for (int x = 0; x < level.width(); ++x) level(x, y) = nan;
      }
    }
    for (FeatureLevel& level : kf->features.levels) {
      for (size_t i = 0; i < level.data.size(); i += 7) level.data[i] = nan;
    }
  };
  Odometry odometry(ExternalFrontend(), o);
  const apps::SequenceRunResult r = apps::RunSequence(Provider(), &odometry, run);
  std::fclose(log);
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_EQ(r.frames.size(), Provider().size());
  EXPECT_GE(count, 3);
  const Trajectory windowed = r.WindowedEstimate();
  for (size_t i = 0; i < windowed.size(); ++i) {
    EXPECT_TRUE(Finite(windowed[i].world_from_cam)) << "frame " << i;
  }
  // Every solve that was not kept (after the first keyframe) has its log line.
  int failed = 0;
  for (const apps::KeyframeRecord& k : r.keyframes) {
    failed += !k.window.optimized && k.window.keyframe_poses.size() >= 2 ? 1 : 0;
  }
  const std::string text = ReadFile(log_path);
  int lines = 0;
  for (size_t p = text.find("kept the previous window state"); p != std::string::npos;
       p = text.find("kept the previous window state", p + 1)) {
    ++lines;
  }
  EXPECT_EQ(lines, failed) << text;
  // frames.csv says which keyframes kept the previous state, and the other solves' outcome.
  int kept_previous = 0, solved = 0;
  for (const apps::FrameRecord& f : r.frames) {
    const std::string line = apps::FramesCsvLine(f);
    EXPECT_EQ(line.substr(line.rfind(',') + 1), f.keyframe_solve + "\n");
    if (!f.keyframe) {
      EXPECT_EQ(f.keyframe_solve, "") << "frame " << f.tracked.index;
      continue;
    }
    kept_previous += f.keyframe_solve == "kept_previous" ? 1 : 0;
    solved += f.keyframe_solve == "converged" || f.keyframe_solve == "iteration_limit" ||
                      f.keyframe_solve == "time_limit"
                  ? 1
                  : 0;
  }
  EXPECT_EQ(kept_previous, failed);
  EXPECT_GE(solved, 1);
  // The keyframes with NaN features are refused by the window and the log says so.
  EXPECT_GE(failed, 1);
  EXPECT_NE(text.find("feature values at pyramid level"), std::string::npos) << text;
  std::printf("[ figures  ] %d of %zu keyframes got NaN data; %d solves not kept\n", count / 3,
              r.keyframes.size(), failed);
}

// run.deterministic: one Ceres thread; two runs IN ONE PROCESS give byte-identical trajectory
// files. (This used to fail: the window's Ceres ParameterBlockOrdering orders blocks by address,
// and the blocks lived in heap objects; the window now solves on contiguous copies laid out in
// insertion order, so the order no longer depends on the allocator's history.)
TEST(WindowedRun, DeterministicRunsInOneProcessAreByteIdentical) {
  std::string files[2][3];
  for (int run = 0; run < 2; ++run) {
    Odometry odometry(ExternalFrontend(), BothOptions());
    const apps::SequenceRunResult r = apps::RunSequence(Provider(), &odometry, Quiet());
    ASSERT_TRUE(r.error.empty()) << r.error;
    const std::string out = test::MakeTempDir("windowed_run_det_" + std::to_string(run));
    apps::WriteRunOutputs(r, out, /*plot=*/false);
    files[run][0] = ReadFile(out + "/windowed_kitti.txt");
    files[run][1] = ReadFile(out + "/frontend_kitti.txt");
    files[run][2] = ReadFile(out + "/keyframes_tum.txt");
  }
  for (int k = 0; k < 3; ++k) {
    EXPECT_FALSE(files[0][k].empty());
    EXPECT_EQ(files[0][k], files[1][k]) << "file " << k;
  }
}

// Bounded memory: over a long run the window's live keyframes, points and residual blocks stay
// under bounds set by the options alone (max_keyframes + 1 keyframes during a step, each hosting
// at most points_per_keyframe points with at most one block per other keyframe), and the store
// grows by one small entry per frame only.
TEST(WindowedRun, WindowStateIsBoundedOverALongRun) {
  static const CachedProvider* long_provider = new CachedProvider(150);
  OdometryOptions o = BothOptions();
  o.window.max_keyframes = 5;
  o.window.points_per_keyframe = 60;
  o.window.max_iterations = 3;
  Odometry odometry(ExternalFrontend(), o);
  const apps::SequenceRunResult r = apps::RunSequence(*long_provider, &odometry, Quiet());
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_GE(r.keyframes.size(), 20u);  // several times the window
  const int max_kf = o.window.max_keyframes + 1;
  const int max_points = max_kf * o.window.points_per_keyframe;
  int peak_kf = 0, peak_points = 0, peak_blocks = 0, marginalized = 0;
  for (const apps::KeyframeRecord& k : r.keyframes) {
    const WindowResult& w = k.window;
    EXPECT_LE(static_cast<int>(w.keyframe_poses.size()), max_kf) << "keyframe " << k.frame_index;
    EXPECT_LE(w.num_points, max_points) << "keyframe " << k.frame_index;
    EXPECT_LE(w.num_residual_blocks, w.num_points * (max_kf - 1)) << "keyframe " << k.frame_index;
    peak_kf = std::max(peak_kf, static_cast<int>(w.keyframe_poses.size()));
    peak_points = std::max(peak_points, w.num_points);
    peak_blocks = std::max(peak_blocks, w.num_residual_blocks);
    marginalized += w.marginalized_frame_index >= 0 ? 1 : 0;
  }
  EXPECT_GE(marginalized, static_cast<int>(r.keyframes.size()) - max_kf);
  EXPECT_EQ(r.poses.num_frames(), static_cast<int>(r.frames.size()));
  std::printf(
      "[ figures  ] %zu frames, %zu keyframes, %d marginalised; window peaks: %d keyframes, "
      "%d points, %d residual blocks\n",
      r.frames.size(), r.keyframes.size(), marginalized, peak_kf, peak_points, peak_blocks);
}

}  // namespace
}  // namespace dfo
