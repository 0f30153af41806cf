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
#include "dfo_frontend/learned/internal/zip_archive.h"

namespace dfo::learned {

namespace F = torch::nn::functional;

namespace {

void Require(bool ok, const std::string& field, double value, const char* rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << field << " = " << value << " violates " << rule;
  throw ConfigError(msg.str());
}

// SplitMix64: decorrelated seeds for (run seed, iteration, purpose).
uint64_t Mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}
uint64_t StepSeed(uint64_t seed, int iteration, uint64_t purpose) {
  return Mix(Mix(seed) ^ Mix(static_cast<uint64_t>(iteration) * 4 + purpose));
}

// Text of the options that fix the networks' parameter shapes (checked on resume).
std::string ShapeSignature(const NetworkOptions& o) {
  std::ostringstream s;
  auto list = [&s](const char* name, const auto& v) {
    s << name << "=[";
    for (size_t i = 0; i < v.size(); ++i) s << (i ? "," : "") << v[i];
    s << "] ";
  };
  s << "num_levels=" << o.num_levels << " ";
  list("channels", o.channels);
  list("depth_encoder_widths", o.depth_encoder_widths);
  list("depth_decoder_widths", o.depth_decoder_widths);
  list("feature_encoder_widths", o.feature_encoder_widths);
  list("feature_decoder_widths", o.feature_decoder_widths);
  s << "reconstruction_width=" << o.reconstruction_width;
  return s.str();
}

torch::Tensor MeanAbsGrey(const torch::Tensor& a, const torch::Tensor& b) {
  return (a.to(torch::kFloat32).mean(0) - b.to(torch::kFloat32).mean(0)).abs().mean() / 255.0;
}

// Columns of the history (checkpoint tensor and CSV). Older checkpoints and CSVs have fewer:
// the first 12 before the pose-error diagnostic (the two pose errors then read NaN), the first
// 14 before the geometry-consistency term, the first 15 before the depth-target term (each then
// reads 0).
constexpr int kHistoryColumns = 16;
constexpr int kConsistencyColumns = 15;
constexpr int kPoseErrorColumns = 14;
constexpr int kOldHistoryColumns = 12;

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

torch::Tensor ViewSynthesisLoss(const Trainer::Batch& batch,
                                const std::vector<torch::Tensor>& depth,
                                const torch::Tensor rotations[2],
                                const torch::Tensor translations[2], const LossOptions& options) {
  const int levels = static_cast<int>(depth.size());
  const std::vector<torch::Tensor> targets = ImagePyramid(batch.target, levels);
  const std::vector<torch::Tensor> sources[2] = {ImagePyramid(batch.previous, levels),
                                                 ImagePyramid(batch.next, levels)};
  torch::Tensor appearance = torch::zeros({}, batch.target.options());
  for (int l = 0; l < levels; ++l) {
    // The level whose images and intrinsics the view synthesis uses.
    const int il = options.full_resolution ? 0 : l;
    const double scale = 1.0 / (1 << il);
    // Level intrinsics: PyramidLevel's (c + 0.5) / 2^l - 0.5.
    torch::Tensor k = batch.intrinsics.clone();
    k.select(1, 0).mul_(scale);
    k.select(1, 1).mul_(scale);
    k.select(1, 2).add_(0.5).mul_(scale).sub_(0.5);
    k.select(1, 3).add_(0.5).mul_(scale).sub_(0.5);
    torch::Tensor d = depth[l].contiguous();
    if (il != l) {
      d = F::interpolate(d, F::InterpolateFuncOptions()
                                .size(std::vector<int64_t>{targets[0].size(2), targets[0].size(3)})
                                .mode(torch::kBilinear)
                                .align_corners(false))
              .contiguous();
    }
    DFO_CHECK(d.size(2) == targets[il].size(2) && d.size(3) == targets[il].size(3))
        << "level " << l << " depth " << d.sizes() << " vs image " << targets[il].sizes();
    std::vector<torch::Tensor> maps;
    for (int s = 0; s < 2; ++s) {
      torch::Tensor valid;
      const torch::Tensor warped =
          InverseWarp(sources[s][il].contiguous(), d, rotations[s], translations[s], k, &valid);
      const torch::Tensor map = AppearanceMap(targets[il].contiguous(), warped, options);
      // A pixel that falls outside this source (border-padded sample) or behind its camera
      // loses the minimum to a valid source by a constant 1 (larger than any error of the
      // clamped mix); it is never excluded. Excluding pixels invalid in both sources rewarded
      // warping them out of view: the bottom rows, which leave the image in the next frame,
      // went to the 0.1 m floor of the depth (measured, hand-made-feature alignment).
      maps.push_back(map + (1.0 - valid));
    }
    if (options.automask) {
      // The unwarped sources; + 1e-5 lets a warp win an exact tie (Monodepth2 adds noise).
      for (int s = 0; s < 2; ++s) {
        maps.push_back(
            AppearanceMap(targets[il].contiguous(), sources[s][il].contiguous(), options).detach() +
            1e-5);
      }
    }
    const torch::Tensor best = std::get<0>(torch::min(torch::cat(maps, 1), 1, true));
    appearance = appearance + best.mean();
  }
  return appearance / levels;
}

std::vector<torch::Tensor> NormaliseDepthScale(const std::vector<torch::Tensor>& raw,
                                               const LossOptions& options, torch::Tensor* prior,
                                               torch::Tensor* factor) {
  // Scale gauge: monocular snippets leave the depth scale unobservable (the alignment's
  // translation scales with it), so the depths are normalised (LossOptions::depth_gauge) to
  // depth_mean_m, and a weak prior keeps the raw output's geometric mean there (metric-ish, away
  // from the sigmoid's saturated ends). The geometric mean, not the mean: a prior on the
  // arithmetic mean was met by a few pixels at the 100 m ceiling with the rest at the 0.1 m floor
  // (measured: median depth 0.0999 m while the mean read 10 m). (Also with ground-truth poses:
  // unnormalised, the initial 0.2 m depths put every warped pixel outside the sources and the
  // depth collapsed to the 0.1 m floor; measured.)
  *prior = torch::zeros({}, raw[0].options());
  if (factor) *factor = torch::ones({raw[0].size(0), 1, 1, 1}, raw[0].options());
  if (options.depth_mean_m <= 0.0) return raw;
  const torch::Tensor log_mean = torch::log(raw[0]).mean();
  const double log_target = std::log(options.depth_mean_m);
  torch::Tensor gauge;
  if (options.depth_gauge == LossOptions::DepthGauge::kGeometricMean) {
    gauge = torch::exp(log_target - log_mean).view({1, 1, 1, 1}).expand({raw[0].size(0), 1, 1, 1});
  } else {
    // Per image: its median depth goes to depth_mean_m. Only each image's median pixel carries
    // the normalisation's gradient. With the batch geometric mean every pixel did: d L / d log
    // raw_i = g_i - mean_j g_j, so a pixel without a photometric gradient of its own
    // (auto-masked, e.g. the uniform road at the bottom) was pushed to the 0.1 m floor or the
    // 100 m ceiling whenever the rest wanted to move together (measured). Detaching the factor
    // instead let the raw scale drift to the ceiling.
    const int64_t n = raw[0].size(0);
    const torch::Tensor median = std::get<0>(raw[0].reshape({n, -1}).median(1));
    gauge = (options.depth_mean_m / median).view({n, 1, 1, 1});
  }
  std::vector<torch::Tensor> out;
  for (const torch::Tensor& d : raw) out.push_back(d * gauge);
  *prior = (log_mean - log_target).pow(2);
  if (factor) *factor = gauge;
  return out;
}

PoseError ComparePoses(const SE3d& estimate, const SE3d& truth) {
  PoseError e;
  const Eigen::Matrix3d dr = estimate.rotationMatrix().transpose() * truth.rotationMatrix();
  const double c = std::clamp((dr.trace() - 1.0) / 2.0, -1.0, 1.0);
  e.rotation_deg = std::acos(c) * 180.0 / M_PI;
  const Eigen::Vector3d a = estimate.translation(), b = truth.translation();
  if (a.norm() < 1e-9 || b.norm() < 1e-9) {
    e.direction_deg = std::numeric_limits<double>::quiet_NaN();
  } else {
    const double cd = std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0);
    e.direction_deg = std::acos(cd) * 180.0 / M_PI;
  }
  return e;
}

torch::Tensor ImageToTensor(const ImageU8& image) {
  DFO_CHECK(image.channels() == 1 || image.channels() == 3) << image.channels();
  torch::Tensor t =
      torch::from_blob(const_cast<uint8_t*>(image.data()),
                       {image.height(), image.width(), image.channels()}, torch::kUInt8)
          .permute({2, 0, 1})
          .to(torch::kFloat32)
          .div(255.0)
          .unsqueeze(0);
  if (image.channels() == 1) t = t.expand({1, 3, image.height(), image.width()});
  return t.contiguous();
}

std::vector<torch::Tensor> HandmadePyramid(const torch::Tensor& image, const PinholeCamera& camera,
                                           int num_levels) {
  DFO_CHECK(image.dim() == 3 && image.size(0) == 3) << image.sizes();
  const torch::Tensor hwc = (image.detach() * 255.0)
                                .round()
                                .clamp(0, 255)
                                .to(torch::kCPU, torch::kUInt8)
                                .permute({1, 2, 0})
                                .contiguous();
  Frame frame;
  frame.camera = camera;
  frame.image = ImageU8(static_cast<int>(hwc.size(1)), static_cast<int>(hwc.size(0)), 3);
  std::memcpy(frame.image.data(), hwc.data_ptr<uint8_t>(), frame.image.size());
  HandmadeFeatureSource source;
  const FeaturePyramid pyramid = source.Compute(frame, num_levels);
  std::vector<torch::Tensor> out;
  for (const FeatureLevel& level : pyramid.levels) {
    out.push_back(torch::from_blob(const_cast<float*>(level.data.data()),
                                   {level.channels, level.height, level.width}, torch::kFloat32)
                      .clone()
                      .to(image.device()));
  }
  return out;
}

torch::Tensor ZScore(const torch::Tensor& features) {
  const torch::Tensor mean = features.mean({-2, -1}, true);
  const torch::Tensor centred = features - mean;
  const torch::Tensor var = (centred * centred).mean({-2, -1}, true);
  // sqrt(var + tiny) keeps the gradient finite for a constant channel (which then stays ~0).
  return centred / torch::sqrt(var + 1e-12);
}

Trainer::Trainer(const TrainingOptions& options, std::vector<TrainingSequence> data)
    : options_(options), data_(std::move(data)) {
  options_.Check();
  // Before the data is touched: a device this LibTorch cannot use is a start-up error.
  device_ = ResolveDevice("train.device", options_.device);
  const int w = options_.network.input_width, h = options_.network.input_height;
  for (size_t s = 0; s < data_.size(); ++s) {
    TrainingSequence& seq = data_[s];
    for (size_t i = 0; i < seq.images.size(); ++i) {
      const ImageU8& im = seq.images[i];
      if (im.channels() != 3 || im.width() != seq.camera.width ||
          im.height() != seq.camera.height) {
        std::ostringstream msg;
        msg << "training data " << seq.name << " frame " << i << ": image is " << im.width() << "x"
            << im.height() << "x" << im.channels() << ", expected RGB " << seq.camera.width << "x"
            << seq.camera.height << " (the sequence's camera)";
        throw InputError(msg.str());
      }
    }
    if (!seq.world_from_cam.empty() && seq.world_from_cam.size() != seq.images.size()) {
      std::ostringstream msg;
      msg << "training data " << seq.name << ": " << seq.world_from_cam.size()
          << " ground-truth poses for " << seq.images.size() << " images (need one each, or none)";
      throw InputError(msg.str());
    }
    if (options_.pose_source == TrainingOptions::PoseSource::kGroundTruth &&
        seq.world_from_cam.empty()) {
      throw InputError("training data " + seq.name +
                       ": no ground-truth poses, but gn.pose_source = ground_truth needs them "
                       "(KITTI layout: poses/<sequence>.txt)");
    }
    if (!seq.depth_targets.empty() && seq.depth_targets.size() != seq.images.size()) {
      std::ostringstream msg;
      msg << "training data " << seq.name << ": depth targets for " << seq.depth_targets.size()
          << " images of " << seq.images.size() << " (need one list each, or none)";
      throw InputError(msg.str());
    }
    for (size_t i = 0; i < seq.depth_targets.size(); ++i) {
      for (const DepthTarget& t : seq.depth_targets[i]) {
        if (!(t.depth_m > 0.0f) || !std::isfinite(t.depth_m) || !(t.weight > 0.0f) ||
            !std::isfinite(t.weight) || !std::isfinite(t.u) || !std::isfinite(t.v)) {
          std::ostringstream msg;
          msg << "training data " << seq.name << " frame " << i << ": depth target at (" << t.u
              << ", " << t.v << ") with depth " << t.depth_m << " and weight " << t.weight
              << ", expected finite, positive values";
          throw InputError(msg.str());
        }
      }
    }
    if (seq.camera.width != w || seq.camera.height != h) {
      const PinholeCamera resized = seq.camera.Resized(w, h);
      for (auto& targets : seq.depth_targets) targets = MoveTargets(targets, seq.camera, resized);
      // Resize to the training size (bilinear, pixel-centre convention as Resized()).
      for (ImageU8& im : seq.images) {
        const torch::Tensor t =
            F::interpolate(ImageToTensor(im), F::InterpolateFuncOptions()
                                                  .size(std::vector<int64_t>{h, w})
                                                  .mode(torch::kBilinear)
                                                  .align_corners(false));
        const torch::Tensor u8 = (t.squeeze(0).permute({1, 2, 0}) * 255.0)
                                     .round()
                                     .clamp(0, 255)
                                     .to(torch::kUInt8)
                                     .contiguous();
        ImageU8 out(w, h, 3);
        std::copy(u8.data_ptr<uint8_t>(), u8.data_ptr<uint8_t>() + u8.numel(), out.data());
        im = std::move(out);
      }
      seq.camera = seq.camera.Resized(w, h);
    }
    // Snippets (t-1, t, t+1) whose target moved relative to both neighbours.
    auto grey = [&](size_t i) {
      return torch::from_blob(seq.images[i].data(), {h, w, 3}, torch::kUInt8).permute({2, 0, 1});
    };
    for (size_t i = 1; i + 1 < seq.images.size(); ++i) {
      if (options_.static_threshold > 0.0) {
        const double a = MeanAbsGrey(grey(i - 1), grey(i)).item<double>();
        const double b = MeanAbsGrey(grey(i), grey(i + 1)).item<double>();
        if (a < options_.static_threshold || b < options_.static_threshold) continue;
      }
      snippets_.push_back({static_cast<int>(s), static_cast<int>(i)});
    }
  }
  if (snippets_.empty()) {
    throw InputError(
        "training data: no usable 3-frame snippet (need sequences of >= 3 frames whose "
        "consecutive frames differ by more than train.static_threshold)");
  }
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

Trainer::Batch Trainer::MakeBatch(int iteration) const {
  std::mt19937_64 rng(StepSeed(options_.seed, iteration, 0));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int w = options_.network.input_width, h = options_.network.input_height;
  std::vector<torch::Tensor> frames[3];
  std::vector<float> intrinsics;
  std::vector<float> gt_rotation[2], gt_translation[2];
  Batch batch;
  batch.has_ground_truth = true;
  for (int b = 0; b < options_.batch_size; ++b) {
    const Snippet& snip =
        snippets_[static_cast<size_t>(unit(rng) * snippets_.size()) % snippets_.size()];
    const TrainingSequence& seq = data_[snip.sequence];
    batch.snippets.push_back(snip);
    if (seq.world_from_cam.empty()) {
      batch.has_ground_truth = false;
    } else {
      // source_from_target = cam_from_world(source) * world_from_cam(target). Cropping and
      // resizing change the intrinsics only.
      const SE3d& world_from_target = seq.world_from_cam[snip.index];
      for (int s = 0; s < 2; ++s) {
        const SE3d source_from_target =
            seq.world_from_cam[snip.index + (s == 0 ? -1 : 1)].Inverse() * world_from_target;
        const Eigen::Matrix3d r = source_from_target.rotationMatrix();
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) gt_rotation[s].push_back(static_cast<float>(r(i, j)));
          gt_translation[s].push_back(static_cast<float>(source_from_target.translation()(i)));
        }
      }
    }
    PinholeCamera camera = seq.camera;
    torch::Tensor images = torch::cat({ImageToTensor(seq.images[snip.index - 1]),
                                       ImageToTensor(seq.images[snip.index]),
                                       ImageToTensor(seq.images[snip.index + 1])});
    if (options_.augment.enabled) {
      // Random scale in [1, max_scale] and crop back to w x h (SfMLearner's data augmentation).
      const double scale = 1.0 + unit(rng) * (options_.augment.max_scale - 1.0);
      const int sw = std::max(w, static_cast<int>(std::lround(w * scale)));
      const int sh = std::max(h, static_cast<int>(std::lround(h * scale)));
      const int x0 = static_cast<int>(unit(rng) * (sw - w + 1)) % (sw - w + 1);
      const int y0 = static_cast<int>(unit(rng) * (sh - h + 1)) % (sh - h + 1);
      if (sw != w || sh != h) {
        images = F::interpolate(images, F::InterpolateFuncOptions()
                                            .size(std::vector<int64_t>{sh, sw})
                                            .mode(torch::kBilinear)
                                            .align_corners(false));
        images = images.slice(2, y0, y0 + h).slice(3, x0, x0 + w);
        camera = camera.Resized(sw, sh).Cropped(x0, y0, w, h);
      }
      // Photometric: gamma, brightness and per-channel colour factors in [min, max], drawn
      // with color_probability (the paper's 50% chance).
      const double draw = unit(rng);
      const double lo = options_.augment.color_min, hi = options_.augment.color_max;
      const double gamma = lo + unit(rng) * (hi - lo);
      const double brightness = lo + unit(rng) * (hi - lo);
      const float colour[3] = {static_cast<float>(lo + unit(rng) * (hi - lo)),
                               static_cast<float>(lo + unit(rng) * (hi - lo)),
                               static_cast<float>(lo + unit(rng) * (hi - lo))};
      if (draw < options_.augment.color_probability) {
        const torch::Tensor factors =
            torch::tensor({colour[0], colour[1], colour[2]}).view({1, 3, 1, 1}) * brightness;
        images = (images.pow(gamma) * factors).clamp(0.0, 1.0);
      }
    }
    for (int k = 0; k < 3; ++k) frames[k].push_back(images[k]);
    torch::Tensor targets;
    if (!seq.depth_targets.empty()) {
      targets = TargetsToTensor(MoveTargets(seq.depth_targets[snip.index], seq.camera, camera));
      if (targets.defined()) targets = targets.to(device_);
    }
    batch.teacher_targets.push_back(targets);
    intrinsics.insert(intrinsics.end(),
                      {static_cast<float>(camera.fx), static_cast<float>(camera.fy),
                       static_cast<float>(camera.cx), static_cast<float>(camera.cy)});
    batch.cameras.push_back(camera);
  }
  // Drawn and augmented on the CPU (the same batch on every device), moved to the device once.
  const auto format =
      options_.channels_last ? torch::MemoryFormat::ChannelsLast : torch::MemoryFormat::Contiguous;
  batch.previous = torch::stack(frames[0]).to(device_).contiguous(format);
  batch.target = torch::stack(frames[1]).to(device_).contiguous(format);
  batch.next = torch::stack(frames[2]).to(device_).contiguous(format);
  batch.intrinsics = torch::tensor(intrinsics).view({options_.batch_size, 4}).to(device_);
  if (batch.has_ground_truth) {
    for (int s = 0; s < 2; ++s) {
      batch.gt_rotation[s] =
          torch::tensor(gt_rotation[s]).view({options_.batch_size, 3, 3}).to(device_);
      batch.gt_translation[s] =
          torch::tensor(gt_translation[s]).view({options_.batch_size, 3}).to(device_);
    }
  }
  return batch;
}

StepRecord Trainer::AeStep(const Batch& batch) {
  StepRecord rec;
  rec.stage = "ae";
  const int levels = options_.network.num_levels;
  const FeatureNetOutput out = networks_->feature->forward(batch.target);
  const std::vector<torch::Tensor> recon = networks_->feature->Reconstruct(out.features);
  const std::vector<torch::Tensor> pyramid = ImagePyramid(batch.target, levels);
  at::Generator gen =
      at::make_generator<at::CPUGeneratorImpl>(StepSeed(options_.seed, iteration_, 1));
  torch::Tensor reconstruction = torch::zeros({}, batch.target.options());
  torch::Tensor sparsity = torch::zeros({}, batch.target.options());
  rec.temperature = TemperatureAt(iteration_);
  for (int l = 0; l < levels; ++l) {
    reconstruction = reconstruction + ReconstructionLoss(recon[l], pyramid[l]) / levels;
    const torch::Tensor mask = GumbelSigmoid(out.mask_logits[l], rec.temperature, gen);
    sparsity = sparsity + SparsityLoss(mask, options_.network.rho[l]);
  }
  // The AE stage trains on reconstruction alone (weight 1) plus the masks' sparsity.
  const torch::Tensor total = reconstruction + options_.loss.sparsity_weight * sparsity;
  optimizer_->zero_grad();
  total.backward();
  ClippedStep(iteration_);
  rec.total = total.item<double>();
  rec.reconstruction = reconstruction.item<double>();
  rec.sparsity = sparsity.item<double>();
  rec.gn_ok_ratio = 0.0;
  return rec;
}

StepRecord Trainer::JointStep(const Batch& batch, int iteration) {
  StepRecord rec;
  rec.stage = "joint";
  const int levels = options_.network.num_levels;
  const int n = options_.batch_size;
  rec.temperature = TemperatureAt(iteration);
  at::Generator gen =
      at::make_generator<at::CPUGeneratorImpl>(StepSeed(options_.seed, iteration, 1));

  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  const torch::TensorOptions float_options = batch.target.options();  // float, on the device
  const DepthNetOutput raw_depth = networks_->depth->forward(batch.target);
  torch::Tensor scale_prior = torch::zeros({}, float_options);
  torch::Tensor gauge_factor;
  const std::vector<torch::Tensor> depth_levels =
      NormaliseDepthScale(raw_depth.depth, options_.loss, &scale_prior, &gauge_factor);
  // The sources' own depth (finest level) in the target's gauge, for the geometry consistency.
  torch::Tensor source_depth[2];
  if (options_.loss.depth_consistency_weight > 0.0) {
    const torch::Tensor both =
        networks_->depth->forward(torch::cat({batch.previous, batch.next}, 0)).depth[0];
    for (int s = 0; s < 2; ++s) source_depth[s] = both.narrow(0, s * n, n) * gauge_factor;
  }
  // Depth targets (teacher.h) on the raw output, each sample's run at its fitted scale.
  torch::Tensor teacher = torch::zeros({}, float_options);
  std::vector<double> teacher_offsets;
  if (options_.loss.teacher_weight > 0.0) {
    std::vector<double> log_scales;
    for (const Snippet& snip : batch.snippets) {
      log_scales.push_back(teacher_log_scales_[static_cast<size_t>(snip.sequence)]);
    }
    teacher = TeacherDepthLoss(raw_depth.depth[0], batch.teacher_targets, log_scales,
                               options_.loss.teacher_huber, &teacher_offsets);
  }
  DepthNetOutput depth = raw_depth;
  depth.depth = depth_levels;
  const bool ground_truth_poses = options_.pose_source == TrainingOptions::PoseSource::kGroundTruth;
  const FeatureNetOutput target = networks_->feature->forward(batch.target);
  FeatureNetOutput sources[2];
  {
    std::unique_ptr<torch::NoGradGuard> no_grad;
    if (!options_.source_feature_grad) no_grad = std::make_unique<torch::NoGradGuard>();
    sources[0] = networks_->feature->forward(batch.previous);
    sources[1] = networks_->feature->forward(batch.next);
  }
  std::vector<torch::Tensor> masks(levels), target_z(levels), source_z[2];
  torch::Tensor sparsity = torch::zeros({}, float_options);
  for (int l = 0; l < levels; ++l) {
    masks[l] = GumbelSigmoid(target.mask_logits[l], rec.temperature, gen);
    sparsity = sparsity + SparsityLoss(masks[l], options_.network.rho[l]);
    target_z[l] = ZScore(target.features[l].contiguous());
    for (int s = 0; s < 2; ++s) source_z[s].push_back(ZScore(sources[s].features[l].contiguous()));
  }

  const auto t1 = Clock::now();
  // Poses source_from_target by the differentiable alignment, per sample and source (or, as a
  // diagnostic, the ground truth).
  torch::Tensor rotation[2], translation[2];
  // 1 where the sample's pose toward source s is usable (the alignment succeeded).
  torch::Tensor pose_ok[2] = {torch::ones({n}, float_options), torch::ones({n}, float_options)};
  if (ground_truth_poses) {
    DFO_CHECK(batch.has_ground_truth);
    for (int s = 0; s < 2; ++s) {
      rotation[s] = batch.gt_rotation[s];
      translation[s] = batch.gt_translation[s];
    }
    rec.gn_ok_ratio = 0.0;
  } else {
    std::vector<torch::Tensor> rotations[2], translations[2];
    int gn_ok = 0;
    double sum_rotation_error = 0.0, sum_direction_error = 0.0;
    int num_rotation_errors = 0, num_direction_errors = 0;
    const bool handmade = iteration - options_.ae_iterations < options_.gn_handmade_iterations;
    for (int b = 0; b < n; ++b) {
      AlignmentView ref;
      std::vector<torch::Tensor> handmade_views[3];
      if (handmade) {
        const torch::Tensor* images[3] = {&batch.target, &batch.previous, &batch.next};
        for (int v = 0; v < 3; ++v) {
          handmade_views[v] = HandmadePyramid((*images[v])[b], batch.cameras[b], levels);
        }
      }
      for (int l = 0; l < levels; ++l) {
        ref.features.push_back(handmade ? handmade_views[0][l] : target_z[l][b]);
        ref.cameras.push_back(batch.cameras[b].PyramidLevel(l));
        ref.depth.push_back(depth.depth[l][b][0]);
        if (options_.gn_use_masks) ref.masks.push_back(masks[l][b][0]);
      }
      for (int s = 0; s < 2; ++s) {
        AlignmentView cur;
        cur.cameras = ref.cameras;
        for (int l = 0; l < levels; ++l) {
          cur.features.push_back(handmade ? handmade_views[1 + s][l] : source_z[s][l][b]);
        }
        const DiffGnResult gn =
            DifferentiableAlign(ref, cur, PoseTensor::FromSE3(SE3d()), options_.gn);
        pose_ok[s][b] = gn.ok ? 1.0 : 0.0;
        if (gn.ok) {
          ++gn_ok;
          rotations[s].push_back(gn.cur_from_ref.rotation.to(torch::kFloat32));
          translations[s].push_back(gn.cur_from_ref.translation.to(torch::kFloat32));
          if (batch.has_ground_truth) {
            // Diagnostic only: the alignment's pose against the ground truth.
            const PoseError e = ComparePoses(
                gn.cur_from_ref.ToSE3(), PoseTensor{batch.gt_rotation[s][b].to(torch::kFloat64),
                                                    batch.gt_translation[s][b].to(torch::kFloat64)}
                                             .ToSE3());
            sum_rotation_error += e.rotation_deg;
            ++num_rotation_errors;
            if (std::isfinite(e.direction_deg)) {
              sum_direction_error += e.direction_deg;
              ++num_direction_errors;
            }
          }
        } else {
          // A failed alignment contributes no pose gradient: the identity warp does not depend
          // on the depth or the features, so the sample only adds a constant to the loss.
          rotations[s].push_back(torch::eye(3, float_options));
          translations[s].push_back(torch::zeros({3}, float_options));
        }
      }
    }
    for (int s = 0; s < 2; ++s) {
      rotation[s] = torch::stack(rotations[s]);
      translation[s] = torch::stack(translations[s]);
      if (!options_.pose_gradient) {
        rotation[s] = rotation[s].detach();
        translation[s] = translation[s].detach();
      }
    }
    rec.gn_ok_ratio = static_cast<double>(gn_ok) / (2.0 * n);
    if (num_rotation_errors > 0)
      rec.pose_rotation_error_deg = sum_rotation_error / num_rotation_errors;
    if (num_direction_errors > 0) {
      rec.pose_direction_error_deg = sum_direction_error / num_direction_errors;
    }
  }
  const auto t2 = Clock::now();

  // Appearance (minimum over the sources) and smoothness over the levels.
  const std::vector<torch::Tensor> targets = ImagePyramid(batch.target, levels);
  const torch::Tensor appearance =
      ViewSynthesisLoss(batch, depth.depth, rotation, translation, options_.loss);
  torch::Tensor smoothness = torch::zeros({}, float_options);
  for (int l = 0; l < levels; ++l) {
    const double scale = 1.0 / (1 << l);
    const torch::Tensor disparity = 10.0 * depth.sigmoid[l] + 0.01;
    smoothness = smoothness + SmoothnessLoss(disparity, targets[l]) * scale;
  }
  torch::Tensor consistency = torch::zeros({}, float_options);
  if (options_.loss.depth_consistency_weight > 0.0) {
    for (int s = 0; s < 2; ++s) {
      consistency =
          consistency + 0.5 * DepthConsistencyLoss(depth.depth[0].contiguous(),
                                                   source_depth[s].contiguous(), rotation[s],
                                                   translation[s], batch.intrinsics, pose_ok[s]);
    }
  }
  torch::Tensor reconstruction = torch::zeros({}, float_options);
  if (options_.loss.ae_weight > 0.0) {
    const std::vector<torch::Tensor> recon = networks_->feature->Reconstruct(target.features);
    for (int l = 0; l < levels; ++l) {
      reconstruction = reconstruction + ReconstructionLoss(recon[l], targets[l]) / levels;
    }
  }
  const torch::Tensor total =
      appearance + options_.loss.smooth_weight * smoothness +
      options_.loss.sparsity_weight * sparsity + options_.loss.ae_weight * reconstruction +
      options_.loss.depth_prior_weight * scale_prior +
      options_.loss.depth_consistency_weight * consistency + options_.loss.teacher_weight * teacher;
  optimizer_->zero_grad();
  const auto t3 = Clock::now();
  total.backward();
  ClippedStep(iteration_);
  const auto t4 = Clock::now();
  if (std::getenv("DFO_TRAIN_PROFILE") != nullptr) {
    auto ms = [](Clock::time_point a, Clock::time_point b) {
      return std::chrono::duration<double, std::milli>(b - a).count();
    };
    std::fprintf(stderr,
                 "joint step ms: networks %.0f, alignment %.0f, warp+losses %.0f, "
                 "backward+adam %.0f\n",
                 ms(t0, t1), ms(t1, t2), ms(t2, t3), ms(t3, t4));
  }
  rec.total = total.item<double>();
  rec.appearance = appearance.item<double>();
  rec.smoothness = smoothness.item<double>();
  rec.sparsity = sparsity.item<double>();
  rec.reconstruction = reconstruction.item<double>();
  rec.consistency = consistency.item<double>();
  rec.teacher = teacher.item<double>();
  // Each run's scale follows the median offsets of its samples in this batch.
  std::map<int, std::vector<double>> offsets_by_sequence;
  for (size_t b = 0; b < teacher_offsets.size(); ++b) {
    if (std::isfinite(teacher_offsets[b])) {
      offsets_by_sequence[batch.snippets[b].sequence].push_back(teacher_offsets[b]);
    }
  }
  for (auto& [sequence, offsets] : offsets_by_sequence) {
    std::nth_element(offsets.begin(), offsets.begin() + offsets.size() / 2, offsets.end());
    double& s = teacher_log_scales_[static_cast<size_t>(sequence)];
    const double o = offsets[offsets.size() / 2];
    s = std::isfinite(s) ? 0.9 * s + 0.1 * o : o;
  }
  rec.mean_depth = raw_depth.depth[0].detach().median().item<double>();
  return rec;
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

void Trainer::SaveCheckpoint(const std::string& path) const {
  torch::serialize::OutputArchive archive;
  torch::serialize::OutputArchive nets, optim;
  networks_->save(nets);
  optimizer_->save(optim);
  archive.write("networks", nets);
  archive.write("optimizer", optim);
  archive.write("iteration", torch::tensor(static_cast<int64_t>(iteration_)));
  archive.write("shape", c10::IValue(ShapeSignature(options_.network)));
  torch::Tensor h =
      torch::zeros({static_cast<int64_t>(history_.size()), kHistoryColumns}, torch::kFloat64);
  auto a = h.accessor<double, 2>();
  for (size_t i = 0; i < history_.size(); ++i) {
    const StepRecord& r = history_[i];
    const double row[kHistoryColumns] = {static_cast<double>(r.iteration),
                                         r.stage == "ae" ? 0.0 : 1.0,
                                         r.total,
                                         r.appearance,
                                         r.smoothness,
                                         r.sparsity,
                                         r.reconstruction,
                                         r.learning_rate,
                                         r.temperature,
                                         r.gn_ok_ratio,
                                         r.mean_depth,
                                         r.seconds,
                                         r.pose_rotation_error_deg,
                                         r.pose_direction_error_deg,
                                         r.consistency,
                                         r.teacher};
    for (int c = 0; c < kHistoryColumns; ++c) a[i][c] = row[c];
  }
  archive.write("history", h);
  archive.write("teacher_log_scales",
                torch::tensor(teacher_log_scales_, torch::TensorOptions().dtype(torch::kFloat64)));
  const std::string tmp = path + ".tmp";
  try {
    archive.save_to(tmp);
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + tmp + ": cannot be written (" + e.what_without_backtrace() +
                     ")");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    throw InputError("checkpoint " + path + ": cannot rename " + tmp + " to it");
  }
}

namespace {

// Opens a checkpoint with every tensor mapped to `device` (checkpoints hold the tensors of the
// device they were trained on: one written on a GPU loads on a CPU-only machine).
torch::serialize::InputArchive OpenCheckpoint(const std::string& path,
                                              const torch::Device& device) {
  // A checkpoint changed after it was written (a disk error, a copy cut short) is refused before
  // training resumes from it.
  CheckZipArchive(path, "checkpoint " + path);
  torch::serialize::InputArchive archive;
  try {
    archive.load_from(path, device);
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + path + ": not a dfo_train checkpoint or unreadable (" +
                     std::string(e.what_without_backtrace()).substr(0, 200) + ")");
  }
  return archive;
}

void CheckShape(torch::serialize::InputArchive& archive, const std::string& path,
                const NetworkOptions& options) {
  c10::IValue shape;
  if (!archive.try_read("shape", shape) || !shape.isString()) {
    throw InputError("checkpoint " + path + ": no 'shape' record; not a dfo_train checkpoint");
  }
  const std::string expected = ShapeSignature(options);
  if (shape.toStringRef() != expected) {
    throw InputError("checkpoint " + path + ": networks are " + shape.toStringRef() +
                     " but the configuration asks for " + expected);
  }
}

}  // namespace

void Trainer::LoadCheckpoint(const std::string& path) {
  torch::serialize::InputArchive archive = OpenCheckpoint(path, device_);
  CheckShape(archive, path, options_.network);
  try {
    torch::serialize::InputArchive nets, optim;
    archive.read("networks", nets);
    archive.read("optimizer", optim);
    networks_->load(nets);
    if (options_.channels_last) ToChannelsLast(*networks_);
    optimizer_->load(optim);
    torch::Tensor it, h;
    archive.read("iteration", it);
    archive.read("history", h);
    iteration_ = static_cast<int>(it.item<int64_t>());
    history_.clear();
    h = h.to(torch::kCPU, torch::kFloat64).contiguous();
    auto a = h.accessor<double, 2>();
    for (int64_t i = 0; i < h.size(0); ++i) {
      StepRecord r;
      r.iteration = static_cast<int>(a[i][0]);
      r.stage = a[i][1] == 0.0 ? "ae" : "joint";
      r.total = a[i][2];
      r.appearance = a[i][3];
      r.smoothness = a[i][4];
      r.sparsity = a[i][5];
      r.reconstruction = a[i][6];
      r.learning_rate = a[i][7];
      r.temperature = a[i][8];
      r.gn_ok_ratio = a[i][9];
      r.mean_depth = a[i][10];
      r.seconds = a[i][11];
      if (h.size(1) >= kPoseErrorColumns) {
        r.pose_rotation_error_deg = a[i][12];
        r.pose_direction_error_deg = a[i][13];
      }
      if (h.size(1) >= kConsistencyColumns) r.consistency = a[i][14];
      if (h.size(1) >= kHistoryColumns) r.teacher = a[i][15];
      history_.push_back(r);
    }
    // Checkpoints from before depth targets have no run scales: they are fitted afresh.
    torch::Tensor scales;
    if (archive.try_read("teacher_log_scales", scales) &&
        scales.numel() == static_cast<int64_t>(teacher_log_scales_.size())) {
      scales = scales.to(torch::kCPU, torch::kFloat64).contiguous();
      for (int64_t i = 0; i < scales.numel(); ++i) {
        teacher_log_scales_[static_cast<size_t>(i)] = scales.data_ptr<double>()[i];
      }
    }
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + path + ": " +
                     std::string(e.what_without_backtrace()).substr(0, 300));
  }
}

void Trainer::LoadWeights(const std::string& path) {
  torch::serialize::InputArchive archive = OpenCheckpoint(path, device_);
  CheckShape(archive, path, options_.network);
  try {
    torch::serialize::InputArchive nets;
    archive.read("networks", nets);
    networks_->load(nets);
    if (options_.channels_last) ToChannelsLast(*networks_);
  } catch (const c10::Error& e) {
    throw InputError("checkpoint " + path + ": " +
                     std::string(e.what_without_backtrace()).substr(0, 300));
  }
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

void WriteHistoryCsv(const std::string& path, const std::vector<StepRecord>& history) {
  std::ofstream out(path);
  if (!out) throw InputError("loss history " + path + ": cannot be written");
  out << "iteration,stage,total,appearance,smoothness,sparsity,reconstruction,learning_rate,"
         "temperature,gn_ok_ratio,mean_depth_m,seconds,pose_rotation_error_deg,"
         "pose_direction_error_deg,consistency,teacher\n";
  out.precision(9);
  for (const StepRecord& r : history) {
    out << r.iteration << "," << r.stage << "," << r.total << "," << r.appearance << ","
        << r.smoothness << "," << r.sparsity << "," << r.reconstruction << "," << r.learning_rate
        << "," << r.temperature << "," << r.gn_ok_ratio << "," << r.mean_depth << "," << r.seconds
        << "," << r.pose_rotation_error_deg << "," << r.pose_direction_error_deg << ","
        << r.consistency << "," << r.teacher << "\n";
  }
  if (!out) throw InputError("loss history " + path + ": write failed");
}

std::vector<StepRecord> ReadHistoryCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError("loss history " + path + ": cannot be read");
  std::vector<StepRecord> out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 || line.empty()) continue;
    std::stringstream ss(line);
    std::string field;
    std::vector<std::string> f;
    while (std::getline(ss, field, ',')) f.push_back(field);
    if (f.size() != kHistoryColumns && f.size() != kConsistencyColumns &&
        f.size() != kPoseErrorColumns && f.size() != kOldHistoryColumns) {
      std::ostringstream msg;
      msg << "loss history " << path << ":" << line_no << ": " << f.size() << " fields, expected "
          << kHistoryColumns;
      throw InputError(msg.str());
    }
    try {
      StepRecord r;
      r.iteration = std::stoi(f[0]);
      r.stage = f[1];
      r.total = std::stod(f[2]);
      r.appearance = std::stod(f[3]);
      r.smoothness = std::stod(f[4]);
      r.sparsity = std::stod(f[5]);
      r.reconstruction = std::stod(f[6]);
      r.learning_rate = std::stod(f[7]);
      r.temperature = std::stod(f[8]);
      r.gn_ok_ratio = std::stod(f[9]);
      r.mean_depth = std::stod(f[10]);
      r.seconds = std::stod(f[11]);
      if (f.size() >= kPoseErrorColumns) {
        r.pose_rotation_error_deg = std::stod(f[12]);
        r.pose_direction_error_deg = std::stod(f[13]);
      }
      if (f.size() >= kConsistencyColumns) r.consistency = std::stod(f[14]);
      if (f.size() >= kHistoryColumns) r.teacher = std::stod(f[15]);
      out.push_back(r);
    } catch (const std::exception&) {
      std::ostringstream msg;
      msg << "loss history " << path << ":" << line_no << ": not a number in '" << line << "'";
      throw InputError(msg.str());
    }
  }
  return out;
}

}  // namespace dfo::learned
