#include "dfo_core/plane_sweep.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"

namespace dfo {
namespace {

// Frame `reference` of a synthetic street and its neighbours within +-3 frames, with the true
// poses (translations multiplied by `translation_scale`).
struct SweepCase {
  ImageF reference;
  std::vector<ImageF> images;
  std::vector<StereoView> views;
  ImageF true_depth;
  PinholeCamera camera;
};

SweepCase MakeCase(int reference, double translation_scale) {
  SyntheticOptions options;
  options.seed = 3;
  options.num_frames = reference + 4;
  const SyntheticSequence sequence(options);
  SweepCase c;
  c.camera = sequence.camera();
  const SyntheticFrame ref = sequence.RenderFrame(reference);
  c.reference = ref.gray.Cast<float>();
  c.true_depth = ref.depth;
  std::vector<int> neighbours = {reference - 3, reference - 2, reference - 1,
                                 reference + 1, reference + 2, reference + 3};
  c.images.reserve(neighbours.size());
  for (int j : neighbours) c.images.push_back(sequence.RenderFrame(j).gray.Cast<float>());
  for (size_t v = 0; v < neighbours.size(); ++v) {
    SE3d view_from_ref = sequence.WorldFromCam(neighbours[v]).Inverse() * ref.world_from_cam;
    view_from_ref = SE3d(view_from_ref.so3(), translation_scale * view_from_ref.translation());
    c.views.push_back({&c.images[v], view_from_ref});
  }
  return c;
}

// |log(estimate / truth)| over the pixels where both have a depth.
std::vector<double> LogErrors(const ImageF& estimate, const ImageF& truth) {
  std::vector<double> errors;
  for (size_t i = 0; i < estimate.size(); ++i) {
    const double e = estimate.vector()[i], t = truth.vector()[i];
    if (e > 0.0 && t > 0.0) errors.push_back(std::log(e / t));
  }
  return errors;
}

double Quantile(std::vector<double> values, double q) {
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * values.size()));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

// With the true poses the sweep recovers the true depth wherever it is confident.
TEST(PlaneSweepTest, RecoversTheTrueDepthFromTruePoses) {
  const SweepCase c = MakeCase(40, 1.0);
  PlaneSweepOptions options;
  options.num_threads = 2;
  const PlaneSweepResult result = PlaneSweepDepth(c.reference, c.camera, c.views, options);
  std::vector<double> errors = LogErrors(result.depth, c.true_depth);
  ASSERT_GT(errors.size(), 1000u);
  EXPECT_GT(result.confident_fraction, 0.3);
  for (double& e : errors) e = std::abs(e);
  EXPECT_LT(Quantile(errors, 0.5), 0.03);
  EXPECT_LT(Quantile(errors, 0.9), 0.15);
}

// The depth follows the poses: translations twice as long give depths twice as far (what makes
// the sweep a metric reference on real video with metric ground-truth poses).
TEST(PlaneSweepTest, DepthScalesWithTheTranslations) {
  const SweepCase c = MakeCase(40, 2.0);
  PlaneSweepOptions options;
  options.min_depth_m = 4.0;
  options.max_depth_m = 240.0;
  const PlaneSweepResult result = PlaneSweepDepth(c.reference, c.camera, c.views, options);
  const std::vector<double> errors = LogErrors(result.depth, c.true_depth);
  ASSERT_GT(errors.size(), 1000u);
  EXPECT_NEAR(std::exp(Quantile(errors, 0.5)), 2.0, 0.03);
}

// Threads share the depth samples, then the pixels of the minimum search; the result does not
// depend on their number.
TEST(PlaneSweepTest, ThreadCountDoesNotChangeTheResult) {
  const SweepCase c = MakeCase(40, 1.0);
  PlaneSweepOptions options;
  options.num_depths = 48;
  const PlaneSweepResult one = PlaneSweepDepth(c.reference, c.camera, c.views, options);
  options.num_threads = 3;
  const PlaneSweepResult three = PlaneSweepDepth(c.reference, c.camera, c.views, options);
  EXPECT_EQ(one.depth.vector(), three.depth.vector());
}

TEST(PlaneSweepTest, RejectsBadOptionsAndImages) {
  PlaneSweepOptions options;
  options.max_depth_m = options.min_depth_m;
  EXPECT_THROW(options.Check(), ConfigError);
  options = PlaneSweepOptions();
  options.num_depths = 2;
  EXPECT_THROW(options.Check(), ConfigError);

  const PinholeCamera camera(50.0, 50.0, 32.0, 16.0, 64, 32);
  const ImageF reference(64, 32, 1, 10.0f), wrong(32, 32, 1, 10.0f);
  const std::vector<StereoView> views = {{&wrong, SE3d()}, {&reference, SE3d()}};
  try {
    PlaneSweepDepth(reference, camera, views, PlaneSweepOptions());
    FAIL() << "a view of another size was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("view 0"), std::string::npos) << e.what();
  }
  const std::vector<StereoView> one = {{&reference, SE3d()}};
  EXPECT_THROW(PlaneSweepDepth(reference, camera, one, PlaneSweepOptions()), InputError);
  const std::vector<StereoView> none = {{nullptr, SE3d()}, {&reference, SE3d()}};
  EXPECT_THROW(PlaneSweepDepth(reference, camera, none, PlaneSweepOptions()), InputError);
}

}  // namespace
}  // namespace dfo
