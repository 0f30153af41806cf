// The differentiable Gauss-Newton alignment against the tracker: the same feature maps, depth and
// start pose give the same pose (to 1e-4), the gradient exists and is finite, the analytic
// scale equivariance (depth x s gives translation x s) holds for the gradient as well, and the
// gradient matches central differences with respect to feature entries of both views, depth
// pixels, a coarse level's depth map and the start rotation.
#include "dfo_frontend/learned/internal/diff_gn.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

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

// Finite-difference checks: the autograd gradient of a scalar of the output pose against central
// differences, with respect to entries of both feature maps, reference depth pixels, a coarse
// level's depth map and the start pose's rotation. The scalar is a fixed linear functional
// L = a . t + <B, R> of the output pose (arbitrary non-zero weights: every component of the pose
// contributes). The inputs the test controls are double (kFloat64 features, depth and start pose),
// and so are the geometry, the Jacobians and the solves; but DifferentiableAlign samples the
// current features in float32 (as the tracker), so L is not smooth to double precision. What that
// asks of the checks (all measured):
//  - float32 sampling: the grid coordinates are rounded to ~1.2e-5 px at the finest level and the
//    perturbed current feature to float32. Whenever an input moves sample positions, these
//    roundings put noise of up to ~1e-7 on L.
//  - bilinear interpolation has a kink at every integer position, and patches leave or enter the
//    image: a step that moves a sample across either changes L by more than its derivative says.
//    From the identity start the first step samples every reference pixel exactly on a kink (it
//    maps onto itself) and autograd returns one one-sided derivative: the forward and backward
//    differences with respect to the start rotation differed by up to 4x there. The start here
//    is a perturbed truth.
//  - the other discrete choices must not flip between the two evaluations: convergence is off
//    (threshold 1e-30: a fixed unroll), the outlier rule is off (one patch crossing its threshold
//    moved L by ~1e-7), the reference feature step keeps the point selection (a 1e-2 step changed
//    it for 1 of 40 entries drawn; 1e-3 did not).
//  - every unrolled step contracts towards the fixed point, so the gradient with respect to what
//    only the earlier steps see shrinks with the unroll while the float32 noise does not (4 steps
//    per level: the gradient with respect to the start rotation was ~1e-3, the differences were
//    noise). Features and depth: one step per level.
// Hence two kinds of checks.
//  - Single entries, exact up to float32 rounding: feature entries of the finest level (they act
//    on the last step without moving any sample) with all four levels, and depth pixels on the
//    finest level alone (with more levels a depth pixel also enters the mean depth that rescales
//    the translation between levels, which moves every sample of every level by ~1e-8 px per mm
//    across float32 roundings: 2 to 7 % errors on 3 of 40 pixels). The depth pixels drawn are
//    those whose step keeps their sample between the same integer positions (the one that did
//    not: 30 % error). Measured over 40 draws of each: relative errors below 1e-4 (features) and
//    8e-4 (depth). Tolerance 1e-2.
//  - Directions that move every sample of several levels (the start rotation, two steps per
//    level; a ramp on level 1's depth map): kinks, image borders and roundings leave ~1e-2 of
//    noise that no single step avoids (with one step, one of 8 start poses tried gave a 2x
//    error, the 1/h signature of a jump). The median of the central differences at three steps
//    a factor ~3 apart: below 1.7e-2 over those 8 start poses, 6e-3 at the one used here.
//    Tolerance 3e-2.
// Both tolerances are below 5 %, so a gradient wrong by 10 % fails: |1.1 ad - fd| / |ad| >=
// 0.1 - |fd - ad| / |ad| > tolerance (also asserted, with the relative errors printed).
constexpr double kEntryTolerance = 1e-2;
constexpr double kDirectionTolerance = 3e-2;

torch::Tensor PoseFunctional(const PoseTensor& pose) {
  const torch::Tensor a = torch::tensor({0.3, -0.5, 0.8}, torch::kFloat64);
  const torch::Tensor b =
      torch::tensor({0.7, -0.2, 0.4, 0.1, 0.9, -0.6, -0.3, 0.5, 0.2}, torch::kFloat64).view({3, 3});
  return (a * pose.translation).sum() + (b * pose.rotation).sum();
}

// Detached, contiguous kFloat64 copies of a view's features and depth.
AlignmentView ToDouble(const AlignmentView& view) {
  AlignmentView out = view;
  for (auto& f : out.features) f = f.detach().to(torch::kFloat64).contiguous().clone();
  for (auto& d : out.depth) d = d.detach().to(torch::kFloat64).contiguous().clone();
  return out;
}

// The start pose with its rotation perturbed on the left: (Exp(omega) R, t).
PoseTensor RotatedStart(const torch::Tensor& omega, const SE3d& start) {
  const PoseTensor base = PoseTensor::FromSE3(start);
  const PoseTensor rotation = ExpSE3(torch::cat({torch::zeros({3}, torch::kFloat64), omega}));
  return {torch::matmul(rotation.rotation, base.rotation), base.translation};
}

// k entries drawn at random (fixed seed) among those whose |gradient| is at least 10 % of the
// largest: the patch pixels, where a relative error means something. (mt19937's output is fixed
// by the standard; the modulo keeps the draw independent of the library's distributions.)
std::vector<int64_t> PickEntries(const torch::Tensor& grad, int k, uint32_t seed) {
  const torch::Tensor g = grad.detach().reshape({-1}).abs().contiguous();
  const double largest = g.max().item<double>();
  const double* p = g.data_ptr<double>();
  std::vector<int64_t> candidates;
  for (int64_t i = 0; i < g.numel(); ++i) {
    if (p[i] >= 0.1 * largest) candidates.push_back(i);
  }
  std::mt19937 rng(seed);
  std::vector<int64_t> out;
  for (int i = 0; i < k && !candidates.empty(); ++i) {
    const size_t j = rng() % candidates.size();
    out.push_back(candidates[j]);
    candidates.erase(candidates.begin() + static_cast<std::ptrdiff_t>(j));
  }
  return out;
}

// Median over `steps` of the central differences (f(h) - f(-h)) / 2h.
double MedianCentralDifference(const std::function<double(double)>& f,
                               const std::vector<double>& steps) {
  std::vector<double> differences;
  for (const double h : steps) differences.push_back((f(h) - f(-h)) / (2.0 * h));
  std::sort(differences.begin(), differences.end());
  return differences[differences.size() / 2];
}

// Compares one autograd derivative with its central difference; prints the relative error.
void ExpectDerivativesAgree(const std::string& what, double ad, double fd, double tolerance) {
  const double error = std::abs(fd - ad) / std::abs(ad);
  std::printf("  %-26s autograd % .6e  central difference % .6e  relative error %.1e\n",
              what.c_str(), ad, fd, error);
  EXPECT_LT(error, tolerance) << what << ": autograd " << ad << ", central difference " << fd;
  // The check has the power to see a gradient wrong by 10 %.
  EXPECT_GT(std::abs(fd - 1.1 * ad) / std::abs(ad), tolerance) << what;
}

class DiffGnGradientTest : public DiffGnTest {
 protected:
  void SetUp() override {
    options_.outlier_rule = false;
    options_.convergence_threshold = {1e-30};
    options_.max_iterations = {1};
    ref_ = ToDouble(ToTensors(*views_[0], options_.num_levels));
    cur_ = ToDouble(ToTensors(*views_[1], options_.num_levels));
    Vector6d perturbation;
    perturbation << 0.1, -0.05, 0.2, 0.01, -0.015, 0.005;
    start_ = SE3d::Exp(perturbation) * TrueCurFromRef();
  }
  // L at ref_, cur_ and `start` (no autograd); NaN when the alignment fails (fails the check).
  double Objective(const PoseTensor& start) const {
    torch::NoGradGuard no_grad;
    const DiffGnResult result = DifferentiableAlign(ref_, cur_, start, options_);
    if (!result.ok) return std::numeric_limits<double>::quiet_NaN();
    return PoseFunctional(result.cur_from_ref).item<double>();
  }
  // Central difference of L along entry `index` of `t`, one of ref_'s or cur_'s double tensors
  // (changed in place, restored).
  double CentralDifference(const torch::Tensor& t, int64_t index, double h) const {
    double* p = t.data_ptr<double>();
    const double x0 = p[index];
    const PoseTensor start = PoseTensor::FromSE3(start_);
    p[index] = x0 + h;
    const double plus = Objective(start);
    p[index] = x0 - h;
    const double minus = Objective(start);
    p[index] = x0;
    return (plus - minus) / (2.0 * h);
  }
  // Autograd gradients of L with respect to every level's features and depth (computed on leaf
  // copies: the differences change ref_ and cur_ in place).
  struct Gradients {
    std::vector<torch::Tensor> ref_features, cur_features, depth;
  };
  Gradients AutogradGradients() const {
    AlignmentView ref = ref_, cur = cur_;
    for (auto& f : ref.features) f = f.clone().requires_grad_(true);
    for (auto& f : cur.features) f = f.clone().requires_grad_(true);
    for (auto& d : ref.depth) d = d.clone().requires_grad_(true);
    const DiffGnResult result =
        DifferentiableAlign(ref, cur, PoseTensor::FromSE3(start_), options_);
    EXPECT_TRUE(result.ok);
    PoseFunctional(result.cur_from_ref).backward();
    Gradients out;
    for (int l = 0; l < options_.num_levels; ++l) {
      out.ref_features.push_back(ref.features[l].grad());
      out.cur_features.push_back(cur.features[l].grad());
      out.depth.push_back(ref.depth[l].grad());
    }
    return out;
  }
  TrackerOptions options_;
  AlignmentView ref_, cur_;
  SE3d start_;
};

TEST_F(DiffGnGradientTest, FeatureGradientsMatchCentralDifferences) {
  const Gradients grads = AutogradGradients();
  // Steps (z-score units): 1e-3 for the reference (keeps the point selection), 1e-2 for the
  // current features (1e-3 would lose ~1e-4 to their float32 rounding).
  struct Input {
    const char* name;
    torch::Tensor grad;
    torch::Tensor values;
    double step;
  };
  const Input inputs[] = {{"reference feature", grads.ref_features[0], ref_.features[0], 1e-3},
                          {"current feature", grads.cur_features[0], cur_.features[0], 1e-2}};
  uint32_t seed = 17;
  for (const Input& input : inputs) {
    ASSERT_TRUE(input.grad.defined()) << input.name;
    const torch::Tensor grad = input.grad.reshape({-1}).contiguous();
    for (const int64_t i : PickEntries(grad, 4, seed++)) {
      ExpectDerivativesAgree(std::string(input.name) + " " + std::to_string(i),
                             grad.data_ptr<double>()[i],
                             CentralDifference(input.values, i, input.step), kEntryTolerance);
    }
  }
}

TEST_F(DiffGnGradientTest, DepthPixelGradientsMatchCentralDifferences) {
  // The finest level alone, whose one step evaluates at the start pose. Step 1e-3 of the depth.
  options_.num_levels = 1;
  const Gradients grads = AutogradGradients();
  ASSERT_TRUE(grads.depth[0].defined());
  const PinholeCamera& camera = ref_.cameras[0];
  const int64_t width = ref_.depth[0].size(1);
  const double* depth = ref_.depth[0].data_ptr<double>();
  // The sample of pixel i at depth d.
  auto sample = [&](int64_t i, double d) {
    const Eigen::Vector3d p_in_ref((i % width - camera.cx) / camera.fx * d,
                                   (i / width - camera.cy) / camera.fy * d, d);
    const Eigen::Vector3d p_in_cur = start_ * p_in_ref;
    return Eigen::Vector2d(camera.fx * p_in_cur.x() / p_in_cur.z() + camera.cx,
                           camera.fy * p_in_cur.y() / p_in_cur.z() + camera.cy);
  };
  // Candidates: pixels whose sample stays between the same integer positions over the step.
  const torch::Tensor autograd = grads.depth[0].reshape({-1}).contiguous();
  torch::Tensor candidates = autograd.clone();
  double* c = candidates.data_ptr<double>();
  for (int64_t i = 0; i < candidates.numel(); ++i) {
    if (c[i] == 0.0) continue;
    const Eigen::Vector2d a = sample(i, 0.999 * depth[i]), b = sample(i, 1.001 * depth[i]);
    if (std::floor(a.x()) != std::floor(b.x()) || std::floor(a.y()) != std::floor(b.y())) {
      c[i] = 0.0;
    }
  }
  for (const int64_t i : PickEntries(candidates, 4, 19)) {
    ExpectDerivativesAgree("reference depth " + std::to_string(i), autograd.data_ptr<double>()[i],
                           CentralDifference(ref_.depth[0], i, 1e-3 * depth[i]), kEntryTolerance);
  }
}

TEST_F(DiffGnGradientTest, DepthMapGradientMatchesCentralDifferences) {
  // Level 1's depth map times (1 + s ramp), ramp = x / (width - 1), at s = 0, with all levels:
  // its points and the mean depth that rescales the translation into and out of level 1 (a
  // uniform scale would cancel exactly: scale equivariance).
  const Gradients grads = AutogradGradients();
  ASSERT_TRUE(grads.depth[1].defined());
  const torch::Tensor original = ref_.depth[1].clone();
  const torch::Tensor direction =
      original * torch::linspace(0.0, 1.0, original.size(1), torch::kFloat64).view({1, -1});
  const PoseTensor start = PoseTensor::FromSE3(start_);
  const double fd = MedianCentralDifference(
      [&](double s) {
        ref_.depth[1].copy_(original + s * direction);
        return Objective(start);
      },
      {1e-4, 3e-4, 1e-3});
  ref_.depth[1].copy_(original);
  ExpectDerivativesAgree("level 1 depth map ramp",
                         (grads.depth[1] * direction).sum().item<double>(), fd,
                         kDirectionTolerance);
}

TEST_F(DiffGnGradientTest, StartRotationGradientMatchesCentralDifferences) {
  // Two steps per level (see above); all four levels.
  options_.max_iterations = {2};
  const torch::Tensor omega = torch::zeros({3}, torch::kFloat64).requires_grad_(true);
  const DiffGnResult result =
      DifferentiableAlign(ref_, cur_, RotatedStart(omega, start_), options_);
  ASSERT_TRUE(result.ok);
  PoseFunctional(result.cur_from_ref).backward();
  // Steps 1e-5 to 1e-4 rad move the finest level's samples by ~0.002 to 0.02 px.
  for (int k = 0; k < 3; ++k) {
    const double fd = MedianCentralDifference(
        [&](double h) {
          torch::Tensor step = torch::zeros({3}, torch::kFloat64);
          step[k] = h;
          return Objective(RotatedStart(step, start_));
        },
        {1e-5, 3e-5, 1e-4});
    ExpectDerivativesAgree("start rotation axis " + std::to_string(k),
                           omega.grad()[k].item<double>(), fd, kDirectionTolerance);
  }
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
