// EvaluateTrajectory (dfo_core/trajectory_evaluation.h): a library function, so a program that
// embeds dfo::Odometry gets dfo_eval's figures and warnings without the apps.
#include "dfo_core/trajectory_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

namespace dfo {
namespace {

// A curved 120 m path, 121 poses, 1 m apart, turning 0.5 deg per pose.
Trajectory CurvedPath() {
  Trajectory t;
  double yaw = 0.0;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int i = 0; i <= 120; ++i) {
    const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
    t.Add(i, SE3d(Eigen::Quaterniond(r), p));
    p += r * Eigen::Vector3d(0.0, 0.0, 1.0);
    yaw += 0.5 * M_PI / 180.0;
  }
  return t;
}

TEST(TrajectoryEvaluation, ASimilarCopyOfTheTruthHasNoErrorAndItsScale) {
  const Trajectory truth = CurvedPath();
  // The truth seen in another frame at 0.4 times its size.
  const Eigen::Matrix3d r = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  Trajectory estimate;
  for (size_t i = 0; i < truth.size(); ++i) {
    const SE3d& pose = truth[i].world_from_cam;
    estimate.Add(truth[i].timestamp_ns,
                 SE3d(Eigen::Quaterniond(r * pose.rotationMatrix()),
                      0.4 * (r * pose.translation()) + Eigen::Vector3d(5, -2, 1)));
  }
  const TrajectoryEvaluation e = EvaluateTrajectory(truth, estimate);
  EXPECT_LT(e.ate.stats.rmse, 1e-9);
  EXPECT_NEAR(e.alignment.transform.scale, 2.5, 1e-9);
  EXPECT_NEAR(e.gt_path_length_m, 120.0, 1e-9);
  EXPECT_LT(e.kitti.t_rel_pct, 1e-6);
  EXPECT_NEAR(ExplainedSpread(e), 1.0, 1e-12);
  EXPECT_TRUE(EvaluationWarnings(e).empty());
}

TEST(TrajectoryEvaluation, AnEstimateThatBarelyMovesIsWarnedAbout) {
  const Trajectory truth = CurvedPath();
  Trajectory estimate;
  for (size_t i = 0; i < truth.size(); ++i) {
    // Millimetre jitter around one place.
    const double k = static_cast<double>(i);
    const Eigen::Vector3d jitter(std::sin(1.7 * k), std::cos(2.3 * k), std::sin(0.9 * k));
    estimate.Add(truth[i].timestamp_ns, SE3d(Eigen::Quaterniond::Identity(), 1e-3 * jitter));
  }
  const TrajectoryEvaluation e = EvaluateTrajectory(truth, estimate);
  const std::vector<std::string> warnings = EvaluationWarnings(e);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("degenerate alignment", 0), 0u) << warnings[0];
  EXPECT_LT(ExplainedSpread(e), kMinExplainedSpread);
}

}  // namespace
}  // namespace dfo
