// The trainer's data: checking and resizing the sequences, listing snippets, drawing and
// augmenting batches (SfMLearner's random scale and crop, the paper's colour augmentation), and
// the image and hand-made feature tensors.
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_core/frame.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/learned/internal/teacher.h"
#include "dfo_frontend/learned/internal/training.h"
#include "dfo_frontend/learned/internal/training_parts.h"

namespace dfo::learned {

namespace F = torch::nn::functional;

namespace {

torch::Tensor MeanAbsGrey(const torch::Tensor& a, const torch::Tensor& b) {
  return (a.to(torch::kFloat32).mean(0) - b.to(torch::kFloat32).mean(0)).abs().mean() / 255.0;
}

}  // namespace

namespace {

// SplitMix64.
uint64_t Mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}
}  // namespace

uint64_t StepSeed(uint64_t seed, int iteration, uint64_t purpose) {
  return Mix(Mix(seed) ^ Mix(static_cast<uint64_t>(iteration) * 4 + purpose));
}

void PrepareTrainingData(const TrainingOptions& options, std::vector<TrainingSequence>* data,
                         std::vector<Snippet>* snippets) {
  const int w = options.network.input_width, h = options.network.input_height;
  for (size_t s = 0; s < data->size(); ++s) {
    TrainingSequence& seq = (*data)[s];
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
    if (options.pose_source == TrainingOptions::PoseSource::kGroundTruth &&
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
      if (options.static_threshold > 0.0) {
        const double a = MeanAbsGrey(grey(i - 1), grey(i)).item<double>();
        const double b = MeanAbsGrey(grey(i), grey(i + 1)).item<double>();
        if (a < options.static_threshold || b < options.static_threshold) continue;
      }
      snippets->push_back({static_cast<int>(s), static_cast<int>(i)});
    }
  }
  if (snippets->empty()) {
    throw InputError(
        "training data: no usable 3-frame snippet (need sequences of >= 3 frames whose "
        "consecutive frames differ by more than train.static_threshold)");
  }
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

}  // namespace dfo::learned
