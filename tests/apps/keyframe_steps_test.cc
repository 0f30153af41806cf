// tools/keyframe_steps.py (docs/window.md, "Keyframes and the sliding window"): on a constructed run whose
// windowed keyframe steps are each 6 cm too long along the travel, it reports exactly that, and
// nothing for the exact frontend. Skipped when /usr/bin/python3 with numpy is absent.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "dfo_core/trajectory.h"
#include "dfo_io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

bool HaveNumpy() { return std::system("/usr/bin/python3 -c 'import numpy' > /dev/null 2>&1") == 0; }

TEST(KeyframeStepsTool, ReportsTheScaleErrorOfKeyframeSteps) {
  if (!HaveNumpy()) GTEST_SKIP() << "/usr/bin/python3 with numpy is not installed";
  const std::string dir = test::MakeTempDir("keyframe_steps");
  // 10 frames 1 m apart along the camera's z axis; keyframes at 0, 3, 6, 9. The windowed
  // trajectory moves every keyframe (and the frames after it) 6 cm further than the last.
  Trajectory gt, frontend, windowed, keyframes;
  for (int i = 0; i < 10; ++i) {
    const int64_t t = i * 100000000LL;
    const SE3d truth(SO3d(), Eigen::Vector3d(0.0, 0.0, i));
    gt.Add(t, truth);
    frontend.Add(t, truth);
    windowed.Add(t, SE3d(SO3d(), Eigen::Vector3d(0.0, 0.0, i + 0.06 * (i / 3))));
    if (i % 3 == 0) keyframes.Add(t, windowed.poses().back().world_from_cam);
  }
  io::WriteKittiTrajectory(dir + "/gt.txt", gt);
  io::WriteKittiTrajectory(dir + "/frontend_kitti.txt", frontend);
  io::WriteKittiTrajectory(dir + "/windowed_kitti.txt", windowed);
  io::WriteTumTrajectory(dir + "/windowed_tum.txt", windowed);
  io::WriteTumTrajectory(dir + "/keyframes_tum.txt", keyframes);

  const std::string script = test::SourceDir() + "/tools/keyframe_steps.py";
  const test::CommandResult r =
      test::RunCommand("/usr/bin/python3", script + " " + dir + " " + dir + "/gt.txt");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("10 frames, 4 keyframes"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frontend  frame step error (m): rms 0.0000, into a keyframe 0.0000, "
                       "other steps 0.0000"),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("into a keyframe 0.0600, other steps 0.0000"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("along the travel: mean +0.0600 m, median |.| 0.0600 m (2.00% of the "
                       "median step 3.00 m); across: median 0.0000 m"),
            std::string::npos)
      << r.out;

  // A missing ground-truth file: one clear line, non-zero exit.
  const test::CommandResult bad =
      test::RunCommand("/usr/bin/python3", script + " " + dir + " " + dir + "/missing.txt");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find("missing.txt: cannot read a KITTI pose file"), std::string::npos)
      << bad.err;
}

}  // namespace
}  // namespace dfo
