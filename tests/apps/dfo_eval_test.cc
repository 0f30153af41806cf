// Runs the real dfo_eval executable (DFO_EVAL_EXE) and checks its output, exit status and error
// lines.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "dfo_core/trajectory.h"
#include "dfo_io/file_reader.h"
#include "dfo_io/image_io.h"
#include "dfo_io/json.h"
#include "dfo_io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

using test::CommandResult;

CommandResult RunEval(const std::string& args) { return test::RunCommand(DFO_EVAL_EXE, args); }

// Exactly one line on stderr containing `fragment`, nothing on stdout, non-zero exit.
void ExpectCleanFailure(const CommandResult& r, const std::string& fragment) {
  EXPECT_NE(r.status, 0);
  EXPECT_TRUE(r.out.empty()) << r.out;
  EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "more than one line: " << r.err;
}

const char* kJsonKeys[] = {"num_poses",
                           "scale",
                           "ate_rmse",
                           "ate_mean",
                           "ate_median",
                           "ate_max",
                           "rpe_trans_rmse",
                           "rpe_rot_rmse_deg",
                           "kitti_t_rel_pct",
                           "kitti_r_rel_deg_per_100m",
                           "snippet_ate_mean",
                           "snippet_ate_std",
                           "ate_rmse_directions_only",
                           "ate_rmse_lengths_only"};

// A curving trajectory written as KITTI, and the same scaled by 2 about the origin.
void WriteScaledPair(const std::string& dir, int n) {
  Trajectory gt, est;
  SE3d pose;
  for (int i = 0; i < n; ++i) {
    gt.Add(i * 100000000LL, pose);
    est.Add(i * 100000000LL, SE3d(pose.so3(), 2.0 * pose.translation()));
    Vector6d xi;
    xi << 0.05 * std::sin(0.3 * i), 0.0, 1.0, 0.0, 0.03, 0.01 * std::cos(0.2 * i);
    pose = pose * SE3d::Exp(xi);
  }
  io::WriteKittiTrajectory(dir + "/gt.txt", gt);
  io::WriteKittiTrajectory(dir + "/est.txt", est);
}

TEST(DfoEval, HelpExitsZero) {
  for (const std::string args : {"--help", "traj --help", "depth --help"}) {
    const CommandResult r = RunEval(args);
    EXPECT_EQ(r.status, 0) << args;
    EXPECT_NE(r.out.find("usage: dfo_eval"), std::string::npos) << r.out;
    EXPECT_TRUE(r.err.empty()) << r.err;
  }
}

TEST(DfoEval, CommandLineMistakesAreOneClearLine) {
  const std::string dir = test::MakeTempDir("dfo_eval_cli");
  WriteScaledPair(dir, 20);
  const std::string files = " --gt " + dir + "/gt.txt --est " + dir + "/est.txt";
  ExpectCleanFailure(RunEval(""), "no command");
  ExpectCleanFailure(RunEval("trajectory"), "unknown command 'trajectory'");
  ExpectCleanFailure(RunEval("traj" + files + " --bogus"), "unknown argument '--bogus'");
  ExpectCleanFailure(RunEval("traj" + files + " --delta"), "--delta needs a value");
  ExpectCleanFailure(RunEval("traj" + files + " --delta abc"),
                     "--delta: 'abc' is not a (finite) number");
  ExpectCleanFailure(RunEval("traj --gt " + dir + "/gt.txt"), "--est is required");
  ExpectCleanFailure(RunEval("traj" + files + " --align affine"), "affine");
  ExpectCleanFailure(RunEval("traj" + files + " --format euroc"), "euroc");
  ExpectCleanFailure(RunEval("traj" + files + " --delta-unit s"), "--delta-unit 's'");
  ExpectCleanFailure(RunEval("traj --gt " + dir + "/missing.txt --est " + dir + "/est.txt"),
                     "missing.txt");
  ExpectCleanFailure(RunEval("depth --gt " + dir), "--pred is required");
}

// A folder given as either trajectory is named as a folder.
TEST(DfoEval, AFolderGivenAsATrajectoryIsNamedAsOne) {
  const std::string dir = test::MakeTempDir("dfo_eval_folder");
  WriteScaledPair(dir, 20);
  ExpectCleanFailure(RunEval("traj --gt " + dir + " --est " + dir + "/est.txt"),
                     "ground-truth trajectory file " + dir + " is a folder");
  ExpectCleanFailure(RunEval("traj --gt " + dir + "/gt.txt --est " + dir), dir + " is a folder");
}

// An estimate that barely moves (noise of 1e-6 about one point) aligns at an absurd scale: its
// figures are computed but flagged, in the JSON and on stderr; a good estimate has no warning.
TEST(DfoEval, DegenerateAlignmentIsFlagged) {
  const std::string dir = test::MakeTempDir("dfo_eval_degenerate");
  WriteScaledPair(dir, 40);
  const Trajectory gt = io::ReadKittiTrajectory(dir + "/gt.txt");
  Trajectory still;
  for (size_t i = 0; i < gt.size(); ++i) {
    const Eigen::Vector3d jitter(1e-6 * std::sin(7.0 * i), 1e-6 * std::cos(3.0 * i),
                                 1e-6 * std::sin(5.0 * i + 1.0));
    still.Add(gt[i].timestamp_ns, SE3d(gt[i].world_from_cam.so3(), jitter));
  }
  io::WriteKittiTrajectory(dir + "/still.txt", still);
  const CommandResult r =
      RunEval("traj --json --gt " + dir + "/gt.txt --est " + dir + "/still.txt");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("dfo_eval traj: warning: degenerate alignment"), std::string::npos) << r.err;
  const io::JsonValue j = io::ParseJson(r.out);
  ASSERT_EQ(j["warnings"].size(), 1u) << r.out;
  EXPECT_LT(j["explained_spread"].AsNumber(), 0.5);
  const CommandResult good =
      RunEval("traj --json --gt " + dir + "/gt.txt --est " + dir + "/est.txt");
  ASSERT_EQ(good.status, 0) << good.err;
  EXPECT_TRUE(good.err.empty()) << good.err;
  EXPECT_EQ(io::ParseJson(good.out)["warnings"].size(), 0u);
  EXPECT_GT(io::ParseJson(good.out)["explained_spread"].AsNumber(), 0.999);
}

// TUM trajectories associated by time stamp: an alignment on a third of the estimate is flagged.
TEST(DfoEval, AlignmentOnASmallShareOfThePosesIsFlagged) {
  const std::string dir = test::MakeTempDir("dfo_eval_share");
  WriteScaledPair(dir, 60);
  const Trajectory gt = io::ReadKittiTrajectory(dir + "/gt.txt");
  const Trajectory est = io::ReadKittiTrajectory(dir + "/est.txt");
  Trajectory gt_part, est_shifted;
  for (size_t i = 0; i < gt.size(); ++i) {
    if (i < 20) gt_part.Add(gt[i].timestamp_ns, gt[i].world_from_cam);
    est_shifted.Add(est[i].timestamp_ns, est[i].world_from_cam);
  }
  io::WriteTumTrajectory(dir + "/gt_part.txt", gt_part);
  io::WriteTumTrajectory(dir + "/est_all.txt", est_shifted);
  const CommandResult r =
      RunEval("traj --json --gt " + dir + "/gt_part.txt --est " + dir + "/est_all.txt");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("the alignment rests on 20 of the 60 estimated poses"), std::string::npos)
      << r.err;
}

TEST(DfoEval, KittiCountMismatchAndBadLinesAreClearErrors) {
  const std::string dir = test::MakeTempDir("dfo_eval_mismatch");
  WriteScaledPair(dir, 20);
  Trajectory shorter = io::ReadKittiTrajectory(dir + "/gt.txt");
  shorter.poses().pop_back();
  io::WriteKittiTrajectory(dir + "/short.txt", shorter);
  ExpectCleanFailure(
      RunEval("traj --format kitti --gt " + dir + "/gt.txt --est " + dir + "/short.txt"),
      "has 20 poses and " + dir + "/short.txt has 19");
  std::ofstream(dir + "/bad.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n";
  ExpectCleanFailure(
      RunEval("traj --format kitti --gt " + dir + "/bad.txt --est " + dir + "/gt.txt"),
      dir + "/bad.txt:2: pose line with 11 numbers, expected 12");
}

TEST(DfoEval, Sim3AlignmentRemovesScaleOfSyntheticPair) {
  const std::string dir = test::MakeTempDir("dfo_eval_sim3");
  WriteScaledPair(dir, 60);
  const std::string files = " --gt " + dir + "/gt.txt --est " + dir + "/est.txt";
  CommandResult r = RunEval("traj" + files + " --align sim3 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  io::JsonValue j = io::ParseJson(r.out, "dfo_eval stdout");
  for (const char* key : kJsonKeys) EXPECT_TRUE(j.Has(key)) << key;
  EXPECT_EQ(j["num_poses"].AsInt(), 60);
  EXPECT_NEAR(j["scale"].AsNumber(), 0.5, 1e-9);
  EXPECT_LT(j["ate_rmse"].AsNumber(), 1e-9);
  EXPECT_LT(j["rpe_trans_rmse"].AsNumber(), 1e-9);
  EXPECT_LT(j["snippet_ate_mean"].AsNumber(), 1e-9);
  EXPECT_LT(j["ate_rmse_directions_only"].AsNumber(), 1e-9);
  EXPECT_LT(j["ate_rmse_lengths_only"].AsNumber(), 1e-9);
  EXPECT_NE(r.out.find("ate_rmse_lengths_only"), std::string::npos);
  EXPECT_TRUE(j["kitti_t_rel_pct"].IsNull());  // 60 m: no 100 m segment
  EXPECT_TRUE(j["kitti_r_rel_deg_per_100m"].IsNull());

  r = RunEval("traj" + files + " --align none --json");
  ASSERT_EQ(r.status, 0) << r.err;
  j = io::ParseJson(r.out, "dfo_eval stdout");
  EXPECT_EQ(j["scale"].AsNumber(), 1.0);
  EXPECT_GT(j["ate_rmse"].AsNumber(), 1.0);
  EXPECT_NEAR(j["rpe_trans_rmse"].AsNumber(), 1.0, 0.01);  // 2 m steps vs 1 m steps
  EXPECT_LT(j["snippet_ate_mean"].AsNumber(), 1e-9);       // snippet ATE fits its own scale

  // Text mode names the alignment and the figures; --plot writes a PNG.
  r = RunEval("traj" + files + " --plot " + dir + "/plots/top.png");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("alignment:    sim3"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("KITTI         not computed"), std::string::npos) << r.out;
  int width = 0, height = 0;
  io::ReadImageSize(dir + "/plots/top.png", &width, &height);
  EXPECT_EQ(width, 1200);
  EXPECT_EQ(height, 900);
}

// A TUM file of n poses, position i given by `position(i)` (printed with %.17g).
template <typename F>
std::string WriteTum(const std::string& path, int n, F position) {
  std::ofstream out(path);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p = position(i);
    char line[256];
    std::snprintf(line, sizeof(line), "%d.0 %.17g %.17g %.17g 0 0 0 1\n", i, p.x(), p.y(), p.z());
    out << line;
  }
  return path;
}

// Trajectories at magnitudes whose squares overflow are evaluated exactly (the scale of 1e-300
// printed as such, not as 0.000000); inputs for which no alignment or metric means anything are
// one clear error line naming the files, exit status 1, never figures of garbage.
TEST(DfoEval, HugeAndDegenerateTrajectories) {
  const std::string dir = test::MakeTempDir("dfo_eval_degenerate");
  const auto curve = [](int i) {
    return Eigen::Vector3d(i, 2.0 * std::sin(0.5 * i), std::cos(0.7 * i));
  };
  const std::string gt = WriteTum(dir + "/gt.txt", 20, curve);
  const std::string est_1e300 = WriteTum(dir + "/est_1e300.txt", 20,
                                         [&](int i) { return Eigen::Vector3d(1e300 * curve(i)); });
  CommandResult r = RunEval("traj --gt " + gt + " --est " + est_1e300);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("alignment:    sim3 (Umeyama), scale 1.000000e-300"), std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("ATE [m]       rmse 0.000000"), std::string::npos) << r.out;
  r = RunEval("traj --json --gt " + gt + " --est " + est_1e300);
  ASSERT_EQ(r.status, 0) << r.err;
  const io::JsonValue j = io::ParseJson(r.out, "dfo_eval stdout");
  EXPECT_NEAR(j["scale"].AsNumber() * 1e300, 1.0, 1e-12);
  EXPECT_LT(j["ate_rmse"].AsNumber(), 1e-9);
  // The other way round: a ground truth of 1e200, errors of that size stay finite.
  r = RunEval("traj --json --gt " +
              WriteTum(dir + "/gt_1e200.txt", 20,
                       [&](int i) {
                         return Eigen::Vector3d(1e200 * curve(i) +
                                                Eigen::Vector3d(0, 1e199 * (i % 2), 0));
                       }) +
              " --est " + gt);
  ASSERT_EQ(r.status, 0) << r.err;
  const io::JsonValue big = io::ParseJson(r.out, "dfo_eval stdout");
  EXPECT_GT(big["scale"].AsNumber(), 1e199);
  EXPECT_LT(big["scale"].AsNumber(), 1e201);
  EXPECT_GT(big["ate_rmse"].AsNumber(), 1e197);
  EXPECT_TRUE(std::isfinite(big["ate_rmse"].AsNumber()));

  const std::string head = "cannot evaluate ";
  const auto expect_failure = [&](const std::string& est, const std::string& fragment) {
    ExpectCleanFailure(RunEval("traj --gt " + gt + " --est " + est),
                       head + est + " against " + gt + ": " + fragment);
  };
  expect_failure(WriteTum(dir + "/same.txt", 20, [](int) { return Eigen::Vector3d(1, 2, 3); }),
                 "all 20 estimate positions are identical");
  expect_failure(
      WriteTum(dir + "/line.txt", 20, [](int i) { return Eigen::Vector3d(i, 2.0 * i, 3.0 * i); }),
      "the 20 estimate positions lie on one line");
  expect_failure(WriteTum(dir + "/mix.txt", 20,
                          [&](int i) { return i == 5 ? Eigen::Vector3d(1e300, 1, 2) : curve(i); }),
                 "the 20 estimate positions lie on one line (collinear within double precision");
  // 1e-300 against 1e300: each fine on its own, but the scale between them is 1e600.
  const std::string tiny =
      WriteTum(dir + "/tiny.txt", 20, [&](int i) { return Eigen::Vector3d(1e-300 * curve(i)); });
  const std::string huge =
      WriteTum(dir + "/huge.txt", 20, [&](int i) { return Eigen::Vector3d(1e300 * curve(i)); });
  ExpectCleanFailure(RunEval("traj --gt " + huge + " --est " + tiny),
                     "Sim3 scale from the estimate to the ground-truth positions is about 1e600");
  const std::string two = WriteTum(dir + "/two.txt", 2, curve);
  ExpectCleanFailure(RunEval("traj --gt " + two + " --est " + two),
                     "Umeyama alignment needs at least 3 point pairs (not all on one line), got 2");
  // Values beyond the double range are the reader's error, naming file and line.
  std::ofstream(dir + "/inf.txt") << "0.0 1 2 3 0 0 0 1\n1.0 1e400 2 3 0 0 0 1\n";
  ExpectCleanFailure(RunEval("traj --gt " + gt + " --est " + dir + "/inf.txt"),
                     dir + "/inf.txt:2: number 2 is '1e400', expected a finite value");
}

TEST(DfoEval, KittiReferenceAnswersThroughTheExecutable) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  const std::string dir = test::SharedDataDir() + "/reference_trajectories";
  CommandResult r = RunEval("traj --gt " + dir + "/KITTI_00_gt.txt --est " + dir +
                            "/KITTI_00_ORB.txt --format kitti --align se3 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  io::JsonValue j = io::ParseJson(r.out, "dfo_eval stdout");
  EXPECT_EQ(j["num_poses"].AsInt(), 4541);
  EXPECT_EQ(j["scale"].AsNumber(), 1.0);
  EXPECT_NEAR(j["ate_rmse"].AsNumber(), 1.303450, 1e-4);
  EXPECT_NEAR(j["ate_mean"].AsNumber(), 1.156997, 1e-4);
  EXPECT_NEAR(j["ate_median"].AsNumber(), 1.065625, 1e-4);
  EXPECT_NEAR(j["ate_max"].AsNumber(), 3.587949, 1e-4);
  // A 3.7 km drive: every KITTI segment length fits. ORB-SLAM2 (stereo) reports 0.70 % and
  // 0.25 deg/100 m on sequence 00; these are its poses.
  EXPECT_NEAR(j["kitti_t_rel_pct"].AsNumber(), 0.70, 0.01);
  EXPECT_NEAR(j["kitti_r_rel_deg_per_100m"].AsNumber(), 0.25, 0.01);
  EXPECT_TRUE(j["snippet_ate_mean"].IsNumber());

  r = RunEval("traj --gt " + dir + "/KITTI_00_gt.txt --est " + dir +
              "/KITTI_00_SPTAM.txt --align se3 --json");  // format detected
  ASSERT_EQ(r.status, 0) << r.err;
  j = io::ParseJson(r.out, "dfo_eval stdout");
  EXPECT_NEAR(j["ate_rmse"].AsNumber(), 3.738488, 1e-4);
}

TEST(DfoEval, TumAssociationThroughTheExecutable) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  const std::string dir = test::SharedDataDir() + "/reference_trajectories";
  const std::string files = " --gt " + dir + "/freiburg1_xyz-groundtruth.txt --est " + dir +
                            "/freiburg1_xyz-rgbdslam.txt --format tum";
  CommandResult r = RunEval("traj" + files + " --align se3 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  io::JsonValue j = io::ParseJson(r.out, "dfo_eval stdout");
  // 788 estimated poses, 785 have a ground-truth stamp within 10 ms.
  EXPECT_EQ(j["num_poses"].AsInt(), 785);
  EXPECT_GT(j["ate_rmse"].AsNumber(), 0.005);
  EXPECT_LT(j["ate_rmse"].AsNumber(), 0.03);
  EXPECT_TRUE(j["kitti_t_rel_pct"].IsNull());
  // A tighter window keeps fewer pairs; a zero-width one none at all (a clear error).
  r = RunEval("traj" + files + " --max-diff 0.002 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_LT(io::ParseJson(r.out)["num_poses"].AsInt(), 785);
  ExpectCleanFailure(RunEval("traj" + files + " --max-diff 0"), "no matching timestamps");
}

TEST(DfoEval, DepthKnownValuesAndPairingErrors) {
  const std::string dir = test::MakeTempDir("dfo_eval_depth");
  // Two images: one predicted 1.2x too far everywhere, one exact; stored at 256 units per metre.
  ImageF gt(16, 8, 1, 10.0f), far(16, 8, 1, 12.0f);
  gt(0, 0) = 0.0f;  // no ground truth here
  io::WriteDepthPng(dir + "/gt/a.png", gt, 256.0);
  io::WriteDepthPng(dir + "/gt/b.png", gt, 256.0);
  io::WriteDepthPng(dir + "/pred/a.png", far, 256.0);
  io::WriteDepthPng(dir + "/pred/b.png", gt, 256.0);
  io::WriteDepthPng(dir + "/pred/extra.png", gt, 256.0);  // ignored
  CommandResult r = RunEval("depth --gt " + dir + "/gt --pred " + dir + "/pred --json");
  ASSERT_EQ(r.status, 0) << r.err;
  io::JsonValue j = io::ParseJson(r.out);
  EXPECT_EQ(j["num_images"].AsInt(), 2);
  EXPECT_EQ(j["num_pixels"].AsInt(), 2 * 127);
  EXPECT_NEAR(j["abs_rel"].AsNumber(), 0.5 * 0.2, 1e-9);  // mean over images
  EXPECT_NEAR(j["rmse"].AsNumber(), 0.5 * 2.0, 1e-9);
  EXPECT_NEAR(j["a1"].AsNumber(), 1.0, 1e-12);

  // Median scaling removes the 1.2 factor of image a.
  r = RunEval("depth --gt " + dir + "/gt --pred " + dir + "/pred --median-scaling --json");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NEAR(io::ParseJson(r.out)["abs_rel"].AsNumber(), 0.0, 1e-6);
  // Per-image ratios 1 / 1.2 and 1: mean 11 / 12, population deviation 1 / 12.
  EXPECT_NEAR(io::ParseJson(r.out)["median_scale_cv"].AsNumber(), 1.0 / 11.0, 1e-3);

  // The per-image CSV: raw medians, their ratio, and the errors after the scaling asked for.
  io::WriteDepthPng(dir + "/gt/c.png", ImageF(16, 8, 1, 0.0f), 256.0);  // no ground truth
  io::WriteDepthPng(dir + "/pred/c.png", gt, 256.0);
  r = RunEval("depth --gt " + dir + "/gt --pred " + dir + "/pred --per-image " + dir +
              "/out/images.csv");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("1 without valid ground truth skipped"), std::string::npos) << r.out;
  EXPECT_EQ(io::ReadWholeFile(dir + "/out/images.csv", "per-image CSV", io::kMaxTextFileBytes),
            "image,pixels,median_gt_m,median_pred_m,median_gt_over_pred,abs_rel,rmse_log,a1\n"
            "a.png,127,10.0000,12.0000,0.83333,0.20000,0.18232,1.00000\n"
            "b.png,127,10.0000,10.0000,1.00000,0.00000,0.00000,1.00000\n"
            "c.png,0,,,,,,\n");
  r = RunEval("depth --gt " + dir + "/gt --pred " + dir + "/pred --median-scaling --per-image " +
              dir + "/out/images.csv");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(io::ReadWholeFile(dir + "/out/images.csv", "per-image CSV", io::kMaxTextFileBytes)
                .find("a.png,127,10.0000,12.0000,0.83333,0.00000,0.00000,1.00000\n"),
            std::string::npos);
  ExpectCleanFailure(
      RunEval("depth --gt " + dir + "/gt --pred " + dir + "/pred --per-image " + dir + "/gt"),
      "per-image CSV " + dir + "/gt: cannot be written");
  std::filesystem::remove(dir + "/gt/c.png");

  std::filesystem::remove(dir + "/pred/b.png");
  ExpectCleanFailure(RunEval("depth --gt " + dir + "/gt --pred " + dir + "/pred"),
                     "no prediction for ground truth " + dir + "/gt/b.png");
  io::WriteDepthPng(dir + "/pred/b.png", ImageF(8, 8, 1, 10.0f), 256.0);
  const CommandResult size = RunEval("depth --gt " + dir + "/gt --pred " + dir + "/pred");
  ExpectCleanFailure(size, dir + "/gt/b.png is 16x8");
  EXPECT_NE(size.err.find(dir + "/pred/b.png is 8x8"), std::string::npos) << size.err;
}

// stereo-depth on a synthetic sequence written by dfo_synth: the depth maps it finds from the
// ground-truth poses match the sequence's true depth (depth_0/) where it is confident, are named
// as the images, and come with pictures; bad ranges and missing poses are one clear line.
TEST(DfoEval, StereoDepthFromGroundTruthPosesMatchesTheTrueDepth) {
  const std::string data = test::CopyOfSyntheticSequence(DFO_SYNTH_EXE, 30, "dfo_eval_stereo");
  const std::string out = data + "/reference";
  CommandResult r = RunEval("stereo-depth --path " + data +
                            " --sequence 00 --frames 10-29 --every 10 --output " + out);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("wrote 2 depth maps"), std::string::npos) << r.out;
  for (const char* name : {"000010.png", "000020.png", "pictures/000010.png"}) {
    EXPECT_TRUE(std::filesystem::exists(out + "/" + name)) << name;
  }
  r = RunEval("depth --gt " + out + " --pred " + data + "/sequences/00/depth_0 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const io::JsonValue j = io::ParseJson(r.out, "dfo_eval stdout");
  EXPECT_EQ(j["num_images"].AsInt(), 2);
  EXPECT_GT(j["num_pixels"].AsInt(), 10000);
  // Share within 1.25x of the truth: 0.936 measured. Of the confident pixels about 5 % are off
  // by more (occlusion edges, repeated texture) and 1.7 % are sky, which the renderer leaves
  // without depth (dfo_eval depth counts them at its minimum depth).
  EXPECT_GT(j["a1"].AsNumber(), 0.9);

  ExpectCleanFailure(
      RunEval("stereo-depth --path " + data + " --sequence 00 --frames 40-50 " + "--output " + out),
      "30 frames");
  ExpectCleanFailure(
      RunEval("stereo-depth --path " + data + " --sequence 00 --frames 9 " + "--output " + out),
      "--frames = '9'");
  ExpectCleanFailure(
      RunEval("stereo-depth --path " + data + " --sequence 00 --max-depth 1 --output " + out),
      "max_depth_m = 1");
  // A cost volume beyond 2 GiB (4096 depths at 4096 x 4096) is refused before it is allocated.
  ExpectCleanFailure(RunEval("stereo-depth --path " + data +
                             " --sequence 00 --depths 4096 --size 4096x4096 --output " + out),
                     "4096 depths (--depths) x 4096 x 4096 pixels (--size)");
  std::filesystem::remove(data + "/poses/00.txt");
  ExpectCleanFailure(
      RunEval("stereo-depth --path " + data + " --sequence 00 --frames 10-10 " + "--output " + out),
      "ground-truth pose");
}

}  // namespace
}  // namespace dfo
