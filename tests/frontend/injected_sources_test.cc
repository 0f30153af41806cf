// Tests of sources handed to the Frontend by the caller (how the applications pass the learned
// sources, which dfo::frontend cannot create): the injected sources are the ones used, null means
// "by name", "learned" passes FrontendOptions::Check but cannot be created by name, and an
// injected depth source frees the frames from carrying a depth map.
#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/frontend.h"

namespace dfo {
namespace {

// Hand-made features, counting its calls.
class CountingFeatureSource : public FeatureSource {
 public:
  explicit CountingFeatureSource(int* calls) : calls_(calls) {}
  std::string name() const override { return "counting"; }
  FeaturePyramid Compute(const Frame& frame, int num_levels) override {
    ++*calls_;
    return handmade_.Compute(frame, num_levels);
  }

 private:
  int* calls_;
  HandmadeFeatureSource handmade_;
};

// Depth from a table of depth maps by frame index (stands in for a depth network: the frames
// themselves carry no depth map).
class TableDepthSource : public DepthSource {
 public:
  TableDepthSource(std::vector<ImageF> depth, int* calls)
      : depth_(std::move(depth)), calls_(calls) {}
  std::string name() const override { return "table"; }
  DepthPyramid Compute(const Frame& frame, int num_levels) override {
    ++*calls_;
    Frame with_depth;
    with_depth.index = frame.index;
    with_depth.image = frame.image;
    with_depth.camera = frame.camera;
    with_depth.depth_m = depth_.at(frame.index);
    return gt_.Compute(with_depth, num_levels);
  }

 private:
  std::vector<ImageF> depth_;
  int* calls_;
  GroundTruthDepthSource gt_;
};

class InjectedSourcesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SyntheticOptions options;
    options.num_frames = 8;
    const SyntheticSequence sequence(options);
    for (int i = 0; i < options.num_frames; ++i) {
      const SyntheticFrame s = sequence.RenderFrame(i);
      Frame f;
      f.index = s.index;
      f.timestamp_ns = s.timestamp_ns;
      f.image = s.gray;
      f.depth_m = s.depth;
      f.camera = sequence.camera();
      frames_.push_back(std::move(f));
    }
  }
  std::vector<Frame> frames_;
};

// Injected sources give the same poses as the sources made by name (they compute the same
// pyramids). The feature source runs on every frame, the depth source only on the frames that
// become references.
TEST_F(InjectedSourcesTest, InjectedSourcesAreUsed) {
  int feature_calls = 0, depth_calls = 0;
  std::vector<ImageF> depth;
  for (const Frame& f : frames_) depth.push_back(f.depth_m);
  FrontendOptions options;
  options.features = "learned";  // a label only: the injected sources are used
  options.depth = "learned";
  Frontend injected(options, std::make_unique<CountingFeatureSource>(&feature_calls),
                    std::make_unique<TableDepthSource>(depth, &depth_calls));
  Frontend by_name(FrontendOptions{});
  int references = 0;
  for (const Frame& frame : frames_) {
    const TrackedFrame a = injected.Process(frame);
    const TrackedFrame b = by_name.Process(frame);
    EXPECT_EQ(a.status, b.status) << "frame " << frame.index;
    EXPECT_EQ(a.world_from_cam.Matrix(), b.world_from_cam.Matrix()) << "frame " << frame.index;
    if (a.is_new_reference) {
      ++references;
    } else {
      EXPECT_EQ(injected.last_timings().depth_ms, 0.0);
    }
  }
  EXPECT_EQ(feature_calls, static_cast<int>(frames_.size()));
  ASSERT_GE(references, 2);  // the first frame and at least one switch
  EXPECT_EQ(depth_calls, references);
}

// With the external policy the caller picks the references: the depth of a frame is computed
// when MakeLastFrameReference makes it one (once, however often it is asked), counted in that
// frame's depth time, and the poses are those of a frontend whose depth comes with the frames.
TEST_F(InjectedSourcesTest, DepthIsComputedForTheFramesMadeReferences) {
  int depth_calls = 0;
  std::vector<ImageF> depth;
  for (const Frame& f : frames_) depth.push_back(f.depth_m);
  FrontendOptions options;
  options.reference.policy = "external";
  options.depth = "learned";
  Frontend lazy(options, nullptr, std::make_unique<TableDepthSource>(depth, &depth_calls));
  FrontendOptions gt_options;
  gt_options.reference.policy = "external";
  Frontend gt(gt_options);
  int references = 0;
  for (const Frame& frame : frames_) {
    Frame no_depth = frame;
    no_depth.depth_m = ImageF();
    const TrackedFrame a = lazy.Process(no_depth);
    const TrackedFrame b = gt.Process(frame);
    EXPECT_EQ(a.world_from_cam.Matrix(), b.world_from_cam.Matrix()) << "frame " << frame.index;
    if (a.status == TrackingStatus::kReference) ++references;
    if (frame.index % 3 != 2) continue;
    const int calls_before = depth_calls;
    KeyframeData from_lazy, from_gt;
    ASSERT_TRUE(lazy.MakeLastFrameReference(&from_lazy)) << "frame " << frame.index;
    ASSERT_TRUE(gt.MakeLastFrameReference(&from_gt));
    ASSERT_TRUE(lazy.MakeLastFrameReference(nullptr));  // again: already the reference
    EXPECT_EQ(depth_calls, calls_before + 1) << "frame " << frame.index;
    ++references;
    ASSERT_EQ(from_lazy.depth.num_levels(), from_gt.depth.num_levels());
    for (int l = 0; l < from_gt.depth.num_levels(); ++l) {
      EXPECT_EQ(from_lazy.depth.levels[l].vector(), from_gt.depth.levels[l].vector());
    }
  }
  EXPECT_EQ(depth_calls, references);
  EXPECT_LT(depth_calls, static_cast<int>(frames_.size()));
}

// With an injected depth source the frames need no depth map (learned depth on KITTI); the
// "gt" source by name still throws InputError for them.
TEST_F(InjectedSourcesTest, InjectedDepthNeedsNoDepthMapInTheFrames) {
  int depth_calls = 0;
  std::vector<ImageF> depth;
  for (const Frame& f : frames_) depth.push_back(f.depth_m);
  FrontendOptions options;
  options.depth = "learned";
  Frontend frontend(options, nullptr, std::make_unique<TableDepthSource>(depth, &depth_calls));
  Frontend gt(FrontendOptions{});
  for (const Frame& frame : frames_) {
    Frame no_depth = frame;
    no_depth.depth_m = ImageF();
    const TrackedFrame t = frontend.Process(no_depth);
    const TrackedFrame expected = gt.Process(frame);
    EXPECT_NE(t.status, TrackingStatus::kLost) << "frame " << frame.index;
    EXPECT_EQ(t.status, expected.status) << "frame " << frame.index;
    EXPECT_EQ(t.world_from_cam.Matrix(), expected.world_from_cam.Matrix());
  }
  Frame no_depth = frames_[0];
  no_depth.depth_m = ImageF();
  EXPECT_THROW(Frontend(FrontendOptions{}).Process(no_depth), InputError);
  // Also on a frame that needs no depth (not a reference): the input is checked on every frame.
  Frontend tracking(FrontendOptions{});
  ASSERT_EQ(tracking.Process(frames_[0]).status, TrackingStatus::kReference);
  EXPECT_THROW(tracking.Process(no_depth), InputError);
  Frame wrong_size = frames_[1];
  wrong_size.depth_m = ImageF(4, 4, 1, 1.0f);
  EXPECT_THROW(tracking.Process(wrong_size), InputError);
  EXPECT_NE(tracking.Process(frames_[1]).status, TrackingStatus::kLost);
}

// "learned" is a valid name, but only an application with a loaded model can make the sources:
// by name it is a ConfigError that points at learned.model. Unknown names list both names.
TEST(InjectedSourcesOptionsTest, LearnedNeedsInjectedSources) {
  FrontendOptions options;
  options.features = "learned";
  options.depth = "learned";
  EXPECT_NO_THROW(options.Check());
  for (const bool learned_features : {true, false}) {
    FrontendOptions o;
    (learned_features ? o.features : o.depth) = "learned";
    try {
      Frontend frontend(o);
      FAIL() << "no error";
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(
          what.find(learned_features ? "frontend.features = learned" : "frontend.depth = learned"),
          std::string::npos)
          << what;
      EXPECT_NE(what.find("learned.model"), std::string::npos) << what;
    }
  }
  // Only the missing one is made by name.
  FrontendOptions learned_depth;
  learned_depth.depth = "learned";
  EXPECT_THROW(Frontend(learned_depth, std::make_unique<HandmadeFeatureSource>(), nullptr),
               ConfigError);
  EXPECT_NO_THROW(Frontend(learned_depth, nullptr, std::make_unique<GroundTruthDepthSource>()));

  options = FrontendOptions();
  options.features = "cnn";
  try {
    options.Check();
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "frontend.features = cnn violates one of {handmade, learned}");
  }
  options = FrontendOptions();
  options.depth = "stereo";
  try {
    options.Check();
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "frontend.depth = stereo violates one of {gt, learned}");
  }
  // Bad options still throw before any source is used.
  options = FrontendOptions();
  options.tracker.patch_size = 4;
  EXPECT_THROW(Frontend(options, std::make_unique<HandmadeFeatureSource>(),
                        std::make_unique<GroundTruthDepthSource>()),
               ConfigError);
}

}  // namespace
}  // namespace dfo
