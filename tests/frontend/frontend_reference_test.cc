// Tests of the frontend's reference policies: "external" (the caller switches through
// MakeLastFrameReference, as dfo_run's keyframe manager does) against "internal".
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_frontend/frontend.h"

namespace dfo {
namespace {

class FrontendReferenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SyntheticOptions options;
    options.num_frames = 24;
    const SyntheticSequence sequence(options);
    frames_ = new std::vector<Frame>();
    for (int i = 0; i < options.num_frames; ++i) {
      const SyntheticFrame s = sequence.RenderFrame(i);
      Frame f;
      f.index = s.index;
      f.timestamp_ns = s.timestamp_ns;
      f.image = s.gray;
      f.depth_m = s.depth;
      f.camera = sequence.camera();
      frames_->push_back(f);
    }
  }
  static void TearDownTestSuite() { delete frames_; }
  static FrontendOptions External() {
    FrontendOptions o;
    o.reference.policy = "external";
    return o;
  }
  static std::vector<Frame>* frames_;
};
std::vector<Frame>* FrontendReferenceTest::frames_ = nullptr;

// Without calls from outside, an external-policy frontend tracks every frame against frame 0.
TEST_F(FrontendReferenceTest, ExternalNeverSwitchesByItself) {
  Frontend frontend(External());
  for (int i = 0; i < 6; ++i) {
    const TrackedFrame t = frontend.Process((*frames_)[i]);
    EXPECT_EQ(t.reference_index, 0) << "frame " << i;
    EXPECT_EQ(t.is_new_reference, i == 0) << "frame " << i;
    if (i > 0) {
      EXPECT_NE(t.status, TrackingStatus::kLost) << "frame " << i;
    }
  }
}

// The internal rule replayed from outside gives bit-identical poses: MakeLastFrameReference
// switches exactly as the internal rule does.
TEST_F(FrontendReferenceTest, ExternalReplayOfTheInternalRuleIsIdentical) {
  Frontend internal(FrontendOptions{});
  Frontend external(External());
  int switches = 0;
  for (const Frame& frame : *frames_) {
    const TrackedFrame a = internal.Process(frame);
    const TrackedFrame b = external.Process(frame);
    ASSERT_EQ(a.status, b.status) << "frame " << frame.index;
    EXPECT_EQ(a.reference_index, b.reference_index) << "frame " << frame.index;
    EXPECT_EQ(a.world_from_cam.Matrix(), b.world_from_cam.Matrix()) << "frame " << frame.index;
    if (a.is_new_reference && a.status != TrackingStatus::kReference) {
      KeyframeData kf;
      ASSERT_TRUE(external.MakeLastFrameReference(&kf)) << "frame " << frame.index;
      EXPECT_EQ(kf.frame_index, frame.index);
      ++switches;
    }
  }
  EXPECT_GT(switches, 1);
}

TEST_F(FrontendReferenceTest, MakeLastFrameReferenceHandsOutTheKeyframe) {
  Frontend frontend(External());
  KeyframeData kf;
  EXPECT_FALSE(frontend.MakeLastFrameReference(&kf));  // no frame yet
  const TrackedFrame t0 = frontend.Process((*frames_)[0]);
  ASSERT_EQ(t0.status, TrackingStatus::kReference);
  ASSERT_TRUE(frontend.MakeLastFrameReference(&kf));  // already the reference: its data
  EXPECT_EQ(kf.frame_index, 0);
  frontend.Process((*frames_)[1]);
  const TrackedFrame t2 = frontend.Process((*frames_)[2]);
  ASSERT_TRUE(frontend.MakeLastFrameReference(&kf));
  EXPECT_EQ(kf.frame_index, 2);
  EXPECT_EQ(kf.timestamp_ns, (*frames_)[2].timestamp_ns);
  EXPECT_EQ(kf.world_from_cam.Matrix(), t2.world_from_cam.Matrix());
  const int levels = frontend.options().tracker.num_levels;
  ASSERT_EQ(kf.features.num_levels(), levels);
  ASSERT_EQ(kf.depth.num_levels(), levels);
  EXPECT_EQ(kf.features.levels[0].width, (*frames_)[2].camera.width);
  EXPECT_EQ(kf.features.levels[0].channels, 3);
  EXPECT_EQ(kf.depth.levels[1].width(), (*frames_)[2].camera.width / 2);
  EXPECT_GT(kf.depth.MeanDepth(0), 0.0);
  // A repeated call switches nothing and gives the same keyframe.
  KeyframeData again;
  ASSERT_TRUE(frontend.MakeLastFrameReference(&again));
  EXPECT_EQ(again.frame_index, 2);
  EXPECT_EQ(again.features.levels[0].data, kf.features.levels[0].data);
  const TrackedFrame t3 = frontend.Process((*frames_)[3]);
  EXPECT_EQ(t3.reference_index, 2);
  EXPECT_NE(t3.status, TrackingStatus::kLost);
  // The tracked pose relative to the new reference composes to the world pose.
  EXPECT_TRUE(
      (kf.world_from_cam * t3.ref_from_cam).Matrix().isApprox(t3.world_from_cam.Matrix(), 1e-9));
}

// A frame without usable depth cannot become the reference: the call refuses and tracking goes
// on against the old one; a lost frame is refused too.
TEST_F(FrontendReferenceTest, SparseDepthOrLostFrameIsRefused) {
  Frontend frontend(External());
  frontend.Process((*frames_)[0]);
  Frame no_depth = (*frames_)[1];
  no_depth.depth_m = ImageF(no_depth.image.width(), no_depth.image.height(), 1,
                            std::numeric_limits<float>::quiet_NaN());
  const TrackedFrame t1 = frontend.Process(no_depth);  // tracked: the reference has depth
  EXPECT_NE(t1.status, TrackingStatus::kLost);
  EXPECT_FALSE(frontend.MakeLastFrameReference(nullptr));
  const TrackedFrame t2 = frontend.Process((*frames_)[2]);
  EXPECT_EQ(t2.reference_index, 0);
  EXPECT_NE(t2.status, TrackingStatus::kLost);

  Frontend lost_first(External());
  Frame zero = (*frames_)[0];
  zero.depth_m = ImageF(zero.image.width(), zero.image.height(), 1, 0.0f);
  EXPECT_EQ(lost_first.Process(zero).status, TrackingStatus::kLost);
  EXPECT_FALSE(lost_first.MakeLastFrameReference(nullptr));
}

TEST(ReferenceOptionsTest, PolicyChecked) {
  FrontendOptions o;
  o.reference.policy = "keyframes";
  try {
    o.Check();
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("frontend.reference.policy = keyframes"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace dfo
