// Runs the real dfo_run executable (DFO_RUN_EXE) on tiny synthetic sequences written by dfo_synth
// (DFO_SYNTH_EXE) into temporary folders, some broken on purpose, and checks the files it writes,
// its exit status and its error lines. The runner library (apps/common/sequence_runner.h) is also
// driven in-process with frames made in memory (NaN depth, a source that fails half-way).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "apps/common/sequence_runner.h"
#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"
#include "dfo_io/image_io.h"
#include "dfo_io/json.h"
#include "dfo_io/keyframe_depth_io.h"
#include "dfo_io/trajectory_io.h"
#include "tests/support/measured_figures.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;

constexpr int kFrames = 10;

using test::CommandResult;
using test::ReadFile;
using test::RunCommand;

CommandResult RunDfoRun(const std::string& args) { return RunCommand(DFO_RUN_EXE, args); }

size_t CountLines(const std::string& text) {
  size_t n = 0;
  for (const char c : text) n += c == '\n' ? 1 : 0;
  return n;
}

// Exactly one line on stderr containing every fragment, non-zero exit.
void ExpectOneLineError(const CommandResult& r, const std::vector<std::string>& fragments) {
  EXPECT_NE(r.status, 0);
  ASSERT_FALSE(r.err.empty()) << "stdout: " << r.out;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "more than one line: " << r.err;
  for (const std::string& f : fragments) {
    EXPECT_NE(r.err.find(f), std::string::npos) << r.err << "\n  missing: " << f;
  }
}

// A fresh copy of a kFrames-frame synthetic sequence (KITTI layout, ground-truth depth and poses)
// in its own temporary folder; rendered by dfo_synth once per test process.
std::string MakeSequence(const std::string& tag) {
  return test::CopyOfSyntheticSequence(DFO_SYNTH_EXE, kFrames, tag);
}

std::string FramePng(const std::string& root, const std::string& folder, int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.png", index);
  return root + "/sequences/00/" + folder + "/" + name;
}

// dfo_run arguments for the sequence at `root` writing into `out`.
std::string RunArgs(const std::string& root, const std::string& out) {
  return "--config " + test::SourceDir() + "/configs/demo.yaml --set dataset.path=" + root +
         " --output " + out + " --set run.progress=plain";
}

io::JsonValue ReadSummary(const std::string& out) {
  return io::ParseJson(ReadFile(out + "/summary.json"), out + "/summary.json");
}

TEST(DfoRun, HelpExitsZero) {
  const CommandResult r = RunDfoRun("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("usage: dfo_run --config FILE.yaml"), std::string::npos) << r.out;
  EXPECT_TRUE(r.err.empty()) << r.err;
}

TEST(DfoRun, CommandLineMistakesAreOneLine) {
  const CommandResult unknown = RunDfoRun("--bogus 3");
  ExpectOneLineError(unknown, {"unknown argument '--bogus'"});
  EXPECT_EQ(unknown.status, 2);
  ExpectOneLineError(RunDfoRun("--config"), {"--config needs a value"});
  ExpectOneLineError(RunDfoRun(""), {"dataset.path is empty"});
}

// Frames of random noise with true depth: whatever the tracker makes of them (with the demo's
// settings they are lost), no evaluation reports an ATE that looks like one of a motion: there is
// none (with the reason), or it is flagged as degenerate (stderr and summary.json).
TEST(DfoRun, ANoiseRunsDegenerateAlignmentIsFlagged) {
  constexpr int kNoiseFrames = 40;
  const std::string root =
      test::CopyOfSyntheticSequence(DFO_SYNTH_EXE, kNoiseFrames, "dfo_run_noise");
  const std::string out = test::MakeTempDir("dfo_run_noise_out") + "/run";
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> grey(0, 255);
  for (int i = 0; i < kNoiseFrames; ++i) {
    const ImageU8 frame = io::ReadGray(FramePng(root, "image_0", i));
    ImageU8 noise(frame.width(), frame.height(), 1);
    for (int y = 0; y < noise.height(); ++y) {
      for (int x = 0; x < noise.width(); ++x) noise.Row(y)[x] = static_cast<uint8_t>(grey(rng));
    }
    io::WriteImage(FramePng(root, "image_0", i), noise);
  }
  const CommandResult r = RunDfoRun(RunArgs(root, out) + " --set run.progress=none");
  ASSERT_EQ(r.status, 0) << r.err;
  const io::JsonValue summary = ReadSummary(out);
  for (const char* which : {"frontend", "windowed"}) {
    if (summary[which].IsNull()) {  // no evaluation at all: its note says why
      EXPECT_FALSE(summary[std::string(which) + "_note"].AsString().empty());
      continue;
    }
    const double explained = summary[which]["explained_spread"].AsNumber();
    if (explained < 0.5) {
      EXPECT_GE(summary[which]["warnings"].size(), 1u) << which;
      EXPECT_NE(r.err.find(std::string("dfo_run: warning: ") + which +
                           " trajectory: degenerate alignment"),
                std::string::npos)
          << r.err;
    } else {
      ADD_FAILURE() << which << ": noise frames explain " << explained
                    << " of the true path's spread";
    }
  }
}

TEST(DfoRun, WritesEveryPromisedFile) {
  const std::string root = MakeSequence("dfo_run_files");
  const std::string out = test::MakeTempDir("dfo_run_files_out") + "/run";
  const CommandResult r = RunDfoRun(RunArgs(root, out));
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;

  // Progress: plain lines (stdout is a pipe), the last one for the last frame, no '\r'.
  EXPECT_NE(r.out.find("dfo_run: frame 10/10 (100%)"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find('\r'), std::string::npos);

  // Trajectories: one pose per frame, with the dataset's timestamps (0.1 s apart).
  const Trajectory kitti = io::ReadKittiTrajectory(out + "/frontend_kitti.txt");
  const Trajectory tum = io::ReadTumTrajectory(out + "/frontend_tum.txt");
  ASSERT_EQ(kitti.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(tum.size(), static_cast<size_t>(kFrames));
  EXPECT_EQ(tum[3].timestamp_ns, 300000000);
  for (int i = 0; i < kFrames; ++i) {
    EXPECT_LT((kitti[i].world_from_cam.translation() - tum[i].world_from_cam.translation()).norm(),
              1e-9);
  }

  // frames.csv: a header and one row per frame.
  const std::string csv = ReadFile(out + "/frames.csv");
  EXPECT_EQ(CountLines(csv), static_cast<size_t>(kFrames + 1));
  EXPECT_EQ(csv.rfind("index,timestamp_s,status,", 0), 0u) << csv;

  // config_effective.yaml loads back to the same configuration.
  const io::Config effective = io::LoadConfig(out + "/config_effective.yaml", io::DfoSchema());
  const io::Config original =
      io::LoadConfig(test::SourceDir() + "/configs/demo.yaml", io::DfoSchema(),
                     {"dataset.path=" + root, "run.output_dir=" + out, "run.progress=plain"});
  for (const auto& key : io::DfoSchema().keys()) {
    EXPECT_EQ(effective.Get(key.path), original.Get(key.path)) << key.path;
  }

  // summary.json: the keys.
  const io::JsonValue s = ReadSummary(out);
  EXPECT_EQ(s["frames"].AsInt(), kFrames);
  EXPECT_GE(s["frames_lost"].AsInt(), 0);
  EXPECT_FALSE(s.Has("error"));
  for (const char* stage : {"load", "features", "depth", "tracking", "total_per_frame"}) {
    SCOPED_TRACE(stage);
    EXPECT_TRUE(s["timing_ms"][stage]["median"].IsNumber());
    EXPECT_TRUE(s["timing_ms"][stage]["p95"].IsNumber());
    EXPECT_GE(s["timing_ms"][stage]["p95"].AsNumber(), s["timing_ms"][stage]["median"].AsNumber());
  }
  EXPECT_GT(s["peak_rss_mb"].AsNumber(), 1.0);
  EXPECT_GT(s["fps"].AsNumber(), 0.0);
  // The synthetic sequence has ground truth: the Sim3 evaluation with dfo_eval's keys, the SE3
  // ATE, and the plot.
  ASSERT_TRUE(s["frontend"].IsObject()) << s.Dump(2);
  for (const char* key : {"num_poses", "alignment", "scale", "ate_rmse", "ate_mean", "ate_median",
                          "ate_max", "rpe_trans_rmse", "rpe_rot_rmse_deg", "kitti_t_rel_pct",
                          "snippet_ate_mean", "ate_rmse_se3", "ate_rmse_pct_of_path"}) {
    EXPECT_TRUE(s["frontend"].Has(key)) << key;
  }
  EXPECT_EQ(s["frontend"]["alignment"].AsString(), "sim3");
  EXPECT_EQ(s["frontend"]["num_poses"].AsInt(), kFrames);
  EXPECT_TRUE(fs::is_regular_file(out + "/frontend_trajectory.png"));
}

// run.write_keyframe_depth: every keyframe of the run with its windowed pose, image and points,
// which dfo_eval keyframe-depth compares with the sequence's true depth maps (416 x 128) while the
// run processed 208 x 64 frames with the window on pyramid level 1, so that a wrong pixel
// convention between the sizes shows. configs/demo.yaml starts the points at the true depth and
// holds them there (window.depth_prior_weight 10000): the error must stay that of the depth maps'
// own resampling (measured 0.0006 on the 10-frame sequence, 0.0003 for the start depths).
TEST(DfoRun, WritesTheKeyframesSettledDepth) {
  const std::string root = MakeSequence("dfo_run_keyframe_depth");
  const std::string out = test::MakeTempDir("dfo_run_keyframe_depth_out");
  const std::string args = RunArgs(root, out + "/run") +
                           " --set dataset.image_width=208 --set dataset.image_height=64"
                           " --set window.pyramid_level=1 --set run.write_keyframe_depth=" +
                           out + "/teacher";
  const CommandResult r = RunDfoRun(args);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const io::KeyframeDepthFolder folder = io::ReadKeyframeDepthFolder(out + "/teacher");
  EXPECT_EQ(folder.image_width, 208);
  EXPECT_EQ(folder.image_height, 64);
  const Trajectory keyframes = io::ReadTumTrajectory(out + "/run/keyframes_tum.txt");
  ASSERT_EQ(folder.keyframes.size(), keyframes.size());
  size_t points = 0;
  for (size_t k = 0; k < keyframes.size(); ++k) {
    const io::KeyframeDepthEntry& kf = folder.keyframes[k];
    EXPECT_EQ(kf.timestamp_ns, keyframes[k].timestamp_ns);
    EXPECT_EQ(kf.image, FramePng(root, "image_0", kf.frame));
    EXPECT_LT((kf.world_from_cam.Inverse() * keyframes[k].world_from_cam).Log().norm(), 1e-9);
    points += kf.points.size();
  }
  EXPECT_GT(points, 100u);
  const CommandResult eval =
      test::RunCommand(DFO_EVAL_EXE, "keyframe-depth --json --folder " + out + "/teacher --gt " +
                                         root + "/sequences/00/depth_0");
  ASSERT_EQ(eval.status, 0) << eval.out << eval.err;
  std::cout << "dfo_eval keyframe-depth: " << eval.out;
  const io::JsonValue j = io::ParseJson(eval.out, "dfo_eval keyframe-depth");
  EXPECT_EQ(static_cast<size_t>(j["keyframes"].AsInt()), keyframes.size());
  EXPECT_GT(j["points"].AsInt(), 100);
  EXPECT_LT(j["abs_rel_run_scale"].AsNumber(), 0.01) << eval.out;
  EXPECT_NEAR(j["run_scale"].AsNumber(), 1.0, 0.01);

  // Without a window there are no points to write: refused before the run.
  const CommandResult frontend = RunDfoRun(args + " --set run.mode=frontend");
  ExpectOneLineError(frontend, {"run.write_keyframe_depth", "run.mode = frontend"});
}

TEST(DfoRun, TwoRunsGiveByteIdenticalTrajectories) {
  const std::string root = MakeSequence("dfo_run_determinism");
  const std::string out = test::MakeTempDir("dfo_run_determinism_out");
  ASSERT_EQ(RunDfoRun(RunArgs(root, out + "/a")).status, 0);
  ASSERT_EQ(RunDfoRun(RunArgs(root, out + "/b")).status, 0);
  // run.deterministic (the default): the windowed files too (one Ceres thread, no time limit).
  for (const char* name : {"frontend_kitti.txt", "frontend_tum.txt", "windowed_kitti.txt",
                           "windowed_tum.txt", "keyframes_tum.txt"}) {
    SCOPED_TRACE(name);
    const std::string a = ReadFile(out + "/a/" + name);
    EXPECT_FALSE(a.empty());
    EXPECT_EQ(a, ReadFile(out + "/b/" + name));
  }
}

TEST(DfoRunBadInput, CorruptImageMidSequenceKeepsWhatWasComputed) {
  const std::string root = MakeSequence("dfo_run_corrupt");
  const std::string bad = FramePng(root, "image_0", 5);
  std::ofstream(bad, std::ios::binary | std::ios::trunc) << "this is not a PNG file";
  const std::string out = test::MakeTempDir("dfo_run_corrupt_out");
  const CommandResult r = RunDfoRun(RunArgs(root, out));
  ExpectOneLineError(r, {"dfo_run: error:", bad, "stopped after 5 of 10 frames"});
  EXPECT_EQ(r.status, 1);
  // Frames 0..4 were tracked: their poses are written, and the summary says what stopped the run.
  EXPECT_EQ(io::ReadKittiTrajectory(out + "/frontend_kitti.txt").size(), 5u);
  EXPECT_EQ(io::ReadTumTrajectory(out + "/frontend_tum.txt").size(), 5u);
  EXPECT_EQ(CountLines(ReadFile(out + "/frames.csv")), 6u);
  EXPECT_TRUE(fs::is_regular_file(out + "/config_effective.yaml"));
  const io::JsonValue s = ReadSummary(out);
  EXPECT_EQ(s["frames"].AsInt(), 5);
  EXPECT_EQ(s["frames_in_sequence"].AsInt(), kFrames);
  EXPECT_NE(s["error"].AsString().find(bad), std::string::npos) << s["error"].AsString();
}

TEST(DfoRunBadInput, DepthOfAnotherSizeIsAClearError) {
  const std::string root = MakeSequence("dfo_run_depth_size");
  const std::string bad = FramePng(root, "depth_0", 4);
  io::WriteU16(bad, ImageU16(100, 30, 1));
  const std::string out = test::MakeTempDir("dfo_run_depth_size_out");
  const CommandResult r = RunDfoRun(RunArgs(root, out));
  ExpectOneLineError(r, {bad, "100x30", "expected the image size 416x128"});
  EXPECT_EQ(io::ReadKittiTrajectory(out + "/frontend_kitti.txt").size(), 4u);
  EXPECT_TRUE(ReadSummary(out).Has("error"));
}

// A depth map with 5 % per-pixel noise leaves the window's depth-edge rule (which expects smooth
// or exact depth) almost no pixel: dfo_run says so once, with the key that turns it off, and
// counts such keyframes in the summary; the run itself goes on.
TEST(DfoRunBadInput, NoisyDepthIsNamedByTheDepthEdgeRule) {
  const std::string root = MakeSequence("dfo_run_noisy_depth");
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (int i = 0; i < kFrames; ++i) {
    ImageU16 depth = io::ReadU16(FramePng(root, "depth_0", i));
    for (uint16_t& v : depth.vector()) {
      if (v > 0) v = static_cast<uint16_t>(std::clamp(v * std::exp(noise(rng)), 1.0, 65535.0));
    }
    io::WriteU16(FramePng(root, "depth_0", i), depth);
  }
  const std::string out = test::MakeTempDir("dfo_run_noisy_depth_out");
  const CommandResult r = RunDfoRun(RunArgs(root, out));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string warning = "the window's depth-edge rule left out";
  const size_t first = r.err.find(warning);
  ASSERT_NE(first, std::string::npos) << r.err;
  EXPECT_EQ(r.err.find(warning, first + 1), std::string::npos) << "warned more than once";
  EXPECT_NE(r.err.find("window.max_depth_edge_slope = 0"), std::string::npos) << r.err;
  EXPECT_GT(ReadSummary(out)["keyframes"]["depth_edge_warnings"].AsInt(), 0);

  // The same frames with their exact depth: no warning.
  const std::string exact = MakeSequence("dfo_run_exact_depth");
  const std::string exact_out = test::MakeTempDir("dfo_run_exact_depth_out");
  const CommandResult e = RunDfoRun(RunArgs(exact, exact_out));
  ASSERT_EQ(e.status, 0) << e.err;
  EXPECT_EQ(e.err.find(warning), std::string::npos) << e.err;
  EXPECT_EQ(ReadSummary(exact_out)["keyframes"]["depth_edge_warnings"].AsInt(), 0);
}

TEST(DfoRunBadInput, MissingSequenceFolder) {
  const std::string out = test::MakeTempDir("dfo_run_missing_out");
  const std::string missing = out + "/no_such_dataset";
  ExpectOneLineError(RunDfoRun(RunArgs(missing, out + "/run")), {"dfo_run: error:", missing});
  EXPECT_FALSE(fs::exists(out + "/run/summary.json"));
}

// The largest frame size the configuration accepts (8192 x 8192; measured: 16 GB of memory for
// 3 frames) is refused before anything is written, naming the estimate, the keys that set it and
// run.memory_limit_mb; a run that is accepted records its estimate beside its peak memory.
TEST(DfoRunBadInput, AFrameSizeBeyondTheMemoryLimitIsRefusedUpFront) {
  const std::string root = MakeSequence("dfo_run_memory");
  const std::string out = test::MakeTempDir("dfo_run_memory_out");
  const CommandResult r =
      RunDfoRun(RunArgs(root, out + "/big") +
                " --set dataset.image_width=8192 --set dataset.image_height=8192");
  ExpectOneLineError(r, {"dfo_run: error:", "MiB", "8192 x 8192", "dataset.image_width",
                         "window.max_keyframes", "run.memory_limit_mb = 4096 (default)"});
  EXPECT_FALSE(fs::exists(out + "/big"));
  // The same limit set lower refuses the default size; set high, it lets the run through.
  ExpectOneLineError(RunDfoRun(RunArgs(root, out + "/small") + " --set run.memory_limit_mb=64"),
                     {"run.memory_limit_mb = 64 (--set)"});
  ASSERT_EQ(RunDfoRun(RunArgs(root, out + "/run")).status, 0);
  const io::JsonValue summary = ReadSummary(out + "/run");
  EXPECT_GE(summary["memory_estimate_mb"].AsNumber(), summary["peak_rss_mb"].AsNumber());
}

TEST(DfoRunBadInput, EmptySequenceFolder) {
  const std::string empty = test::MakeTempDir("dfo_run_empty");
  const std::string out = test::MakeTempDir("dfo_run_empty_out");
  ExpectOneLineError(RunDfoRun(RunArgs(empty, out)), {"dfo_run: error:", empty});
  // The KITTI layout with an image folder holding no image.
  const std::string root = MakeSequence("dfo_run_no_images");
  for (const auto& entry : fs::directory_iterator(root + "/sequences/00/image_0")) {
    fs::remove(entry.path());
  }
  ExpectOneLineError(RunDfoRun(RunArgs(root, out)), {"dfo_run: error:", "image_0"});
}

TEST(DfoRunBadInput, ConfigTypoSuggestsTheKey) {
  const std::string dir = test::MakeTempDir("dfo_run_typo");
  std::ofstream(dir + "/typo.yaml") << "tracker:\n  num_levels: 4\n  patch_sise: 3\n";
  const CommandResult file = RunDfoRun("--config " + dir + "/typo.yaml");
  ExpectOneLineError(file, {dir + "/typo.yaml:3", "unknown key 'tracker.patch_sise'",
                            "did you mean 'tracker.patch_size'"});
  const CommandResult set = RunDfoRun("--set refrence.max_interval=3");
  ExpectOneLineError(set, {"unknown configuration key 'refrence.max_interval'",
                           "did you mean 'reference.max_interval'"});
  const CommandResult range = RunDfoRun("--set tracker.num_levels=0");
  ExpectOneLineError(range, {"tracker.num_levels = 0 violates >= 1"});
}

TEST(DfoRunBadInput, DatasetWithoutDepthNeedsADepthSource) {
  const std::string root = MakeSequence("dfo_run_no_depth");
  fs::remove_all(root + "/sequences/00/depth_0");
  const std::string out = test::MakeTempDir("dfo_run_no_depth_out");
  ExpectOneLineError(RunDfoRun(RunArgs(root, out)),
                     {"no depth source", "has no depth maps", "--set frontend.depth=learned"});
}

// Every dfo_run configuration in configs/ runs with only dataset.path (and dataset.sequence)
// changed: on the synthetic KITTI-layout sequence with its depth maps, kitti.yaml and default.yaml
// also without them (frontend.depth = auto then takes the network, at the model's input size),
// and on the real KITTI and TUM extracts of ../shared/data when present.
TEST(DfoRun, ShippedConfigsRunWithOnlyThePathChanged) {
  const std::string with_depth = MakeSequence("dfo_run_shipped");
  const std::string without_depth = MakeSequence("dfo_run_shipped_no_depth");
  fs::remove_all(without_depth + "/sequences/00/depth_0");
  const std::string out = test::MakeTempDir("dfo_run_shipped_out");
  struct Case {
    std::string config, path, sequence, expect;
  };
  std::vector<Case> cases;
  for (const char* config : {"default", "demo", "demo_learned", "kitti"}) {
    cases.push_back({config, with_depth, "00", ""});
  }
  cases.push_back({"kitti", without_depth, "00", "depth learned (auto)"});
  cases.push_back({"default", without_depth, "00", "depth learned (auto)"});
  const std::string shared = test::SharedDataDir();
  if (!shared.empty()) {
    cases.push_back({"kitti", shared + "/kitti", "06", "depth learned (auto)"});
    cases.push_back({"tum", shared + "/tum/fr3_cabinet_keyframes", "", ""});
  } else {
    std::cout << "[ SKIPPED  ] the real KITTI and TUM cases: ../shared/data is absent\n";
  }
  int n = 0;
  for (const Case& c : cases) {
    const std::string run_out = out + "/" + std::to_string(n++) + "_" + c.config;
    std::string args = "--config " + test::SourceDir() + "/configs/" + c.config +
                       ".yaml --set dataset.path=" + c.path + " --set dataset.last=4" +
                       " --set run.progress=none --output " + run_out;
    if (!c.sequence.empty()) args += " --set dataset.sequence=" + c.sequence;
    // From the project root, as users run it (the configs' model path is relative to it).
    const CommandResult r =
        RunCommand("cd " + test::SourceDir() + " && " + std::string(DFO_RUN_EXE), args);
    ASSERT_EQ(r.status, 0) << c.config << " on " << c.path << ":\n" << r.out << r.err;
    EXPECT_TRUE(fs::exists(run_out + "/summary.json")) << c.config;
    if (!c.expect.empty()) {
      EXPECT_NE(r.out.find(c.expect), std::string::npos) << c.config << ": " << r.out;
      // The frames come at the model's input size, and the effective configuration says why.
      EXPECT_NE(r.out.find("of 208x64"), std::string::npos) << r.out;
      EXPECT_NE(ReadFile(run_out + "/config_effective.yaml").find("# from the input size of"),
                std::string::npos);
    }
  }
}

// The OpenMP runtime reads OMP_WAIT_POLICY when it loads, before main(): dfo_run re-executes
// itself with PASSIVE when the variable is unset, and summary.json reports the value its process
// image started with (/proc/self/environ, which a mere setenv() would not change).
TEST(DfoRun, StartsOpenMpWithPassiveWaitUnlessTheUserChoseAnother) {
  const std::string root = MakeSequence("dfo_run_omp");
  const std::string out = test::MakeTempDir("dfo_run_omp_out");
  const std::string args = "--config " + test::SourceDir() + "/configs/demo.yaml --set " +
                           "dataset.path=" + root + " --set dataset.last=2 --set run.progress=none";
  const CommandResult unset = RunCommand("env -u OMP_WAIT_POLICY " + std::string(DFO_RUN_EXE),
                                         args + " --output " + out + "/unset");
  ASSERT_EQ(unset.status, 0) << unset.err;
  EXPECT_EQ(ReadSummary(out + "/unset")["openmp_wait_policy"].AsString(), "PASSIVE");
  const CommandResult chosen = RunCommand("env OMP_WAIT_POLICY=ACTIVE " + std::string(DFO_RUN_EXE),
                                          args + " --output " + out + "/chosen");
  ASSERT_EQ(chosen.status, 0) << chosen.err;
  EXPECT_EQ(ReadSummary(out + "/chosen")["openmp_wait_policy"].AsString(), "ACTIVE");
}

// A longer sequence (150 frames, several seconds of work) for runs that are stopped half-way.
std::string MakeLongSequence() { return test::SyntheticSequence(DFO_SYNTH_EXE, 150); }

// Starts dfo_run on the long sequence in the background, waits until frames.csv holds `frames`
// frame lines, sends `signal` (and then runs the shell commands `then`, with the process id in $p),
// and returns the exit status.
int RunAndSignal(const std::string& out, const char* signal, int frames,
                 const std::string& then = "") {
  const std::string command = std::string(DFO_RUN_EXE) + " --config " + test::SourceDir() +
                              "/configs/demo.yaml --set dataset.path=" + MakeLongSequence() +
                              " --set run.progress=none --output " + out + " > " + out +
                              ".log 2>&1 & p=$!; i=0; " + "while [ \"$(cat " + out +
                              "/frames.csv 2>/dev/null | wc -l)\" -le " + std::to_string(frames) +
                              " ] && [ $i -lt 3000 ]; do sleep 0.02; i=$((i+1)); done; kill -" +
                              signal + " $p; " + then + " wait $p; echo $?";
  const CommandResult r = RunCommand("sh", "-c '" + command + "'");
  return std::atoi(r.out.c_str());
}

size_t FileLines(const std::string& path) { return CountLines(ReadFile(path)); }

TEST(DfoRunInterrupted, SigintAndSigtermWriteEveryOutputAndSaySo) {
  const std::string dir = test::MakeTempDir("dfo_run_sigint");
  for (const auto& [signal, name, status] :
       {std::make_tuple("INT", "SIGINT", 130), std::make_tuple("TERM", "SIGTERM", 143)}) {
    const std::string out = dir + "/" + name;
    EXPECT_EQ(RunAndSignal(out, signal, 5), status) << ReadFile(out + ".log");
    const io::JsonValue summary = ReadSummary(out);
    ASSERT_TRUE(summary.Has("interrupted")) << ReadFile(out + ".log");
    EXPECT_EQ(summary["interrupted"]["signal"].AsString(), name);
    const int64_t frames = summary["frames"].AsInt();
    EXPECT_EQ(summary["interrupted"]["frame"].AsInt(), frames);
    EXPECT_GE(frames, 5);
    EXPECT_LT(frames, 150);
    // Every output of the frames processed, complete.
    EXPECT_EQ(FileLines(out + "/frontend_kitti.txt"), static_cast<size_t>(frames));
    EXPECT_EQ(FileLines(out + "/windowed_kitti.txt"), static_cast<size_t>(frames));
    EXPECT_EQ(FileLines(out + "/frames.csv"), static_cast<size_t>(frames) + 1);
    EXPECT_TRUE(fs::exists(out + "/windowed_trajectory.png"));
    EXPECT_NE(ReadFile(out + ".log").find(std::string("interrupted by ") + name),
              std::string::npos);
  }
}

// Every output of a run that was stopped by a signal, complete, and the line that says so.
void ExpectInterruptedRunComplete(const std::string& out, int signals) {
  const std::string log = ReadFile(out + ".log");
  const io::JsonValue summary = ReadSummary(out);
  ASSERT_TRUE(summary.Has("interrupted")) << log;
  const size_t frames = static_cast<size_t>(summary["frames"].AsInt());
  EXPECT_EQ(FileLines(out + "/frontend_kitti.txt"), frames) << log;
  EXPECT_EQ(FileLines(out + "/windowed_kitti.txt"), frames) << log;
  EXPECT_EQ(FileLines(out + "/frames.csv"), frames + 1) << log;
  EXPECT_TRUE(fs::exists(out + "/keyframes_tum.txt")) << log;
  EXPECT_NE(log.find("dfo_run: interrupted by"), std::string::npos) << log;
  if (signals > 1) {
    EXPECT_EQ(summary["interrupted"]["signals"].AsInt(), signals) << log;
    EXPECT_TRUE(summary["interrupted"]["plots_skipped"].AsBool()) << log;
    EXPECT_NE(log.find("another stop signal"), std::string::npos) << log;
  }
}

// The same, with the number of signals the run counted: a second signal may come after the first
// one's outputs were written (then it counts one).
void ExpectInterruptedRunCompleteAfterItsSignals(const std::string& out) {
  const io::JsonValue summary = ReadSummary(out);
  ExpectInterruptedRunComplete(
      out,
      summary.Has("interrupted") ? static_cast<int>(summary["interrupted"]["signals"].AsInt()) : 1);
}

// dfo_run on the long sequence under coreutils `timeout -s TERM seconds`; its exit status.
int RunUnderTimeout(const std::string& out, const std::string& seconds) {
  const CommandResult r = RunCommand(
      "sh", "-c 'timeout -s TERM " + seconds + " " + std::string(DFO_RUN_EXE) + " --config " +
                test::SourceDir() + "/configs/demo.yaml --set dataset.path=" + MakeLongSequence() +
                " --set run.progress=none --output " + out + " > " + out + ".log 2>&1; echo $?'");
  return std::atoi(r.out.c_str());
}

// An impatient Ctrl-C Ctrl-C, with the second signal at several moments of the first one's
// hand-over (right away, during the last frame, while the outputs are written), and coreutils
// timeout (which signals the process and then its group): every result is still written.
TEST(DfoRunInterrupted, ASecondSignalStillWritesEveryResult) {
  const std::string dir = test::MakeTempDir("dfo_run_double_signal");
  const std::vector<std::string> gaps = {"",           "sleep 0.01;", "sleep 0.05;",
                                         "sleep 0.1;", "sleep 0.2;",  "sleep 0.3;"};
  for (size_t i = 0; i < gaps.size(); ++i) {
    const std::string out = dir + "/double_" + std::to_string(i);
    EXPECT_EQ(
        RunAndSignal(out, "INT", 3 + static_cast<int>(i), gaps[i] + " kill -INT $p 2>/dev/null;"),
        130)
        << ReadFile(out + ".log");
    ExpectInterruptedRunCompleteAfterItsSignals(out);
  }
  // coreutils timeout: the run is stopped during its first frames.
  const std::string out = dir + "/timeout";
  EXPECT_EQ(RunUnderTimeout(out, "3"), 124) << ReadFile(out + ".log");
  ExpectInterruptedRunComplete(out, 1);
}

// The same, repeated in a loop over a fixed schedule (tools/signal_check.sh runs it 100 times
// each way): double SIGINTs at frames 1-12 with gaps of 0-150 ms, and coreutils timeout after
// 1.5-2.7 s (past start-up, during the first frames). No run loses a result.
TEST(DfoRunInterrupted, DoubleSignalsInALoopLoseNothing) {
  const std::string dir = test::MakeTempDir("dfo_run_signal_loop");
  const std::vector<std::string> gaps = {"", "sleep 0.01;", "sleep 0.03;", "sleep 0.07;",
                                         "sleep 0.15;"};
  for (int i = 0; i < 12; ++i) {
    SCOPED_TRACE("run " + std::to_string(i));
    const std::string out = dir + "/run_" + std::to_string(i);
    if (i % 3 == 2) {
      char duration[16];
      std::snprintf(duration, sizeof(duration), "%.1f", 1.5 + 0.1 * i);
      EXPECT_EQ(RunUnderTimeout(out, duration), 124) << ReadFile(out + ".log");
    } else {
      const int frame = 1 + (i * 7) % 12;
      EXPECT_EQ(
          RunAndSignal(out, "INT", frame,
                       gaps[static_cast<size_t>(i) % gaps.size()] + " kill -INT $p 2>/dev/null;"),
          130)
          << ReadFile(out + ".log");
    }
    ExpectInterruptedRunCompleteAfterItsSignals(out);
  }
}

TEST(DfoRunInterrupted, SigkillLeavesThePerFrameFilesUpToTheLastFrames) {
  const std::string out = test::MakeTempDir("dfo_run_sigkill") + "/run";
  EXPECT_EQ(RunAndSignal(out, "KILL", 20), 137);
  EXPECT_FALSE(fs::exists(out + "/summary.json"));  // a summary is never half-written
  // frames.csv (header + one line a frame) and the frontend poses, written as the run went.
  const size_t rows = FileLines(out + "/frames.csv");
  EXPECT_GE(rows, 21u);
  const Trajectory kitti = io::ReadKittiTrajectory(out + "/frontend_kitti.txt");
  const Trajectory tum = io::ReadTumTrajectory(out + "/frontend_tum.txt");
  EXPECT_GE(kitti.size() + 1, rows - 1);  // the kill may fall between two files' lines
  EXPECT_LE(kitti.size(), rows);
  EXPECT_GE(tum.size() + 1, kitti.size());
  for (size_t i = 0; i < std::min(kitti.size(), tum.size()); ++i) {
    EXPECT_LT((kitti[i].world_from_cam.translation() - tum[i].world_from_cam.translation()).norm(),
              1e-9);
  }
}

TEST(DfoRunInterrupted, ClosedStdoutDoesNotStopTheRun) {
  const std::string root = MakeSequence("dfo_run_pipe");
  const std::string out = test::MakeTempDir("dfo_run_pipe_out") + "/run";
  const CommandResult r = RunCommand(
      "sh", "-c '" + std::string(DFO_RUN_EXE) + " " + RunArgs(root, out) + " | head -c 1'");
  EXPECT_EQ(ReadSummary(out)["frames"].AsInt(), kFrames);
  EXPECT_EQ(FileLines(out + "/windowed_tum.txt"), static_cast<size_t>(kFrames) + 1);
}

TEST(DfoRunBadOutput, AnOutputThatCannotBeWrittenLosesNoOtherAndIsNamed) {
  const std::string root = MakeSequence("dfo_run_badout");
  const std::string out = test::MakeTempDir("dfo_run_badout_out") + "/run";
  fs::create_directories(out + "/frontend_kitti.txt");  // a folder where a file must go
  const CommandResult r = RunDfoRun(RunArgs(root, out));
  EXPECT_EQ(r.status, 1) << r.err;
  EXPECT_NE(r.err.find(out + "/frontend_kitti.txt"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("Is a directory"), std::string::npos) << r.err;
  const io::JsonValue summary = ReadSummary(out);
  ASSERT_EQ(summary["incomplete_files"].size(), 1u);
  EXPECT_NE(summary["incomplete_files"][0].AsString().find("frontend_kitti.txt"),
            std::string::npos);
  for (const char* kept :
       {"frontend_tum.txt", "windowed_kitti.txt", "frames.csv", "comparison_trajectory.png"}) {
    EXPECT_TRUE(fs::is_regular_file(out + "/" + kept)) << kept;
  }
}

TEST(DfoRun, AReusedFolderKeepsNoOutputOfAnEarlierRun) {
  const std::string root = MakeSequence("dfo_run_reuse");
  const std::string out = test::MakeTempDir("dfo_run_reuse_out") + "/run";
  ASSERT_EQ(RunDfoRun(RunArgs(root, out)).status, 0);
  EXPECT_TRUE(fs::exists(out + "/windowed_kitti.txt"));
  std::ofstream(out + "/notes.txt") << "mine";
  const CommandResult again = RunDfoRun(RunArgs(root, out) + " --set run.mode=frontend");
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_NE(again.out.find("removed"), std::string::npos) << again.out;
  EXPECT_FALSE(fs::exists(out + "/windowed_kitti.txt"));
  EXPECT_FALSE(fs::exists(out + "/comparison_trajectory.png"));
  EXPECT_TRUE(fs::exists(out + "/frontend_kitti.txt"));
  EXPECT_TRUE(fs::exists(out + "/notes.txt"));  // not an output of dfo_run: kept
}

// The demo's accuracy as the README states it (tests/support/measured_figures.h).
TEST(DfoRun, DemoKeepsItsMeasuredAccuracy) {
  const std::string dir = test::MakeTempDir("dfo_run_demo_figures");
  const CommandResult synth = RunCommand(DFO_SYNTH_EXE, "--output " + dir + "/synthetic");
  ASSERT_EQ(synth.status, 0) << synth.err;
  const CommandResult r =
      RunDfoRun("--config " + test::SourceDir() + "/configs/demo.yaml --set dataset.path=" + dir +
                "/synthetic --set run.progress=none --set run.plot=false --output " + dir + "/run");
  ASSERT_EQ(r.status, 0) << r.err;
  const io::JsonValue summary = ReadSummary(dir + "/run");
  EXPECT_EQ(summary["frames_lost"].AsInt(), 0);
  const double frontend = summary["frontend"]["ate_rmse"].AsNumber();
  const double windowed = summary["windowed"]["ate_rmse"].AsNumber();
  EXPECT_LE(frontend, test::kDemoFrontendAteBound) << "measured " << test::kDemoFrontendAte;
  EXPECT_LE(windowed, test::kDemoWindowedAteBound) << "measured " << test::kDemoWindowedAte;
  // Much better than measured means the figures in the README are stale: update them.
  EXPECT_GT(frontend, 0.5 * test::kDemoFrontendAte);
  EXPECT_GT(windowed, 0.5 * test::kDemoWindowedAte);
}

// configs/kitti.yaml on real video (../shared/data) keeps the figures the README states
// (tests/support/measured_figures.h): KITTI 06 frames 0-50, KITTI 00 frames 0-159 and all 801
// frames of KITTI 03.
TEST(DfoRun, KittiConfigKeepsItsMeasuredAccuracyOnRealVideo) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  const std::string shared = test::SharedDataDir();
  const std::string dir = test::MakeTempDir("dfo_run_kitti_figures");
  const auto run = [&](const std::string& sequence, const std::string& extra) {
    const std::string out = dir + "/" + sequence;
    const CommandResult r =
        RunCommand("cd " + test::SourceDir() + " && " + std::string(DFO_RUN_EXE),
                   "--config configs/kitti.yaml --set dataset.path=" + shared +
                       "/kitti --set dataset.sequence=" + sequence + extra +
                       " --set run.progress=none --set run.plot=false --output " + out);
    EXPECT_EQ(r.status, 0) << r.out << r.err;
    return ReadSummary(out);
  };
  const io::JsonValue k06 = run("06", " --set dataset.last=50");
  EXPECT_EQ(k06["frames_lost"].AsInt(), 0);
  const double k06_ate = k06["windowed"]["ate_rmse"].AsNumber();
  EXPECT_LE(k06_ate, test::kKitti06WindowedAteBound) << "measured " << test::kKitti06WindowedAte;
  const io::JsonValue k00 = run("00", " --set dataset.last=159");
  EXPECT_EQ(k00["frames_lost"].AsInt(), 0);
  const double k00_ate = k00["windowed"]["ate_rmse"].AsNumber();
  EXPECT_LE(k00_ate, test::kKitti00WindowedAteBound) << "measured " << test::kKitti00WindowedAte;
  const io::JsonValue k03 = run("03", "");
  EXPECT_EQ(k03["frames_lost"].AsInt(), 0);
  const double k03_ate = k03["windowed"]["ate_rmse"].AsNumber();
  const double k03_trel = k03["windowed"]["kitti_t_rel_pct"].AsNumber();
  EXPECT_LE(k03_ate, test::kKitti03WindowedAteBound) << "measured " << test::kKitti03WindowedAte;
  EXPECT_LE(k03_trel, test::kKitti03WindowedTRelPctBound)
      << "measured " << test::kKitti03WindowedTRelPct;
  // Much better than measured means the README's figures are stale: update them.
  EXPECT_GT(k06_ate, 0.5 * test::kKitti06WindowedAte);
  EXPECT_GT(k00_ate, 0.5 * test::kKitti00WindowedAte);
  EXPECT_GT(k03_ate, 0.5 * test::kKitti03WindowedAte);
}

// A sequence without ground truth (a user's own video) still gives a picture of the path from
// above and its length, in the estimate's own scale.
TEST(DfoRun, WithoutGroundTruthDrawsThePathAndGivesItsLength) {
  const std::string root = MakeSequence("dfo_run_no_gt");
  fs::remove_all(root + "/poses");
  const std::string out = test::MakeTempDir("dfo_run_no_gt_out") + "/run";
  const CommandResult r = RunDfoRun(RunArgs(root, out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::is_regular_file(out + "/comparison_trajectory.png"));
  const io::JsonValue summary = ReadSummary(out);
  EXPECT_TRUE(summary["windowed"].IsNull());
  EXPECT_GT(summary["path_length"]["frontend"].AsNumber(), 0.0);
  EXPECT_GT(summary["path_length"]["windowed"].AsNumber(), 0.0);
  EXPECT_NE(r.out.find("path length"), std::string::npos) << r.out;
}

TEST(DfoRunBadInput, DepthFullOfZerosIsLostNotACrash) {
  const std::string root = MakeSequence("dfo_run_zero_depth");
  for (int i = 0; i < kFrames; ++i)
    io::WriteU16(FramePng(root, "depth_0", i), ImageU16(416, 128, 1));
  const std::string out = test::MakeTempDir("dfo_run_zero_depth_out");
  const CommandResult r = RunDfoRun(RunArgs(root, out));
  EXPECT_EQ(r.status, 0) << r.err;
  const io::JsonValue s = ReadSummary(out);
  EXPECT_EQ(s["frames"].AsInt(), kFrames);
  EXPECT_EQ(s["frames_ok"].AsInt(), 0);
  EXPECT_EQ(s["frames_degraded"].AsInt(), 0);
  EXPECT_GE(s["frames_lost"].AsInt(), 1);
  // Each lost frame says why, and stderr says it once.
  EXPECT_EQ(s["frames_lost_by_cause"]["no_depth"].AsInt(), s["frames_lost"].AsInt());
  EXPECT_NE(r.err.find("warning: frame 0 cannot start a tracking reference: its depth has too few "
                       "valid pixels"),
            std::string::npos)
      << r.err;
  const std::string csv = ReadFile(out + "/frames.csv");
  EXPECT_NE(
      csv.find(",lost_cause,windowed_step_scale,keyframe_stereo_fraction,keyframe_source_scale,"
               "keyframe_solve\n"),
      std::string::npos);
  EXPECT_NE(csv.find(",no_depth,,,,\n"), std::string::npos);
  // No frame tracked: no ATE, and the summary says why.
  EXPECT_TRUE(s["frontend"].IsNull());
  EXPECT_TRUE(s["windowed"].IsNull());
  EXPECT_NE(s["windowed_note"].AsString().find("frames were tracked"), std::string::npos);
  EXPECT_EQ(io::ReadKittiTrajectory(out + "/frontend_kitti.txt").size(),
            static_cast<size_t>(kFrames));
}

// --- The runner library in-process -----------------------------------------------------------

// Synthetic frames rendered in memory; depth replaced by NaN when asked; Load throws for frames
// at or after `fail_at`.
class InMemoryProvider : public apps::FrameProvider {
 public:
  InMemoryProvider(int frames, bool nan_depth, int fail_at = -1)
      : sequence_(Options(frames)), nan_depth_(nan_depth), fail_at_(fail_at) {}
  std::string name() const override { return "in-memory synthetic"; }
  size_t size() const override { return static_cast<size_t>(sequence_.num_frames()); }
  io::LoadedFrame Load(size_t i) const override {
    if (fail_at_ >= 0 && static_cast<int>(i) >= fail_at_) {
      throw InputError("frame " + std::to_string(i) + ": broken on purpose");
    }
    const SyntheticFrame f = sequence_.RenderFrame(static_cast<int>(i), 2);
    io::LoadedFrame loaded;
    loaded.index = static_cast<int>(i);
    loaded.timestamp_ns = f.timestamp_ns;
    loaded.image = f.gray;
    loaded.depth_m = f.depth;
    if (nan_depth_) {
      for (int y = 0; y < loaded.depth_m.height(); ++y) {
        for (int x = 0; x < loaded.depth_m.width(); ++x) {
          loaded.depth_m(x, y) = std::numeric_limits<float>::quiet_NaN();
        }
      }
    }
    loaded.camera = sequence_.camera();
    loaded.world_from_cam = f.world_from_cam;
    return loaded;
  }

 private:
  static SyntheticOptions Options(int frames) {
    SyntheticOptions o;
    o.num_frames = frames;
    return o;
  }
  SyntheticSequence sequence_;
  bool nan_depth_;
  int fail_at_;
};

TEST(SequenceRunner, NanDepthIsLostNotACrash) {
  const InMemoryProvider provider(5, /*nan_depth=*/true);
  OdometryOptions system;
  system.mode = OdometryMode::kFrontend;
  Odometry odometry(FrontendOptions{}, system);
  apps::SequenceRunOptions options;
  options.progress_stream = nullptr;
  const apps::SequenceRunResult result = apps::RunSequence(provider, &odometry, options);
  EXPECT_TRUE(result.error.empty()) << result.error;
  ASSERT_EQ(result.frames.size(), 5u);
  EXPECT_EQ(result.CountStatus(TrackingStatus::kOk), 0);
  EXPECT_EQ(result.CountStatus(TrackingStatus::kDegraded), 0);
  EXPECT_GE(result.CountStatus(TrackingStatus::kLost), 1);
  for (const apps::FrameRecord& f : result.frames) {
    EXPECT_TRUE(f.tracked.world_from_cam.translation().allFinite());
  }
}

TEST(SequenceRunner, ErrorHalfWayKeepsTheFramesBefore) {
  const InMemoryProvider provider(6, /*nan_depth=*/false, /*fail_at=*/3);
  OdometryOptions system;
  system.mode = OdometryMode::kFrontend;
  Odometry odometry(FrontendOptions{}, system);
  apps::SequenceRunOptions options;
  options.progress_stream = nullptr;
  const apps::SequenceRunResult result = apps::RunSequence(provider, &odometry, options);
  EXPECT_EQ(result.frames.size(), 3u);
  EXPECT_EQ(result.frames_in_sequence, 6u);
  EXPECT_NE(result.error.find("frame 3: broken on purpose"), std::string::npos) << result.error;
  const std::string out = test::MakeTempDir("sequence_runner_partial");
  const apps::RunOutputs outputs = apps::WriteRunOutputs(result, out, /*plot=*/false);
  EXPECT_EQ(io::ReadKittiTrajectory(out + "/frontend_kitti.txt").size(), 3u);
  EXPECT_EQ(outputs.summary["error"].AsString(), result.error);
  EXPECT_EQ(outputs.summary["frames"].AsInt(), 3);
  EXPECT_TRUE(outputs.plot_path.empty());
}

TEST(SequenceRunner, SummaryWithoutGroundTruthSaysWhy) {
  apps::SequenceRunResult result;
  result.sequence_name = "no gt";
  result.frames_in_sequence = 2;
  result.frames.resize(2);
  result.wall_s = 0.5;
  const apps::RunEvaluation evaluation = apps::EvaluateRun(result);
  EXPECT_FALSE(evaluation.available);
  const io::JsonValue s = apps::MakeRunSummary(result, evaluation);
  EXPECT_TRUE(s["frontend"].IsNull());
  EXPECT_NE(s["frontend_note"].AsString().find("no ground truth"), std::string::npos);
  EXPECT_DOUBLE_EQ(s["fps"].AsNumber(), 4.0);
}

}  // namespace
}  // namespace dfo
