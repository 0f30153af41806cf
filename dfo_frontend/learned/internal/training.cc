// Training loop of the DFO networks. References: SfMLearner (Zhou et al. 2017: 3-frame snippets,
// random scale 1..1.15 + crop augmentation, multi-scale warping loss), Monodepth2 (Godard et al.
// 2019: per-pixel minimum reprojection over the sources, 3 x 3 SSIM, mean-normalised disparity
// smoothness), the DFO paper (Yin & Liu: clamped appearance loss, mask sparsity, autoencoder
// stage, pose from the differentiable feature-metric Gauss-Newton).
#include "dfo_frontend/learned/internal/training.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/utils.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_core/frame.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/learned/internal/device.h"
#include "dfo_frontend/learned/internal/training_parts.h"

namespace dfo::learned {

namespace F = torch::nn::functional;

namespace {

void Require(bool ok, const std::string& field, double value, const char* rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << field << " = " << value << " violates " << rule;
  throw ConfigError(msg.str());
}

}  // namespace

void AugmentOptions::Check() const {
  Require(max_scale >= 1.0 && max_scale <= 2.0, "augment.max_scale", max_scale, "in [1, 2]");
  Require(color_probability >= 0.0 && color_probability <= 1.0, "augment.color_probability",
          color_probability, "in [0, 1]");
  Require(color_min > 0.0, "augment.color_min", color_min, "> 0");
  Require(color_max >= color_min, "augment.color_max", color_max, ">= augment.color_min");
}

void TrainingOptions::Check() const {
  network.Check();
  loss.Check();
  augment.Check();
  gn.Check();
  Require(gn.num_levels == network.num_levels, "gn.num_levels", gn.num_levels,
          "== network.num_levels");
  Require(batch_size >= 1, "train.batch_size", batch_size, ">= 1");
  Require(static_threshold >= 0.0, "train.static_threshold", static_threshold, ">= 0");
  Require(ae_iterations >= 0, "train.ae_iterations", ae_iterations, ">= 0");
  Require(iterations >= 1, "train.iterations", iterations, ">= 1");
  Require(learning_rate > 0.0, "train.learning_rate", learning_rate, "> 0");
  Require(final_learning_rate > 0.0, "train.final_learning_rate", final_learning_rate, "> 0");
  Require(adam_beta1 >= 0.0 && adam_beta1 < 1.0, "train.adam_beta1", adam_beta1, "in [0, 1)");
  Require(adam_beta2 >= 0.0 && adam_beta2 < 1.0, "train.adam_beta2", adam_beta2, "in [0, 1)");
  Require(max_grad_norm > 0.0, "train.max_grad_norm", max_grad_norm, "> 0");
  Require(temperature_start > 0.0, "train.temperature_start", temperature_start, "> 0");
  Require(temperature_end > 0.0, "train.temperature_end", temperature_end, "> 0");
  Require(threads >= 1, "train.threads", threads, ">= 1");
  CheckDeviceName("train.device", device);
  Require(initial_depth_m == 0.0 || (initial_depth_m > 0.1 && initial_depth_m < 100.0),
          "train.initial_depth_m", initial_depth_m, "0 or in (0.1, 100)");
  Require(gn_handmade_iterations >= 0, "gn.handmade_iterations", gn_handmade_iterations, ">= 0");
  Require(checkpoint_every >= 1, "train.checkpoint_every", checkpoint_every, ">= 1");
  const int divisor = 1 << (network.num_levels - 1);
  Require(network.input_width % divisor == 0, "network.input_width", network.input_width,
          "divisible by 2^(num_levels - 1)");
  Require(network.input_height % divisor == 0, "network.input_height", network.input_height,
          "divisible by 2^(num_levels - 1)");
}

Trainer::Trainer(const TrainingOptions& options, std::vector<TrainingSequence> data)
    : options_(options), data_(std::move(data)) {
  options_.Check();
  // Before the data is touched: a device this LibTorch cannot use is a start-up error.
  device_ = ResolveDevice("train.device", options_.device);
  PrepareTrainingData(options_, &data_, &snippets_);
  teacher_log_scales_.assign(data_.size(), std::numeric_limits<double>::quiet_NaN());
  torch::set_num_threads(options_.threads);
  networks_ = Networks(options_.network, options_.seed);
  if (options_.initial_depth_m > 0.0) networks_->depth->SetInitialDepth(options_.initial_depth_m);
  if (options_.channels_last) ToChannelsLast(*networks_);
  // Built (and initialised) on the CPU, then moved: the same initial weights on every device.
  if (!device_.is_cpu()) networks_->to(device_);
  optimizer_ = std::make_unique<torch::optim::Adam>(
      networks_->parameters(), torch::optim::AdamOptions(options_.learning_rate)
                                   .betas({options_.adam_beta1, options_.adam_beta2}));
}

Trainer::~Trainer() = default;

void Trainer::ClippedStep(int iteration) {
  const double norm =
      torch::nn::utils::clip_grad_norm_(networks_->parameters(), options_.max_grad_norm);
  if (!std::isfinite(norm)) {
    // A non-finite gradient (the unrolled GN through a near-singular system can overflow) would
    // turn every weight into NaN through Adam; skip this update instead (measured: with mask
    // weights the run ended with a NaN loss at iteration 611).
    optimizer_->zero_grad();
    ++skipped_updates_;
    std::fprintf(stderr,
                 "dfo_train: iteration %d: non-finite gradient, update skipped (%d so far)\n",
                 iteration + 1, skipped_updates_);
    return;
  }
  optimizer_->step();
}

double Trainer::LearningRateAt(int iteration) const {
  const double progress =
      std::clamp(static_cast<double>(iteration) / std::max(1, options_.iterations), 0.0, 1.0);
  return options_.learning_rate *
         std::pow(options_.final_learning_rate / options_.learning_rate, progress);
}

double Trainer::TemperatureAt(int iteration) const {
  const int joint = std::max(1, options_.iterations - options_.ae_iterations);
  const double progress =
      std::clamp(static_cast<double>(iteration - options_.ae_iterations) / joint, 0.0, 1.0);
  return options_.temperature_start *
         std::pow(options_.temperature_end / options_.temperature_start, progress);
}

StepRecord Trainer::Step() {
  const auto start = std::chrono::steady_clock::now();
  torch::set_num_threads(options_.threads);
  const double lr = LearningRateAt(iteration_);
  for (auto& group : optimizer_->param_groups()) {
    static_cast<torch::optim::AdamOptions&>(group.options()).lr(lr);
  }
  networks_->train();
  const Batch batch = MakeBatch(iteration_);
  StepRecord rec =
      iteration_ < options_.ae_iterations ? AeStep(batch) : JointStep(batch, iteration_);
  if (!std::isfinite(rec.total)) {
    std::ostringstream msg;
    msg << "training: the loss is not finite at iteration " << iteration_ + 1 << " (" << rec.stage
        << " stage, appearance " << rec.appearance << ", smoothness " << rec.smoothness
        << ", sparsity " << rec.sparsity << ", reconstruction " << rec.reconstruction
        << "); lower train.learning_rate or train.max_grad_norm";
    throw InternalError(msg.str());
  }
  ++iteration_;
  rec.iteration = iteration_;
  rec.learning_rate = lr;
  rec.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  history_.push_back(rec);
  return rec;
}

int Trainer::Run(const std::atomic<bool>* stop, const std::string& checkpoint_path,
                 const std::function<void(const StepRecord&)>& on_step) {
  int steps = 0;
  while (iteration_ < options_.iterations) {
    if (stop && stop->load()) break;
    const StepRecord rec = Step();
    ++steps;
    if (on_step) on_step(rec);
    if (!checkpoint_path.empty() && iteration_ % options_.checkpoint_every == 0) {
      SaveCheckpoint(checkpoint_path);
    }
  }
  if (!checkpoint_path.empty() && steps > 0) SaveCheckpoint(checkpoint_path);
  return steps;
}

std::vector<torch::Tensor> Trainer::PredictDepth(const torch::Tensor& images) {
  torch::NoGradGuard no_grad;
  networks_->eval();
  const auto format =
      options_.channels_last ? torch::MemoryFormat::ChannelsLast : torch::MemoryFormat::Contiguous;
  DepthNetOutput out = networks_->depth->forward(images.to(device_).contiguous(format));
  networks_->train();
  for (torch::Tensor& d : out.depth) d = d.to(torch::kCPU);
  return out.depth;
}

}  // namespace dfo::learned
