// One iteration of each stage: the autoencoder stage (reconstruction and mask sparsity) and the
// joint stage (depth, features and masks through the differentiable alignment and view
// synthesis).
#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>

#include "dfo_core/error.h"
#include "dfo_frontend/learned/internal/teacher.h"
#include "dfo_frontend/learned/internal/training.h"
#include "dfo_frontend/learned/internal/training_parts.h"

namespace dfo::learned {

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

  // Poses source_from_target by the differentiable alignment, per sample and source (or, as a
  // diagnostic, the ground truth); pose_ok[s] is 1 where the sample's pose toward source s is
  // usable (the alignment succeeded).
  torch::Tensor rotation[2], translation[2];
  torch::Tensor pose_ok[2] = {torch::ones({n}, float_options), torch::ones({n}, float_options)};
  AlignSnippets(batch, iteration, depth.depth, masks, target_z, source_z, rotation, translation,
                pose_ok, &rec);

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
  total.backward();
  ClippedStep(iteration_);
  rec.total = total.item<double>();
  rec.appearance = appearance.item<double>();
  rec.smoothness = smoothness.item<double>();
  rec.sparsity = sparsity.item<double>();
  rec.reconstruction = reconstruction.item<double>();
  rec.consistency = consistency.item<double>();
  rec.teacher = teacher.item<double>();
  UpdateTeacherScales(batch, teacher_offsets);
  rec.mean_depth = raw_depth.depth[0].detach().median().item<double>();
  return rec;
}

void Trainer::AlignSnippets(const Batch& batch, int iteration,
                            const std::vector<torch::Tensor>& depth,
                            const std::vector<torch::Tensor>& masks,
                            const std::vector<torch::Tensor>& target_z,
                            const std::vector<torch::Tensor> source_z[2], torch::Tensor rotation[2],
                            torch::Tensor translation[2], torch::Tensor pose_ok[2],
                            StepRecord* rec) const {
  const int levels = options_.network.num_levels;
  const int n = options_.batch_size;
  const torch::TensorOptions float_options = batch.target.options();
  const bool ground_truth_poses = options_.pose_source == TrainingOptions::PoseSource::kGroundTruth;
  if (ground_truth_poses) {
    DFO_CHECK(batch.has_ground_truth);
    for (int s = 0; s < 2; ++s) {
      rotation[s] = batch.gt_rotation[s];
      translation[s] = batch.gt_translation[s];
    }
    rec->gn_ok_ratio = 0.0;
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
        ref.depth.push_back(depth[l][b][0]);
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
    rec->gn_ok_ratio = static_cast<double>(gn_ok) / (2.0 * n);
    if (num_rotation_errors > 0)
      rec->pose_rotation_error_deg = sum_rotation_error / num_rotation_errors;
    if (num_direction_errors > 0) {
      rec->pose_direction_error_deg = sum_direction_error / num_direction_errors;
    }
  }
}

void Trainer::UpdateTeacherScales(const Batch& batch, const std::vector<double>& offsets) {
  // Each run's scale follows the median offsets of its samples in this batch.
  std::map<int, std::vector<double>> offsets_by_sequence;
  for (size_t b = 0; b < offsets.size(); ++b) {
    if (std::isfinite(offsets[b])) {
      offsets_by_sequence[batch.snippets[b].sequence].push_back(offsets[b]);
    }
  }
  for (auto& [sequence, sample_offsets] : offsets_by_sequence) {
    std::nth_element(sample_offsets.begin(), sample_offsets.begin() + sample_offsets.size() / 2,
                     sample_offsets.end());
    double& s = teacher_log_scales_[static_cast<size_t>(sequence)];
    const double o = sample_offsets[sample_offsets.size() / 2];
    s = std::isfinite(s) ? 0.9 * s + 0.1 * o : o;
  }
}

}  // namespace dfo::learned
