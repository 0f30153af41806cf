// The "use dfo from your own program" example (apps/example/odometry_example.cc, README): runs
// the built dfo_example on a short synthetic image folder with the committed default model and
// checks that it prints a pose for every frame that follows the true path.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "apps/common/evaluation.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_core/trajectory.h"
#include "dfo_io/synth_writer.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

#ifdef DFO_EXAMPLE_EXE
TEST(OdometryExample, PrintsAPoseForEveryFrameAlongTheTruePath) {
  SyntheticOptions synth;
  synth.seed = 1;  // held out of training
  synth.num_frames = 40;
  const SyntheticSequence sequence(synth);
  const std::string root = test::MakeTempDir("odometry_example");
  io::SynthWriteOptions write;
  write.output_dir = root;
  write.write_rgb = false;
  write.write_depth = false;
  io::WriteSyntheticSequence(sequence, write);

  const PinholeCamera& c = sequence.camera();
  std::ostringstream args;
  args.precision(17);
  args << root << "/sequences/00/image_0 " << c.fx << " " << c.fy << " " << c.cx << " " << c.cy
       << " " << test::SourceDir() << "/models/default.dfo";
  const test::CommandResult r = test::RunCommand(DFO_EXAMPLE_EXE, args.str());
  ASSERT_EQ(r.status, 0) << r.err;

  Trajectory estimate, truth;
  std::istringstream lines(r.out);
  std::string line;
  int lost = 0;
  while (std::getline(lines, line)) {
    std::istringstream in(line);
    int index = -1;
    std::string status;
    double t[3], q[4];
    ASSERT_TRUE(in >> index >> status >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3])
        << line;
    ASSERT_EQ(index, static_cast<int>(estimate.size())) << line;
    lost += status == "lost" ? 1 : 0;
    const SE3d pose(Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized(),
                    Eigen::Vector3d(t[0], t[1], t[2]));
    ASSERT_TRUE(pose.translation().allFinite()) << line;
    estimate.Add(index, pose);
    truth.Add(index, sequence.WorldFromCam(index));
  }
  ASSERT_EQ(estimate.size(), static_cast<size_t>(synth.num_frames)) << r.out << r.err;
  EXPECT_EQ(lost, 0) << r.out;
  apps::TrajectoryEvaluationOptions sim3;
  sim3.alignment = AlignmentType::kSim3;
  const apps::TrajectoryEvaluation e = apps::EvaluateTrajectory(truth, estimate, sim3);
  // The example runs the library with its defaults; its path must follow the true one (a
  // standing still or reversed estimate leaves an ATE near the path's own spread).
  EXPECT_LT(e.ate.stats.rmse, 0.1 * e.gt_path_length_m)
      << "Sim3 ATE " << e.ate.stats.rmse << " m over " << e.gt_path_length_m << " m";
  std::printf("[ figures  ] dfo_example: %zu frames, Sim3 ATE %.3f m over %.1f m\n",
              estimate.size(), e.ate.stats.rmse, e.gt_path_length_m);
}
#endif

}  // namespace
}  // namespace dfo
