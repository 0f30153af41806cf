// The training engine on a tiny synthetic sequence: snippets and static-frame skipping, the
// deterministic augmented batch, a few steps lowering the loss (AE and joint stages), checkpoint
// and resume giving exactly the uninterrupted run, the loss history CSV, and option errors.
#include "dfo_frontend/learned/internal/training.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "tests/support/test_support.h"

namespace dfo::learned {
namespace {

// Frames of the synthetic street (seed 7, not the demo's) at 208 x 64.
TrainingSequence SyntheticData(int frames) {
  SyntheticOptions options;
  options.seed = 7;
  options.num_frames = frames;
  options.width = 208;
  options.height = 64;
  const SyntheticSequence sequence(options);
  TrainingSequence seq;
  seq.name = "synthetic seed 7";
  seq.camera = sequence.camera();
  for (int i = 0; i < frames; ++i) seq.images.push_back(sequence.RenderFrame(i).rgb);
  return seq;
}

// Small networks and short schedules so that a step takes a fraction of a second.
TrainingOptions TinyOptions() {
  TrainingOptions o;
  o.network.input_width = 208;
  o.network.input_height = 64;
  o.network.channels = {4, 4, 4, 4};
  o.network.depth_encoder_widths = {8, 8, 16, 16, 16};
  o.network.depth_decoder_widths = {8, 8, 8, 16, 16};
  o.network.feature_encoder_widths = {8, 8, 16, 16};
  o.network.feature_decoder_widths = {8, 8, 8, 8};
  o.network.reconstruction_width = 8;
  o.gn.max_points = 150;
  o.gn.max_iterations = {2, 2, 2, 2};
  o.gn_use_masks = false;
  o.batch_size = 1;
  o.threads = 1;
  o.ae_iterations = 3;
  o.iterations = 8;
  o.learning_rate = 1e-3;
  o.final_learning_rate = 1e-3;
  o.seed = 3;
  return o;
}

class TrainingTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { data_ = new TrainingSequence(SyntheticData(5)); }
  static void TearDownTestSuite() { delete data_; }
  static TrainingSequence* data_;
};
TrainingSequence* TrainingTest::data_ = nullptr;

TEST_F(TrainingTest, SnippetsSkipStaticFrames) {
  TrainingOptions o = TinyOptions();
  Trainer moving(o, {*data_});
  EXPECT_EQ(moving.snippets().size(), 3u);  // targets 1, 2, 3 of 5 frames
  // Repeating frame 1 makes the snippets around the copy static.
  TrainingSequence with_stop = *data_;
  with_stop.images.insert(with_stop.images.begin() + 2, with_stop.images[1]);
  Trainer stopped(o, {with_stop});
  for (const Snippet& s : stopped.snippets()) {
    EXPECT_NE(s.index, 1);
    EXPECT_NE(s.index, 2);
  }
  EXPECT_EQ(stopped.snippets().size(), 2u);
}

TEST_F(TrainingTest, BatchIsDeterministicAndAugmented) {
  TrainingOptions o = TinyOptions();
  o.batch_size = 2;
  o.augment.max_scale = 1.5;
  o.augment.color_probability = 1.0;
  Trainer trainer(o, {*data_});
  const Trainer::Batch a = trainer.MakeBatch(4), b = trainer.MakeBatch(4), c = trainer.MakeBatch(5);
  EXPECT_TRUE(torch::equal(a.target, b.target));
  EXPECT_TRUE(torch::equal(a.intrinsics, b.intrinsics));
  EXPECT_FALSE(torch::equal(a.target, c.target));
  EXPECT_EQ(a.target.sizes(), (std::vector<int64_t>{2, 3, 64, 208}));
  EXPECT_GE(a.target.min().item<double>(), 0.0);
  EXPECT_LE(a.target.max().item<double>(), 1.0);
  // Upscaling enlarges the focal length by the drawn scale (1 .. 1.5).
  for (const PinholeCamera& cam : a.cameras) {
    EXPECT_GE(cam.fx, data_->camera.fx - 1e-9);
    EXPECT_LE(cam.fx, 1.5 * data_->camera.fx + 1e-6);
  }
}

TEST_F(TrainingTest, FewStepsLowerTheLoss) {
  // One snippet, no augmentation: every batch is the same, so the loss must go down.
  TrainingSequence three = *data_;
  three.images.resize(3);
  TrainingOptions o = TinyOptions();
  o.augment.enabled = false;
  o.ae_iterations = 12;
  o.iterations = 36;
  Trainer trainer(o, {three});
  trainer.Run(nullptr, "", nullptr);
  const std::vector<StepRecord>& h = trainer.history();
  ASSERT_EQ(h.size(), 36u);
  EXPECT_EQ(h[0].stage, "ae");
  EXPECT_EQ(h[12].stage, "joint");
  EXPECT_LT(h[11].reconstruction, 0.8 * h[0].reconstruction);
  // Joint stage: mean of the last 4 steps below the first step's total.
  double last = 0.0;
  for (int i = 32; i < 36; ++i) last += h[i].total / 4.0;
  EXPECT_LT(last, h[12].total) << "first joint " << h[12].total << ", last " << last;
  int gn_ok = 0;
  for (int i = 12; i < 36; ++i) gn_ok += h[i].gn_ok_ratio > 0.0;
  EXPECT_GT(gn_ok, 0) << "the differentiable alignment never succeeded";
}

TEST_F(TrainingTest, ResumeContinuesExactlyWhereTheRunStopped) {
  const std::string dir = test::MakeTempDir("train_resume");
  const std::string checkpoint = dir + "/checkpoint.pt";
  TrainingOptions o = TinyOptions();  // 3 AE + 5 joint iterations
  // Uninterrupted run.
  Trainer full(o, {*data_});
  full.Run(nullptr, "", nullptr);
  // Stopped after 5 steps (by the stop flag), then resumed by a fresh trainer.
  {
    Trainer first(o, {*data_});
    std::atomic<bool> stop(false);
    int steps = 0;
    first.Run(&stop, checkpoint, [&](const StepRecord&) {
      if (++steps == 5) stop = true;
    });
    EXPECT_EQ(first.iteration(), 5);
  }
  ASSERT_TRUE(std::filesystem::exists(checkpoint));
  Trainer second(o, {*data_});
  second.LoadCheckpoint(checkpoint);
  EXPECT_EQ(second.iteration(), 5);
  ASSERT_EQ(second.history().size(), 5u);
  second.Run(nullptr, checkpoint, nullptr);
  ASSERT_EQ(second.history().size(), full.history().size());
  for (size_t i = 0; i < full.history().size(); ++i) {
    EXPECT_EQ(second.history()[i].iteration, static_cast<int>(i) + 1);
    EXPECT_NEAR(second.history()[i].total, full.history()[i].total,
                1e-5 * std::abs(full.history()[i].total))
        << "iteration " << i + 1;
  }
  // The CSV round trip keeps the curve.
  WriteHistoryCsv(dir + "/losses.csv", second.history());
  const std::vector<StepRecord> back = ReadHistoryCsv(dir + "/losses.csv");
  ASSERT_EQ(back.size(), second.history().size());
  EXPECT_EQ(back.back().iteration, 8);
  EXPECT_NEAR(back.back().total, second.history().back().total, 1e-6);
}

TEST_F(TrainingTest, BadCheckpointAndShapeMismatchAreInputErrors) {
  const std::string dir = test::MakeTempDir("train_badckpt");
  TrainingOptions o = TinyOptions();
  Trainer trainer(o, {*data_});
  { std::ofstream(dir + "/junk.pt") << "not a checkpoint"; }
  EXPECT_THROW(trainer.LoadCheckpoint(dir + "/junk.pt"), InputError);
  trainer.SaveCheckpoint(dir + "/ok.pt");
  TrainingOptions other = o;
  other.network.channels = {4, 4, 4, 8};
  Trainer different(other, {*data_});
  try {
    different.LoadCheckpoint(dir + "/ok.pt");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("channels=[4,4,4,4]"), std::string::npos) << e.what();
  }
}

TEST_F(TrainingTest, OptionErrorsNameTheField) {
  TrainingOptions o = TinyOptions();
  o.batch_size = 0;
  EXPECT_THROW(Trainer(o, {*data_}), ConfigError);
  o = TinyOptions();
  o.network.input_width = 210;
  try {
    Trainer t(o, {*data_});
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("network.input_width = 210"), std::string::npos)
        << e.what();
  }
  TrainingSequence tiny = *data_;
  tiny.images.resize(2);
  EXPECT_THROW(Trainer(TinyOptions(), {tiny}), InputError);
}

TEST(ZScoreTest, MatchesFeatureLevelZScore) {
  torch::manual_seed(0);
  const torch::Tensor f = torch::rand({3, 6, 7});
  const torch::Tensor z = ZScore(f);
  EXPECT_NEAR(z.mean({1, 2}).abs().max().item<double>(), 0.0, 1e-5);
  EXPECT_NEAR((z * z).mean({1, 2}).sub(1.0).abs().max().item<double>(), 0.0, 1e-4);
}

}  // namespace
}  // namespace dfo::learned
