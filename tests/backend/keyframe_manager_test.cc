#include "dfo_backend/keyframe_manager.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dfo_core/error.h"

namespace dfo {
namespace {

// A frame tracked against keyframe `ref` with `ref_from_cam` = translation t along x and a
// rotation of `deg` degrees about y; reference mean depth 10 m, 100 points.
TrackedFrame Tracked(int index, int ref, double t_m, double deg = 0.0, double rmse = 0.1,
                     int inliers = 100) {
  TrackedFrame f;
  f.index = index;
  f.status = TrackingStatus::kOk;
  f.reference_index = ref;
  f.ref_from_cam = SE3d(SO3d::Exp(Eigen::Vector3d(0.0, deg * M_PI / 180.0, 0.0)),
                        Eigen::Vector3d(t_m, 0.0, 0.0));
  f.reference_parallax_depth = 10.0;
  f.num_points = 100;
  f.num_inliers = inliers;
  f.rmse = rmse;
  return f;
}

TrackedFrame Restart(int index) {
  TrackedFrame f;
  f.index = index;
  f.status = TrackingStatus::kReference;
  f.reference_index = index;
  f.is_new_reference = true;
  return f;
}

// A manager whose current keyframe is frame 0.
KeyframeManager Started(const KeyframeOptions& options) {
  KeyframeManager m(options);
  const KeyframeDecision d = m.Decide(Restart(0));
  EXPECT_TRUE(d.new_keyframe);
  EXPECT_EQ(d.reason, KeyframeReason::kRestart);
  m.AcceptKeyframe(0);
  return m;
}

TEST(KeyframeManagerTest, TranslationRatioRelativeToMeanDepth) {
  KeyframeOptions o;
  o.translation_ratio = 0.1;
  KeyframeManager m = Started(o);
  KeyframeDecision d = m.Decide(Tracked(1, 0, 0.9));  // 0.9 / 10 = 0.09
  EXPECT_FALSE(d.new_keyframe);
  EXPECT_NEAR(d.translation_ratio, 0.09, 1e-12);
  d = m.Decide(Tracked(2, 0, 1.1));  // 0.11 > 0.1
  EXPECT_TRUE(d.new_keyframe);
  EXPECT_EQ(d.reason, KeyframeReason::kTranslation);
  EXPECT_EQ(d.frames_since_keyframe, 2);
  // The same distance with a deeper keyframe is not enough.
  m.AcceptKeyframe(2);
  TrackedFrame deep = Tracked(3, 2, 1.1);
  deep.reference_parallax_depth = 20.0;
  EXPECT_FALSE(m.Decide(deep).new_keyframe);
}

TEST(KeyframeManagerTest, Rotation) {
  KeyframeOptions o;
  o.rotation_deg = 5.0;
  KeyframeManager m = Started(o);
  KeyframeDecision d = m.Decide(Tracked(1, 0, 0.0, 4.5));
  EXPECT_FALSE(d.new_keyframe);
  EXPECT_NEAR(d.rotation_deg, 4.5, 1e-9);
  d = m.Decide(Tracked(2, 0, 0.0, 5.5));
  EXPECT_TRUE(d.new_keyframe);
  EXPECT_EQ(d.reason, KeyframeReason::kRotation);
}

TEST(KeyframeManagerTest, ResidualGrowthRelativeToFirstFrameAfterKeyframe) {
  KeyframeOptions o;
  o.residual_ratio = 2.0;
  KeyframeManager m = Started(o);
  EXPECT_FALSE(m.Decide(Tracked(1, 0, 0.0, 0.0, 0.2)).new_keyframe);  // the first: 0.2
  KeyframeDecision d = m.Decide(Tracked(2, 0, 0.0, 0.0, 0.39));
  EXPECT_FALSE(d.new_keyframe);
  EXPECT_NEAR(d.residual_ratio, 1.95, 1e-12);
  d = m.Decide(Tracked(3, 0, 0.0, 0.0, 0.41));
  EXPECT_TRUE(d.new_keyframe);
  EXPECT_EQ(d.reason, KeyframeReason::kResidual);
  // After a new keyframe, the reference residual is the new first frame's.
  m.AcceptKeyframe(3);
  EXPECT_FALSE(m.Decide(Tracked(4, 3, 0.0, 0.0, 0.5)).new_keyframe);
  EXPECT_FALSE(m.Decide(Tracked(5, 3, 0.0, 0.0, 0.9)).new_keyframe);
  EXPECT_TRUE(m.Decide(Tracked(6, 3, 0.0, 0.0, 1.1)).new_keyframe);
}

TEST(KeyframeManagerTest, InlierRatio) {
  KeyframeOptions o;
  o.min_inlier_ratio = 0.5;
  KeyframeManager m = Started(o);
  KeyframeDecision d = m.Decide(Tracked(1, 0, 0.0, 0.0, 0.1, 50));
  EXPECT_FALSE(d.new_keyframe);
  EXPECT_NEAR(d.inlier_ratio, 0.5, 1e-12);
  d = m.Decide(Tracked(2, 0, 0.0, 0.0, 0.1, 49));
  EXPECT_TRUE(d.new_keyframe);
  EXPECT_EQ(d.reason, KeyframeReason::kInlierRatio);
}

TEST(KeyframeManagerTest, MaxInterval) {
  KeyframeOptions o;
  o.max_interval = 4;
  KeyframeManager m = Started(o);
  for (int i = 1; i < 4; ++i) EXPECT_FALSE(m.Decide(Tracked(i, 0, 0.0)).new_keyframe) << i;
  const KeyframeDecision d = m.Decide(Tracked(4, 0, 0.0));
  EXPECT_TRUE(d.new_keyframe);
  EXPECT_EQ(d.reason, KeyframeReason::kMaxInterval);
  EXPECT_EQ(d.frames_since_keyframe, 4);
}

TEST(KeyframeManagerTest, MinIntervalHoldsEveryRuleButRestart) {
  KeyframeOptions o;
  o.min_interval = 3;
  KeyframeManager m = Started(o);
  // Far, rotated, few inliers: still no keyframe on frames 1 and 2.
  EXPECT_FALSE(m.Decide(Tracked(1, 0, 5.0, 20.0, 0.1, 10)).new_keyframe);
  EXPECT_FALSE(m.Decide(Tracked(2, 0, 5.0, 20.0, 0.1, 10)).new_keyframe);
  EXPECT_TRUE(m.Decide(Tracked(3, 0, 5.0, 20.0, 0.1, 10)).new_keyframe);
  m.AcceptKeyframe(3);
  // A lost frame is never a keyframe; the frontend's restart right after it always is.
  TrackedFrame lost = Tracked(4, 3, 0.0);
  lost.status = TrackingStatus::kLost;
  EXPECT_FALSE(m.Decide(lost).new_keyframe);
  const KeyframeDecision d = m.Decide(Restart(5));
  EXPECT_TRUE(d.new_keyframe);
  EXPECT_EQ(d.reason, KeyframeReason::kRestart);
  m.AcceptKeyframe(5);
  EXPECT_EQ(m.keyframe_index(), 5);
  EXPECT_EQ(m.num_keyframes(), 3);
}

TEST(KeyframeManagerTest, RejectedKeyframeFiresAgainNextFrame) {
  KeyframeOptions o;
  KeyframeManager m = Started(o);
  EXPECT_TRUE(m.Decide(Tracked(1, 0, 2.0)).new_keyframe);
  // Not accepted (e.g. too little depth): the rule fires again on the next frame.
  EXPECT_TRUE(m.Decide(Tracked(2, 0, 2.2)).new_keyframe);
  EXPECT_EQ(m.keyframe_index(), 0);
}

TEST(KeyframeManagerTest, UnknownDepthDisablesTranslationRule) {
  KeyframeManager m = Started(KeyframeOptions());
  TrackedFrame f = Tracked(1, 0, 100.0);
  f.reference_parallax_depth = 0.0;
  const KeyframeDecision d = m.Decide(f);
  EXPECT_FALSE(d.new_keyframe);
  EXPECT_EQ(d.translation_ratio, 0.0);
}

// Checks that `options` is rejected with a message containing `key`.
void ExpectRejected(const KeyframeOptions& options, const std::string& key) {
  try {
    options.Check();
    ADD_FAILURE() << "accepted; expected a ConfigError naming " << key;
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
  }
  EXPECT_THROW(KeyframeManager m(options), ConfigError);
}

TEST(KeyframeOptionsTest, ContradictionsAndRangesRejectedWithKeyNames) {
  EXPECT_NO_THROW(KeyframeOptions().Check());
  KeyframeOptions o;
  o.translation_ratio = 0.0;
  ExpectRejected(o, "keyframe.translation_ratio = 0 violates > 0");
  o = KeyframeOptions();
  o.translation_ratio = -0.1;
  ExpectRejected(o, "keyframe.translation_ratio = -0.1");
  o = KeyframeOptions();
  o.rotation_deg = 0.0;
  ExpectRejected(o, "keyframe.rotation_deg");
  o = KeyframeOptions();
  o.residual_ratio = 0.5;
  ExpectRejected(o, "keyframe.residual_ratio");
  o = KeyframeOptions();
  o.min_inlier_ratio = 1.5;
  ExpectRejected(o, "keyframe.min_inlier_ratio");
  o = KeyframeOptions();
  o.min_interval = 0;
  ExpectRejected(o, "keyframe.min_interval");
  o = KeyframeOptions();
  o.min_interval = 12;
  o.max_interval = 10;
  ExpectRejected(o, "keyframe.min_interval = 12 violates <= keyframe.max_interval (10)");
}

TEST(KeyframeReasonTest, Names) {
  EXPECT_STREQ(KeyframeReasonName(KeyframeReason::kTranslation), "translation");
  EXPECT_STREQ(KeyframeReasonName(KeyframeReason::kRestart), "restart");
  EXPECT_STREQ(KeyframeReasonName(KeyframeReason::kMaxInterval), "max_interval");
  EXPECT_STREQ(KeyframeReasonName(KeyframeReason::kRetrack), "retrack");
}

}  // namespace
}  // namespace dfo
