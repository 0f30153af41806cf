// The differentiable Gauss-Newton alignment against the tracker: the same feature maps, depth and
// start pose give the same pose (to 1e-4), the gradient exists and is finite, and the analytic
// scale equivariance (depth x s gives translation x s) holds for the gradient as well.
#include "dfo_frontend/learned/internal/diff_gn.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/tracker.h"

namespace dfo::learned {
namespace {

struct View {
  FeaturePyramid features;
  DepthPyramid depth;
};

// Tensors (C x H x W features, H x W depth) from the frontend's pyramids.
AlignmentView ToTensors(const View& view, int levels) {
  AlignmentView out;
  for (int l = 0; l < levels; ++l) {
    const FeatureLevel& f = view.features.levels[l];
    out.features.push_back(torch::from_blob(const_cast<float*>(f.data.data()),
                                            {f.channels, f.height, f.width}, torch::kFloat32)
                               .clone());
    out.cameras.push_back(f.camera);
    const ImageF& d = view.depth.levels[l];
    torch::Tensor dt = torch::empty({d.height(), d.width()}, torch::kFloat32);
    auto a = dt.accessor<float, 2>();
    for (int y = 0; y < d.height(); ++y) {
      for (int x = 0; x < d.width(); ++x) a[y][x] = d(x, y);
    }
    out.depth.push_back(dt);
  }
  return out;
}

class DiffGnTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    SyntheticOptions options;
    options.num_frames = 8;
    sequence_ = new SyntheticSequence(options);
    for (int i : {0, 2}) {
      const SyntheticFrame s = sequence_->RenderFrame(i);
      Frame frame;
      frame.index = i;
      frame.image = s.gray;
      frame.depth_m = s.depth;
      frame.camera = sequence_->camera();
      HandmadeFeatureSource features;
      GroundTruthDepthSource depth;
      views_[i == 0 ? 0 : 1] = new View{features.Compute(frame, 4), depth.Compute(frame, 4)};
    }
  }
  static void TearDownTestSuite() {
    delete sequence_;
    delete views_[0];
    delete views_[1];
  }
  static SE3d TrueCurFromRef() {
    return sequence_->WorldFromCam(2).Inverse() * sequence_->WorldFromCam(0);
  }
  static SyntheticSequence* sequence_;
  static View* views_[2];
};
SyntheticSequence* DiffGnTest::sequence_ = nullptr;
View* DiffGnTest::views_[2] = {nullptr, nullptr};

TEST(ExpSE3Test, MatchesLieExpAndHasFiniteGradientAtZero) {
  for (const double scale : {0.0, 1e-6, 0.3}) {
    Vector6d xi;
    xi << 0.5, -0.2, 1.0, 0.3, -0.6, 0.2;
    xi *= scale;
    const torch::Tensor t =
        torch::tensor({xi(0), xi(1), xi(2), xi(3), xi(4), xi(5)}, torch::kFloat64);
    const SE3d expected = SE3d::Exp(xi);
    const SE3d got = ExpSE3(t).ToSE3();
    EXPECT_LT((got.Matrix() - expected.Matrix()).cwiseAbs().maxCoeff(), 1e-12) << scale;
  }
  const torch::Tensor zero = torch::zeros({6}, torch::kFloat64).requires_grad_(true);
  const PoseTensor p = ExpSE3(zero);
  (p.rotation.sum() + p.translation.sum()).backward();
  EXPECT_TRUE(torch::isfinite(zero.grad()).all().item<bool>());
}

TEST_F(DiffGnTest, AgreesWithTheTrackerOnTheSameInputs) {
  TrackerOptions options;
  const AlignmentView ref = ToTensors(*views_[0], options.num_levels);
  const AlignmentView cur = ToTensors(*views_[1], options.num_levels);
  // Start poses: identity (the paper's start) and a perturbed truth.
  const SE3d truth = TrueCurFromRef();
  Vector6d perturbation;
  perturbation << 0.1, -0.05, 0.2, 0.01, -0.015, 0.005;
  for (const SE3d& start : {SE3d(), SE3d::Exp(perturbation) * truth}) {
    Tracker tracker(options);
    tracker.SetReference(views_[0]->features, views_[0]->depth);
    const TrackResult tracked = tracker.Track(views_[1]->features, {start});
    ASSERT_NE(tracked.status, TrackingStatus::kLost);
    const DiffGnResult diff = DifferentiableAlign(ref, cur, PoseTensor::FromSE3(start), options);
    ASSERT_TRUE(diff.ok);
    const SE3d got = diff.cur_from_ref.ToSE3();
    const Eigen::Matrix4d difference = got.Matrix() - tracked.cur_from_ref.Matrix();
    EXPECT_LT(difference.cwiseAbs().maxCoeff(), 1e-4) << "\n" << difference;
    std::printf("tracker vs differentiable GN: max |T_diff - T_tracker| = %.2e\n",
                difference.cwiseAbs().maxCoeff());
    for (int l = 0; l < options.num_levels; ++l) {
      EXPECT_EQ(diff.levels[l].num_points, tracked.levels[l].num_points) << "level " << l;
    }
    // Both are close to the truth (rendering accuracy).
    EXPECT_LT((got.translation() - truth.translation()).norm(), 0.05);
  }
}

TEST_F(DiffGnTest, GradientFlowsToFeaturesAndDepthAndRespectsScaleEquivariance) {
  TrackerOptions options;
  options.max_iterations = {4, 4, 4, 4};  // short unroll, as in training
  AlignmentView ref = ToTensors(*views_[0], options.num_levels);
  AlignmentView cur = ToTensors(*views_[1], options.num_levels);
  // depth x s: every GN iterate's translation scales by s exactly (start t = 0, rotations and
  // the convergence test are scale-free), so d t / d s at s = 1 equals t.
  const torch::Tensor s = torch::ones({}, torch::kFloat64).requires_grad_(true);
  for (auto& d : ref.depth) d = d.to(torch::kFloat64) * s;
  for (auto& f : cur.features) f.requires_grad_(true);
  const DiffGnResult diff = DifferentiableAlign(ref, cur, PoseTensor::FromSE3(SE3d()), options);
  ASSERT_TRUE(diff.ok);
  const torch::Tensor tz = diff.cur_from_ref.translation[2];
  const torch::Tensor grad_s = torch::autograd::grad({tz}, {s}, {}, /*retain_graph=*/true)[0];
  EXPECT_NEAR(grad_s.item<double>(), tz.item<double>(), 1e-6 + 1e-4 * std::abs(tz.item<double>()));
  tz.backward();
  const torch::Tensor g = cur.features[0].grad();
  ASSERT_TRUE(g.defined());
  EXPECT_TRUE(torch::isfinite(g).all().item<bool>());
  EXPECT_GT(g.abs().sum().item<double>(), 0.0);
}

TEST_F(DiffGnTest, SingularSystemStopsTheLevelInsteadOfThrowing) {
  // Features that vary along x only: every Jacobian's v row is zero, so the 6 x 6 system is
  // exactly singular (torch::linalg::solve throws where the tracker's LDLT returns a non-finite
  // step; a training run stopped on it).
  TrackerOptions options;
  AlignmentView ref = ToTensors(*views_[0], options.num_levels);
  AlignmentView cur = ToTensors(*views_[1], options.num_levels);
  for (AlignmentView* view : {&ref, &cur}) {
    for (torch::Tensor& f : view->features) {
      const torch::Tensor x = torch::arange(f.size(2), torch::kFloat32).view({1, 1, -1});
      const torch::Tensor c = torch::arange(f.size(0), torch::kFloat32).view({-1, 1, 1});
      f = torch::sin(0.7 * x + c + (view == &cur ? 0.3 : 0.0)).expand(f.sizes()).contiguous();
    }
  }
  DiffGnResult result;
  EXPECT_NO_THROW(result = DifferentiableAlign(ref, cur, PoseTensor::FromSE3(SE3d()), options));
  EXPECT_TRUE(torch::isfinite(result.cur_from_ref.translation).all().item<bool>());
}

TEST_F(DiffGnTest, TooFewLevelsIsAnInputError) {
  TrackerOptions options;
  const AlignmentView ref = ToTensors(*views_[0], 2);
  const AlignmentView cur = ToTensors(*views_[1], 2);
  EXPECT_THROW(DifferentiableAlign(ref, cur, PoseTensor::FromSE3(SE3d()), options), InputError);
}

}  // namespace
}  // namespace dfo::learned
