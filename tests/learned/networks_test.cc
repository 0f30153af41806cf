// Tests of the DFO networks (dfo_frontend/learned/internal/networks.h): shapes, ranges, the
// Gaussian smoothing, masks, seeded determinism and that every parameter is trainable.
#include "dfo_frontend/learned/internal/networks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dfo_core/error.h"

namespace dfo::learned {
namespace {

// A small but complete configuration: 4 levels at 128 x 64 keeps each test well under a second.
NetworkOptions SmallOptions() {
  NetworkOptions o;
  o.input_width = 128;
  o.input_height = 64;
  return o;
}

torch::Tensor TestImage(int width, int height, uint64_t seed) {
  at::Generator gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  return torch::rand({1, 3, height, width}, gen, torch::kFloat32);
}

// The training memory estimate lies above dfo_train's measured peaks (default widths: 621 MiB at
// 208 x 64 in batches of 4, 977 in batches of 8, 1622 at 416 x 128, 3015 at 832 x 256 in batches
// of 2) and grows with the pixels, the batch and the widths.
TEST(NetworkOptionsTest, TrainingMemoryEstimateCoversTheMeasuredPeaks) {
  NetworkOptions o;
  const auto at = [&o](int width, int height, int batch) {
    NetworkOptions sized = o;
    sized.input_width = width;
    sized.input_height = height;
    return EstimateTrainingMemoryMib(sized, batch);
  };
  EXPECT_GE(at(208, 64, 4), 621.0);
  EXPECT_GE(at(208, 64, 8), 977.0);
  EXPECT_GE(at(416, 128, 4), 1622.0);
  EXPECT_GE(at(832, 256, 2), 3015.0);
  EXPECT_LE(at(832, 256, 2), 1.5 * 3015.0);
  EXPECT_GT(at(4096, 4096, 64), 1e6);
  NetworkOptions wider = o;
  for (int& w : wider.depth_decoder_widths) w *= 2;
  EXPECT_GT(EstimateTrainingMemoryMib(wider, 4), EstimateTrainingMemoryMib(o, 4));
}

TEST(NetworkOptionsTest, DefaultsAreValidAndBadValuesNameTheField) {
  EXPECT_NO_THROW(NetworkOptions().Check());
  NetworkOptions o;
  o.channels = {8, 8, 16};
  try {
    o.Check();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("network.channels"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("num_levels = 4"), std::string::npos) << e.what();
  }
  o = NetworkOptions();
  o.input_width = 100;  // not divisible by 8
  EXPECT_THROW(o.Check(), ConfigError);
  o = NetworkOptions();
  o.rho[2] = 0.0;
  EXPECT_THROW(o.Check(), ConfigError);
  o = NetworkOptions();
  o.patch_sizes[0] = 4;
  EXPECT_THROW(o.Check(), ConfigError);
  o = NetworkOptions();
  o.depth_encoder_widths = {16, 32, 64};  // fewer stages than levels
  o.depth_decoder_widths = {16, 32, 64};
  EXPECT_THROW(o.Check(), ConfigError);
  o = NetworkOptions();
  o.input_std[1] = 0.0;
  EXPECT_THROW(o.Check(), ConfigError);
}

TEST(NetworksTest, OutputShapesPerLevel) {
  const NetworkOptions o = SmallOptions();
  Networks nets(o, 1);
  nets->eval();
  torch::NoGradGuard no_grad;
  const torch::Tensor image = TestImage(o.input_width, o.input_height, 7).repeat({2, 1, 1, 1});
  const DepthNetOutput d = nets->depth->forward(image);
  const FeatureNetOutput f = nets->feature->forward(image);
  const std::vector<torch::Tensor> recon = nets->feature->Reconstruct(f.features);
  ASSERT_EQ(d.sigmoid.size(), 4u);
  ASSERT_EQ(d.depth.size(), 4u);
  ASSERT_EQ(f.features.size(), 4u);
  ASSERT_EQ(f.mask_logits.size(), 4u);
  ASSERT_EQ(recon.size(), 4u);
  for (int l = 0; l < 4; ++l) {
    const int64_t h = o.input_height >> l, w = o.input_width >> l;
    EXPECT_EQ(d.sigmoid[l].sizes(), c10::IntArrayRef({2, 1, h, w})) << "level " << l;
    EXPECT_EQ(d.depth[l].sizes(), c10::IntArrayRef({2, 1, h, w})) << "level " << l;
    EXPECT_EQ(f.features[l].sizes(), c10::IntArrayRef({2, o.channels[l], h, w})) << "level " << l;
    EXPECT_EQ(f.mask_logits[l].sizes(), c10::IntArrayRef({2, 1, h, w})) << "level " << l;
    EXPECT_EQ(recon[l].sizes(), c10::IntArrayRef({2, 3, h, w})) << "level " << l;
    EXPECT_GE(f.features[l].min().item<float>(), 0.0f) << "ReLU then a positive kernel";
    EXPECT_GT(f.features[l].max().item<float>(), 0.0f) << "features are not all dead";
    // Zero-initialised residual trunks keep untrained activations of order 1 (not ~1e2).
    EXPECT_LT(f.features[l].max().item<float>(), 50.0f) << "level " << l;
    EXPECT_TRUE(torch::isfinite(f.mask_logits[l]).all().item<bool>());
    EXPECT_GE(recon[l].min().item<float>(), 0.0f);
    EXPECT_LE(recon[l].max().item<float>(), 1.0f);
  }
}

TEST(NetworksTest, DepthRangeIsThePapers) {
  // depth = 1 / (10 s + 0.01): s = 0 -> 100 m, s = 1 -> 1 / 10.01 m, s = 0.5 -> 1 / 5.01 m.
  const torch::Tensor s = torch::tensor({0.0f, 0.5f, 1.0f});
  const torch::Tensor depth = DepthFromSigmoid(s);
  EXPECT_NEAR(depth[0].item<float>(), 100.0f, 1e-3f);
  EXPECT_NEAR(depth[1].item<float>(), 1.0f / 5.01f, 1e-6f);
  EXPECT_NEAR(depth[2].item<float>(), 1.0f / 10.01f, 1e-6f);
  EXPECT_NEAR(kMinNetworkDepth, 1.0 / 10.01, 1e-12);

  const NetworkOptions o = SmallOptions();
  Networks nets(o, 2);
  nets->eval();
  torch::NoGradGuard no_grad;
  const DepthNetOutput d = nets->depth->forward(TestImage(o.input_width, o.input_height, 3));
  for (int l = 0; l < o.num_levels; ++l) {
    EXPECT_GE(d.depth[l].min().item<double>(), kMinNetworkDepth * (1 - 1e-6));
    EXPECT_LE(d.depth[l].max().item<double>(), kMaxNetworkDepth * (1 + 1e-6));
    EXPECT_TRUE(torch::allclose(d.depth[l], DepthFromSigmoid(d.sigmoid[l])));
  }
}

// SetInitialDepth: with the heads' weights zeroed, every level outputs exactly the initial
// depth; out-of-range depths are ConfigErrors.
TEST(NetworksTest, InitialDepthSetsTheHeadsBias) {
  const NetworkOptions o = SmallOptions();
  Networks nets(o, 2);
  {
    torch::NoGradGuard no_grad;
    for (auto& p : nets->depth->named_parameters()) {
      if (p.key().rfind("disp_heads.", 0) == 0 && p.key().find("weight") != std::string::npos) {
        p.value().zero_();
      }
    }
  }
  nets->depth->SetInitialDepth(10.0);
  torch::NoGradGuard no_grad;
  const DepthNetOutput d = nets->depth->forward(TestImage(o.input_width, o.input_height, 3));
  for (int l = 0; l < o.num_levels; ++l) {
    EXPECT_NEAR(d.depth[l].min().item<double>(), 10.0, 1e-3) << "level " << l;
    EXPECT_NEAR(d.depth[l].max().item<double>(), 10.0, 1e-3) << "level " << l;
  }
  EXPECT_THROW(nets->depth->SetInitialDepth(0.05), ConfigError);
  EXPECT_THROW(nets->depth->SetInitialDepth(100.0), ConfigError);
}

TEST(NetworksTest, GaussianSmoothingKernel) {
  const torch::Tensor k = GaussianKernel3x3();
  const torch::Tensor expected =
      torch::tensor({1.0f, 2.0f, 1.0f, 2.0f, 4.0f, 2.0f, 1.0f, 2.0f, 1.0f}).view({3, 3}) / 16.0f;
  EXPECT_TRUE(torch::allclose(k, expected));
  EXPECT_NEAR(k.sum().item<float>(), 1.0f, 1e-7f);

  // An impulse in the interior gives the kernel back, per channel independently.
  torch::Tensor impulse = torch::zeros({1, 2, 7, 7});
  impulse[0][1][3][3] = 1.0f;
  const torch::Tensor smoothed = GaussianSmooth3x3(impulse);
  EXPECT_TRUE(torch::allclose(smoothed[0][1].slice(0, 2, 5).slice(1, 2, 5), k));
  EXPECT_EQ(smoothed[0][0].abs().sum().item<float>(), 0.0f) << "channels must not mix";
  EXPECT_NEAR(smoothed.sum().item<float>(), 1.0f, 1e-6f);

  // A constant map stays constant, borders included (replicate padding).
  const torch::Tensor constant = torch::full({1, 3, 5, 6}, 2.5f);
  EXPECT_TRUE(torch::allclose(GaussianSmooth3x3(constant), constant));
}

TEST(NetworksTest, HardTopMaskKeepsExactlyRhoOfThePixels) {
  at::Generator gen = at::make_generator<at::CPUGeneratorImpl>(5);
  const torch::Tensor logits = torch::randn({2, 1, 16, 52}, gen);
  for (double rho : {0.015, 0.04, 0.1, 0.5, 1.0}) {
    const torch::Tensor mask = HardTopMask(logits, rho);
    ASSERT_EQ(mask.sizes(), logits.sizes());
    ASSERT_EQ(mask.scalar_type(), torch::kUInt8);
    const int64_t expected = std::max<int64_t>(1, std::llround(rho * 16 * 52));
    for (int n = 0; n < 2; ++n) {
      EXPECT_EQ(mask[n].sum().item<int64_t>(), expected) << "rho " << rho;
      // Every kept pixel's logit is >= every dropped pixel's.
      const torch::Tensor kept = logits[n].masked_select(mask[n].to(torch::kBool));
      const torch::Tensor dropped = logits[n].masked_select(~mask[n].to(torch::kBool));
      if (dropped.numel() > 0) {
        EXPECT_GE(kept.min().item<float>(), dropped.max().item<float>());
      }
    }
  }
}

TEST(NetworksTest, InferenceMaskDensityEqualsRhoPerLevel) {
  const NetworkOptions o = SmallOptions();
  Networks nets(o, 4);
  nets->eval();
  torch::NoGradGuard no_grad;
  const FeatureNetOutput f = nets->feature->forward(TestImage(o.input_width, o.input_height, 9));
  for (int l = 0; l < o.num_levels; ++l) {
    const torch::Tensor mask = HardTopMask(f.mask_logits[l], o.rho[l]);
    const double pixels = static_cast<double>(NetworkOptions::LevelPixels(128, 64, l));
    const double density = mask.sum().item<double>() / pixels;
    // Within rounding: at most half a pixel off (or the 1-pixel minimum).
    EXPECT_NEAR(density, o.rho[l], std::max(0.5 / pixels, 1.0 / pixels)) << "level " << l;
  }
}

TEST(NetworksTest, GumbelSigmoidRelaxation) {
  const torch::Tensor logits = torch::full({1, 1, 200, 500}, 0.8f);
  at::Generator g1 = at::make_generator<at::CPUGeneratorImpl>(11);
  at::Generator g2 = at::make_generator<at::CPUGeneratorImpl>(11);
  const torch::Tensor a = GumbelSigmoid(logits, 1.0, g1);
  const torch::Tensor b = GumbelSigmoid(logits, 1.0, g2);
  EXPECT_TRUE(torch::equal(a, b)) << "same generator seed, same sample";
  EXPECT_GT(a.min().item<float>(), 0.0f);
  EXPECT_LT(a.max().item<float>(), 1.0f);
  // P(sigmoid((x + logistic noise) / t) > 0.5) = sigmoid(x) for any temperature; 1e5 samples give
  // a standard error of ~0.0015.
  const double above = (a > 0.5f).to(torch::kFloat64).mean().item<double>();
  EXPECT_NEAR(above, 1.0 / (1.0 + std::exp(-0.8)), 0.01);
  // A low temperature pushes samples towards 0/1.
  const torch::Tensor cold = GumbelSigmoid(logits, 0.1, g1);
  const double near_binary =
      ((cold < 0.05f) | (cold > 0.95f)).to(torch::kFloat64).mean().item<double>();
  EXPECT_GT(near_binary, 0.8);
  // Differentiable with respect to the logits.
  const torch::Tensor x = torch::zeros({4}, torch::requires_grad());
  GumbelSigmoid(x, 0.5).sum().backward();
  EXPECT_GT(x.grad().abs().sum().item<float>(), 0.0f);
  EXPECT_THROW(GumbelSigmoid(x, 0.0), InternalError);
}

TEST(NetworksTest, SameSeedSameWeightsAndOutputs) {
  const NetworkOptions o = SmallOptions();
  Networks a(o, 42), b(o, 42), c(o, 43);
  const auto pa = a->named_parameters(), pb = b->named_parameters(), pc = c->named_parameters();
  ASSERT_EQ(pa.size(), pb.size());
  bool any_differs_from_c = false;
  for (size_t i = 0; i < pa.size(); ++i) {
    EXPECT_EQ(pa[i].key(), pb[i].key());
    EXPECT_TRUE(torch::equal(pa[i].value(), pb[i].value())) << pa[i].key();
    if (!torch::equal(pa[i].value(), pc[i].value())) any_differs_from_c = true;
  }
  EXPECT_TRUE(any_differs_from_c) << "another seed must give other weights";
  // The global torch RNG is not consumed by the seeded initialisation.
  torch::manual_seed(1);
  const torch::Tensor r1 = torch::rand({3});
  torch::manual_seed(1);
  Networks unused(o, 7);
  EXPECT_TRUE(torch::equal(r1, torch::rand({3})));

  a->eval();
  b->eval();
  torch::NoGradGuard no_grad;
  const torch::Tensor image = TestImage(o.input_width, o.input_height, 1);
  const FeatureNetOutput fa = a->feature->forward(image), fb = b->feature->forward(image);
  const DepthNetOutput da = a->depth->forward(image), db = b->depth->forward(image);
  for (int l = 0; l < o.num_levels; ++l) {
    EXPECT_TRUE(torch::equal(fa.features[l], fb.features[l]));
    EXPECT_TRUE(torch::equal(fa.mask_logits[l], fb.mask_logits[l]));
    EXPECT_TRUE(torch::equal(da.depth[l], db.depth[l]));
  }
}

TEST(NetworksTest, ChannelsLastGivesTheSameOutputs) {
  const NetworkOptions o = SmallOptions();
  Networks a(o, 5), b(o, 5);
  ToChannelsLast(*b);
  a->eval();
  b->eval();
  c10::InferenceMode guard;
  const torch::Tensor image = TestImage(o.input_width, o.input_height, 2);
  const DepthNetOutput da = a->depth->forward(image);
  const DepthNetOutput db = b->depth->forward(image.contiguous(torch::MemoryFormat::ChannelsLast));
  const FeatureNetOutput fa = a->feature->forward(image);
  const FeatureNetOutput fb =
      b->feature->forward(image.contiguous(torch::MemoryFormat::ChannelsLast));
  for (int l = 0; l < o.num_levels; ++l) {
    // Other summation orders in oneDNN's NHWC kernels: equal to float rounding (relative 1e-4
    // of the level's largest value).
    const double depth_tol = 1e-4 * da.depth[l].abs().max().item<double>();
    const double feature_tol = 1e-4 * fa.features[l].abs().max().item<double>();
    EXPECT_TRUE(torch::allclose(da.depth[l], db.depth[l], 0.0, depth_tol)) << l;
    EXPECT_TRUE(torch::allclose(fa.features[l], fb.features[l], 0.0, feature_tol))
        << l << " max diff " << (fa.features[l] - fb.features[l]).abs().max().item<float>()
        << " max " << fa.features[l].abs().max().item<float>();
  }
}

TEST(NetworksTest, EveryParameterReceivesAGradient) {
  NetworkOptions o = SmallOptions();
  Networks nets(o, 3);
  nets->train();
  const torch::Tensor image = TestImage(o.input_width, o.input_height, 4);
  auto loss_of = [&]() {
    const DepthNetOutput d = nets->depth->forward(image);
    const FeatureNetOutput f = nets->feature->forward(image);
    const std::vector<torch::Tensor> recon = nets->feature->Reconstruct(f.features);
    torch::Tensor loss = torch::zeros({});
    for (int l = 0; l < o.num_levels; ++l) {
      loss = loss + d.depth[l].mean() + f.features[l].mean() + f.mask_logits[l].mean() +
             recon[l].mean();
    }
    return loss;
  };
  // The residual trunks start at zero, so the first gradient reaches their last convolution
  // only; after one step every parameter is trained.
  torch::optim::SGD sgd(nets->parameters(), torch::optim::SGDOptions(0.01));
  loss_of().backward();
  sgd.step();
  sgd.zero_grad();
  loss_of().backward();
  for (const auto& p : nets->named_parameters()) {
    ASSERT_TRUE(p.value().grad().defined()) << p.key();
    EXPECT_GT(p.value().grad().abs().sum().item<double>(), 0.0) << p.key();
  }
}

TEST(NetworksTest, RejectsInputsOfUnusableSize) {
  const NetworkOptions o = SmallOptions();
  Networks nets(o, 1);
  torch::NoGradGuard no_grad;
  EXPECT_THROW(nets->depth->forward(torch::rand({1, 3, 60, 128})), InternalError);
  EXPECT_THROW(nets->feature->forward(torch::rand({1, 1, 64, 128})), InternalError);
  // Any size with sides divisible by 8 runs (fully convolutional), e.g. 208 x 64 for training.
  const DepthNetOutput d = nets->depth->forward(torch::rand({1, 3, 64, 208}));
  EXPECT_EQ(d.depth[3].sizes(), c10::IntArrayRef({1, 1, 8, 26}));
}

}  // namespace
}  // namespace dfo::learned
