#include "dfo_io/trajectory_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "dfo_core/alignment.h"
#include "dfo_core/error.h"
#include "dfo_core/metrics.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

std::string WriteText(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// Runs `fn`, expects an InputError whose message names the file and contains every fragment.
template <typename Fn>
void ExpectInputError(Fn fn, const std::string& path, const std::vector<std::string>& fragments) {
  try {
    fn();
    ADD_FAILURE() << "no InputError for " << path;
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    for (const auto& f : fragments) EXPECT_NE(what.find(f), std::string::npos) << what;
  }
}

const char* kIdentity = "1 0 0 0 0 1 0 0 0 0 1 0\n";

TEST(TrajectoryFormat, ParsesNames) {
  EXPECT_EQ(ParseTrajectoryFormat("kitti"), TrajectoryFormat::kKitti);
  EXPECT_EQ(ParseTrajectoryFormat("tum"), TrajectoryFormat::kTum);
  EXPECT_EQ(TrajectoryFormatName(TrajectoryFormat::kTum), "tum");
  EXPECT_THROW(ParseTrajectoryFormat("euroc"), InputError);
}

TEST(KittiReader, ReadsPosesAndDefaultOrGivenTimestamps) {
  const std::string dir = test::MakeTempDir("kitti_read");
  const std::string path = WriteText(
      dir, "poses.txt", std::string(kIdentity) + "\n# comment\n0 -1 0 1.5  1 0 0 -2  0 0 1 3.25\n");
  const Trajectory t = ReadKittiTrajectory(path);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].timestamp_ns, 0);
  EXPECT_EQ(t[1].timestamp_ns, 1000000000);
  EXPECT_LT((t[1].world_from_cam.translation() - Eigen::Vector3d(1.5, -2, 3.25)).norm(), 1e-15);
  EXPECT_NEAR(t[1].world_from_cam.so3().Angle(), M_PI / 2, 1e-12);
  const std::vector<int64_t> stamps = {5, 17};
  EXPECT_EQ(ReadKittiTrajectory(path, &stamps)[1].timestamp_ns, 17);
  const std::vector<int64_t> wrong = {5};
  ExpectInputError([&] { ReadKittiTrajectory(path, &wrong); }, path, {"2 poses", "1 timestamps"});
}

TEST(KittiReader, EveryErrorNamesFileAndLine) {
  const std::string dir = test::MakeTempDir("kitti_errors");
  ExpectInputError([&] { ReadKittiTrajectory(dir + "/missing.txt"); }, dir + "/missing.txt",
                   {"not found"});
  std::string p = WriteText(dir, "count.txt", std::string(kIdentity) + "1 0 0 0 0 1 0 0 0 0 1\n");
  ExpectInputError([&] { ReadKittiTrajectory(p); },
                   p + ":2:", {"pose line with 11 numbers, expected 12"});
  p = WriteText(dir, "token.txt", std::string(kIdentity) + kIdentity + "1 0 0 x 0 1 0 0 0 0 1 0\n");
  ExpectInputError([&] { ReadKittiTrajectory(p); }, p + ":3:", {"'x'", "expected a number"});
  p = WriteText(dir, "nan.txt", "1 0 0 nan 0 1 0 0 0 0 1 0\n");
  ExpectInputError([&] { ReadKittiTrajectory(p); }, p + ":1:", {"finite"});
  p = WriteText(dir, "inf.txt", "1 0 0 0 0 1 0 inf 0 0 1 0\n");
  ExpectInputError([&] { ReadKittiTrajectory(p); }, p + ":1:", {"finite"});
  p = WriteText(dir, "skew.txt", std::string(kIdentity) + "1 0.1 0 0 0 1 0 0 0 0 1 0\n");
  ExpectInputError([&] { ReadKittiTrajectory(p); }, p + ":2:", {"not orthonormal"});
  p = WriteText(dir, "mirror.txt", "1 0 0 0 0 1 0 0 0 0 -1 0\n");  // det = -1
  ExpectInputError([&] { ReadKittiTrajectory(p); }, p + ":1:", {"det = -1"});
}

TEST(KittiReader, ReorthonormalisesRotationsPrintedWithFewDigits) {
  const std::string dir = test::MakeTempDir("kitti_ortho");
  // A rotation printed with 7 significant digits, ~1e-7 from orthonormal.
  const Eigen::Matrix3d R = SO3d::Exp(Eigen::Vector3d(0.3, -0.2, 0.9)).Matrix();
  char line[512];
  std::snprintf(line, sizeof(line), "%.6e %.6e %.6e 1 %.6e %.6e %.6e 2 %.6e %.6e %.6e 3\n", R(0, 0),
                R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2));
  const std::string p = WriteText(dir, "rounded.txt", line);
  const Trajectory t = ReadKittiTrajectory(p);
  const Eigen::Matrix3d Rr = t[0].world_from_cam.rotationMatrix();
  EXPECT_LT((Rr.transpose() * Rr - Eigen::Matrix3d::Identity()).norm(), 1e-14);
  EXPECT_LT((Rr - R).norm(), 1e-6);
}

TEST(TumReader, ReadsAndChecks) {
  const std::string dir = test::MakeTempDir("tum_read");
  std::string p = WriteText(dir, "ok.txt",
                            "# timestamp tx ty tz qx qy qz qw\n\n"
                            "1305031102.160407 1 2 3 0 0 0 1\n"
                            "1305031102.194330 1 2 3.5 0 0 0.7071068 0.7071068\n");
  const Trajectory t = ReadTumTrajectory(p);
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t[0].timestamp_ns, 1305031102160407000LL);  // exact, no double rounding
  EXPECT_EQ(t[1].timestamp_ns, 1305031102194330000LL);
  EXPECT_NEAR(t[1].world_from_cam.so3().Angle(), M_PI / 2, 1e-6);
  EXPECT_EQ(ReadTrajectory(p, TrajectoryFormat::kTum).size(), 2u);

  ExpectInputError([&] { ReadTumTrajectory(dir + "/none.txt"); }, dir + "/none.txt", {"not found"});
  p = WriteText(dir, "count.txt", "0 1 2 3 0 0 0 1\n1 1 2 3 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(p); }, p + ":2:", {"7 numbers, expected 8"});
  p = WriteText(dir, "token.txt", "0 1 2 3 0 0 0 1\n1 1 2 three 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(p); }, p + ":2:", {"'three'"});
  p = WriteText(dir, "nan.txt", "0 1 2 3 0 0 0 1\n1 1 NaN 3 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(p); }, p + ":2:", {"finite"});
  p = WriteText(dir, "quat.txt", "# header\n0 1 2 3 0 0 0 1\n1 1 2 3 0 0 0.5 0.5\n");
  ExpectInputError([&] { ReadTumTrajectory(p); }, p + ":3:", {"norm", "0.707"});
  p = WriteText(dir, "back.txt", "0.5 1 2 3 0 0 0 1\n0.7 1 2 3 0 0 0 1\n0.6 1 2 3 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(p); }, p + ":3:", {"does not increase", "line 2"});
  p = WriteText(dir, "dup.txt", "0.5 1 2 3 0 0 0 1\n0.5 1 2 3 0 0 0 1\n");
  ExpectInputError([&] { ReadTumTrajectory(p); }, p + ":2:", {"does not increase"});
}

TEST(TimestampText, ParsesAndFormatsExactly) {
  int64_t ns = 0;
  ASSERT_TRUE(ParseSecondsToNs("1305031102.160407", &ns));
  EXPECT_EQ(ns, 1305031102160407000LL);
  ASSERT_TRUE(ParseSecondsToNs("-0.5", &ns));
  EXPECT_EQ(ns, -500000000);
  ASSERT_TRUE(ParseSecondsToNs("1.0000000005", &ns));  // rounds on the tenth decimal
  EXPECT_EQ(ns, 1000000001);
  ASSERT_TRUE(ParseSecondsToNs("2.5e-3", &ns));
  EXPECT_EQ(ns, 2500000);
  ASSERT_TRUE(ParseSecondsToNs(".25", &ns));
  EXPECT_EQ(ns, 250000000);
  EXPECT_FALSE(ParseSecondsToNs("abc", &ns));
  EXPECT_FALSE(ParseSecondsToNs("1e30", &ns));
  EXPECT_EQ(FormatNsAsSeconds(1305031102160407000LL), "1305031102.160407");
  EXPECT_EQ(FormatNsAsSeconds(1000000001), "1.000000001");
  EXPECT_EQ(FormatNsAsSeconds(-500000000), "-0.500000");
  EXPECT_EQ(FormatNsAsSeconds(0), "0.000000");
}

TEST(ReadTimestamps, ReadsTimesFile) {
  const std::string dir = test::MakeTempDir("times");
  const std::string p = WriteText(dir, "times.txt", "0.000000e+00\n1.036815e-01\n\n2.0\n");
  const std::vector<int64_t> t = ReadTimestamps(p);
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[1], 103681500);
  const std::string bad = WriteText(dir, "bad.txt", "0.1\n0.2 0.3\n");
  ExpectInputError([&] { ReadTimestamps(bad); }, bad + ":2:", {"expected 1"});
}

Trajectory RandomTrajectory(int n) {
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 1.0);
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    t.Add(1305031102000000000LL + i * 33333333LL + (i % 7),
          SE3d(SO3d::Exp(Eigen::Vector3d(noise(rng), noise(rng), noise(rng))),
               Eigen::Vector3d(100 * noise(rng), noise(rng), 1e-3 * noise(rng))));
  }
  return t;
}

TEST(TrajectoryWriters, RoundTripBothFormatsAndCreateFolders) {
  const std::string dir = test::MakeTempDir("traj_roundtrip");
  const Trajectory t = RandomTrajectory(50);

  const std::string tum = dir + "/new/sub/est.txt";
  WriteTumTrajectory(tum, t);
  const Trajectory tum_back = ReadTumTrajectory(tum);
  ASSERT_EQ(tum_back.size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(tum_back[i].timestamp_ns, t[i].timestamp_ns);
    EXPECT_EQ(tum_back[i].world_from_cam.translation(), t[i].world_from_cam.translation());
    EXPECT_LT(
        tum_back[i].world_from_cam.quaternion().angularDistance(t[i].world_from_cam.quaternion()),
        1e-14);
  }

  const std::string kitti = dir + "/other/est_kitti.txt";
  WriteTrajectory(kitti, t, TrajectoryFormat::kKitti);
  std::vector<int64_t> stamps;
  for (const auto& p : t) stamps.push_back(p.timestamp_ns);
  const Trajectory kitti_back = ReadKittiTrajectory(kitti, &stamps);
  ASSERT_EQ(kitti_back.size(), t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    EXPECT_EQ(kitti_back[i].timestamp_ns, t[i].timestamp_ns);
    EXPECT_EQ(kitti_back[i].world_from_cam.translation(), t[i].world_from_cam.translation());
    EXPECT_LT((kitti_back[i].world_from_cam.rotationMatrix() - t[i].world_from_cam.rotationMatrix())
                  .norm(),
              1e-14);
  }
  EXPECT_THROW(WriteKittiTrajectory("/proc/definitely/not/writable.txt", t), InputError);
}

TEST(ReferenceTrajectories, RealFilesReadAndAssociate) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  const std::string dir = test::SharedDataDir() + "/reference_trajectories";
  const Trajectory gt = ReadKittiTrajectory(dir + "/KITTI_00_gt.txt");
  EXPECT_EQ(gt.size(), 4541u);
  const Trajectory tum_gt = ReadTumTrajectory(dir + "/freiburg1_xyz-groundtruth.txt");
  const Trajectory tum_est = ReadTumTrajectory(dir + "/freiburg1_xyz-rgbdslam.txt");
  EXPECT_EQ(tum_gt.size(), 3000u);  // 3003 lines less 3 header lines
  EXPECT_EQ(tum_est.size(), 788u);  // 1 header line
}

// The evo known answers: KITTI 00 ORB-SLAM and S-PTAM against ground truth, SE(3) Umeyama
// alignment, APE translation part (evo's stored test results).
TEST(ReferenceTrajectories, KittiAteMatchesEvo) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  const std::string dir = test::SharedDataDir() + "/reference_trajectories";
  const Trajectory gt = ReadKittiTrajectory(dir + "/KITTI_00_gt.txt");
  const Trajectory orb = ReadKittiTrajectory(dir + "/KITTI_00_ORB.txt");
  const Trajectory sptam = ReadKittiTrajectory(dir + "/KITTI_00_SPTAM.txt");
  TrajectoryAlignmentOptions options;
  options.type = AlignmentType::kSe3;
  const AteResult ate_orb = ComputeAte(gt, AlignTrajectory(orb, gt, options).aligned_estimate);
  EXPECT_EQ(ate_orb.errors.size(), 4541u);
  EXPECT_NEAR(ate_orb.stats.rmse, 1.303450, 1e-4);
  EXPECT_NEAR(ate_orb.stats.mean, 1.156997, 1e-4);
  EXPECT_NEAR(ate_orb.stats.median, 1.065625, 1e-4);
  EXPECT_NEAR(ate_orb.stats.max, 3.587949, 1e-4);
  EXPECT_NEAR(ate_orb.stats.min, 0.069313, 1e-4);
  const AteResult ate_sptam = ComputeAte(gt, AlignTrajectory(sptam, gt, options).aligned_estimate);
  EXPECT_NEAR(ate_sptam.stats.rmse, 3.738488, 1e-4);
}

// TUM fr1/xyz: RGBD-SLAM's estimate against motion capture, associated by nearest timestamp
// within 10 ms (evo's default).
TEST(ReferenceTrajectories, TumAssociationAndAte) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  const std::string dir = test::SharedDataDir() + "/reference_trajectories";
  const Trajectory gt = ReadTumTrajectory(dir + "/freiburg1_xyz-groundtruth.txt");
  const Trajectory est = ReadTumTrajectory(dir + "/freiburg1_xyz-rgbdslam.txt");
  const auto pairs = AssociateByTimestamp(gt, est, 10000000);
  // The estimate is the shorter trajectory: at most one pair per estimated pose.
  EXPECT_GT(pairs.size(), 700u);
  EXPECT_LE(pairs.size(), est.size());
  for (const auto& [i, j] : pairs) {
    EXPECT_LE(std::llabs(gt[i].timestamp_ns - est[j].timestamp_ns), 10000000);
  }
  Trajectory gt_assoc, est_assoc;
  ApplyAssociation(pairs, gt, est, &gt_assoc, &est_assoc);
  const AteResult ate = ComputeAte(gt_assoc, AlignTrajectory(est_assoc, gt_assoc).aligned_estimate);
  // RGBD-SLAM on fr1/xyz is a few centimetres off (its published ATE is ~1-3 cm).
  EXPECT_GT(ate.stats.rmse, 0.003);
  EXPECT_LT(ate.stats.rmse, 0.05);
}

}  // namespace
}  // namespace dfo::io
