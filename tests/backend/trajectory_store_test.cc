#include "dfo_backend/trajectory_store.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dfo_core/error.h"

namespace dfo {
namespace {

SE3d Pose(double tx, double yaw_rad, double tz = 0.0) {
  return SE3d(SO3d::Exp(Eigen::Vector3d(0.0, yaw_rad, 0.0)), Eigen::Vector3d(tx, 0.0, tz));
}

void ExpectPoseNear(const SE3d& a, const SE3d& b, double tol = 1e-12) {
  EXPECT_TRUE(a.Matrix().isApprox(b.Matrix(), tol)) << a.Matrix() << "\nvs\n" << b.Matrix();
}

// Frames 0..5: 0 keyframe, 1-2 tracked against 0, 3 promoted, 4-5 tracked against 3.
TrajectoryStore MakeStore() {
  TrajectoryStore s;
  s.AddKeyframe(0, 0, Pose(0.0, 0.0));
  s.AddFrame(1, 10, 0, Pose(1.0, 0.01));
  s.AddFrame(2, 20, 0, Pose(2.0, 0.02));
  s.AddFrame(3, 30, 0, Pose(3.0, 0.03));
  s.PromoteToKeyframe(3);
  s.AddFrame(4, 40, 3, Pose(1.0, -0.01));
  s.AddFrame(5, 50, 3, Pose(2.0, -0.02, 0.5));
  return s;
}

TEST(TrajectoryStoreTest, FrontendPosesComposeOnKeyframes) {
  const TrajectoryStore s = MakeStore();
  EXPECT_EQ(s.num_frames(), 6);
  EXPECT_EQ(s.num_keyframes(), 2);
  EXPECT_EQ(s.KeyframeIndices(), (std::vector<int>{0, 3}));
  ExpectPoseNear(s.FrontendPose(2), Pose(2.0, 0.02));
  ExpectPoseNear(s.FrontendPose(5), Pose(3.0, 0.03) * Pose(2.0, -0.02, 0.5));
  // Untouched by the backend, both trajectories are the same.
  const Trajectory f = s.FrontendTrajectory(), w = s.WindowedTrajectory();
  ASSERT_EQ(f.size(), 6u);
  ASSERT_EQ(w.size(), 6u);
  for (size_t i = 0; i < f.size(); ++i) {
    EXPECT_EQ(f[i].timestamp_ns, static_cast<int64_t>(10 * i));
    ExpectPoseNear(f[i].world_from_cam, w[i].world_from_cam);
  }
}

TEST(TrajectoryStoreTest, MovingAKeyframeMovesItsFramesOnlyInTheWindowedTrajectory) {
  TrajectoryStore s = MakeStore();
  const SE3d moved = Pose(3.5, 0.1, 0.2);
  s.SetWindowedPose(3, moved);
  ExpectPoseNear(s.WindowedPose(3), moved);
  ExpectPoseNear(s.WindowedPose(4), moved * Pose(1.0, -0.01));
  ExpectPoseNear(s.WindowedPose(5), moved * Pose(2.0, -0.02, 0.5));
  ExpectPoseNear(s.WindowedPose(2), Pose(2.0, 0.02));  // tracked against keyframe 0
  // The frontend-only trajectory keeps the frontend's keyframe pose.
  ExpectPoseNear(s.FrontendPose(4), Pose(3.0, 0.03) * Pose(1.0, -0.01));
  const Trajectory kf = s.KeyframeTrajectory(true);
  ASSERT_EQ(kf.size(), 2u);
  ExpectPoseNear(kf[1].world_from_cam, moved);
  ExpectPoseNear(s.KeyframeTrajectory(false)[1].world_from_cam, Pose(3.0, 0.03));
}

TEST(TrajectoryStoreTest, NewKeyframeStartsFromTheWindowedPoseOfItsKeyframe) {
  TrajectoryStore s = MakeStore();
  const SE3d moved = Pose(3.5, 0.1);
  s.SetWindowedPose(3, moved);
  s.AddFrame(6, 60, 3, Pose(3.0, 0.0));
  s.PromoteToKeyframe(6);
  ExpectPoseNear(s.WindowedPose(6), moved * Pose(3.0, 0.0));
  ExpectPoseNear(s.FrontendPose(6), Pose(3.0, 0.03) * Pose(3.0, 0.0));
  // A restart keyframe (after a loss) keeps its frontend relation to the previous keyframe.
  s.AddFrame(7, 70, 6, Pose(0.5, 0.0));
  const SE3d restart_frontend = s.FrontendPose(7);  // the frontend's last good pose
  s.AddKeyframe(8, 80, restart_frontend);
  ExpectPoseNear(s.FrontendPose(8), restart_frontend);
  ExpectPoseNear(s.WindowedPose(8), s.WindowedPose(7));
  EXPECT_TRUE(s.IsKeyframe(8));
  EXPECT_FALSE(s.IsKeyframe(7));
}

TEST(TrajectoryStoreTest, FrameWithoutKeyframeIsAbsolute) {
  TrajectoryStore s;
  s.AddFrame(0, 0, -1, Pose(0.0, 0.0));  // e.g. a lost first frame
  s.AddKeyframe(1, 10, Pose(0.0, 0.0));
  ExpectPoseNear(s.WindowedPose(0), Pose(0.0, 0.0));
  EXPECT_FALSE(s.IsKeyframe(0));
  EXPECT_TRUE(s.Contains(1));
  EXPECT_FALSE(s.Contains(2));
}

TEST(TrajectoryStoreTest, StepScaleScalesOnlyMarkedStepsAndOnlyInTheWindowedTrajectory) {
  TrajectoryStore s;
  s.AddKeyframe(0, 0, Pose(0.0, 0.0));
  s.SetWindowedStepScale(0, 1.5);  // at the keyframe's solve, before frames are tracked against it
  s.AddFrame(1, 10, 0, Pose(1.0, 0.01, 0.5), /*scale_step=*/true);
  s.AddFrame(2, 20, 0, Pose(2.0, 0.02), /*scale_step=*/false);  // e.g. tracked against the window
  s.AddFrame(3, 30, 0, Pose(3.0, 0.03), /*scale_step=*/true);
  const SE3d scaled(Pose(1.0, 0.01, 0.5).so3(), 1.5 * Pose(1.0, 0.01, 0.5).translation());
  ExpectPoseNear(s.WindowedPose(1), scaled);
  ExpectPoseNear(s.FrontendPose(1), Pose(1.0, 0.01, 0.5));
  ExpectPoseNear(s.WindowedPose(2), Pose(2.0, 0.02));
  // A promoted frame keeps its scaled step as its windowed pose; its own frames start from it.
  s.PromoteToKeyframe(3);
  ExpectPoseNear(s.WindowedPose(3), Pose(4.5, 0.03));
  ExpectPoseNear(s.FrontendPose(3), Pose(3.0, 0.03));
  s.AddFrame(4, 40, 3, Pose(1.0, 0.0), /*scale_step=*/true);
  ExpectPoseNear(s.WindowedPose(4), Pose(4.5, 0.03) * Pose(1.0, 0.0));  // 3's own scale is 1
  ExpectPoseNear(s.WindowedStep(1), scaled);
  ExpectPoseNear(s.WindowedStep(3), SE3d());  // a keyframe
  // A later change of a keyframe's scale applies to the frames added after it only: a step once
  // given out (e.g. published) stays.
  s.SetWindowedStepScale(3, 0.5);
  ExpectPoseNear(s.WindowedPose(4), Pose(4.5, 0.03) * Pose(1.0, 0.0));
  s.AddFrame(5, 50, 3, Pose(1.0, 0.0), /*scale_step=*/true);
  ExpectPoseNear(s.WindowedPose(5), Pose(4.5, 0.03) * Pose(0.5, 0.0));
  // rescale_added: the frames added with scale_step against the keyframe take the new scale as
  // well; the unmarked ones and promoted frames keep theirs.
  s.AddFrame(6, 60, 3, Pose(2.0, 0.0), /*scale_step=*/false);
  s.SetWindowedStepScale(3, 2.0, /*rescale_added=*/true);
  ExpectPoseNear(s.WindowedPose(4), Pose(4.5, 0.03) * Pose(2.0, 0.0));
  ExpectPoseNear(s.WindowedPose(5), Pose(4.5, 0.03) * Pose(2.0, 0.0));
  ExpectPoseNear(s.WindowedPose(6), Pose(4.5, 0.03) * Pose(2.0, 0.0));
  s.SetWindowedStepScale(0, 3.0, /*rescale_added=*/true);
  ExpectPoseNear(s.WindowedPose(1),
                 SE3d(Pose(1.0, 0.01, 0.5).so3(), 3.0 * Pose(1.0, 0.01, 0.5).translation()));
  ExpectPoseNear(s.WindowedPose(2), Pose(2.0, 0.02));
  ExpectPoseNear(s.WindowedPose(3), Pose(4.5, 0.03));           // promoted: kept
  EXPECT_THROW(s.SetWindowedStepScale(1, 2.0), InternalError);  // not a keyframe
  EXPECT_THROW(s.SetWindowedStepScale(0, 0.0), InternalError);
  EXPECT_THROW(s.SetWindowedStepScale(0, std::nan("")), InternalError);
}

TEST(TrajectoryStoreTest, ContractViolationsThrowInternalError) {
  TrajectoryStore s = MakeStore();
  EXPECT_THROW(s.AddFrame(5, 50, 3, SE3d()), InternalError);  // index not increasing
  EXPECT_THROW(s.AddFrame(6, 60, 4, SE3d()), InternalError);  // 4 is not a keyframe
  EXPECT_THROW(s.PromoteToKeyframe(4), InternalError);        // not the last frame
  EXPECT_THROW(s.SetWindowedPose(4, SE3d()), InternalError);  // not a keyframe
  EXPECT_THROW(s.WindowedPose(42), InternalError);            // unknown frame
}

}  // namespace
}  // namespace dfo
