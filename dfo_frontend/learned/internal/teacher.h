// Depth targets from the system's own geometry: the depths that a run's window settled on
// (dfo_run run.write_keyframe_depth), taught to the depth network with one free scale per run
// ("supervising the new with the old", Klodt & Vedaldi 2018; still self-supervised: no ground
// truth enters). Internal header (includes <torch/torch.h>).
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_TEACHER_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_TEACHER_H_

#include <torch/torch.h>

#include <vector>

#include "dfo_core/camera.h"

namespace dfo::learned {

// A sparse depth target of a training image: pixel (the image's camera convention, centres at
// integers), depth in its run's scale (> 0), weight (> 0).
struct DepthTarget {
  float u = 0.0f, v = 0.0f;
  float depth_m = 0.0f;
  float weight = 1.0f;
};

// Targets of a view seen through camera `from` moved into camera `to` of the same view (a
// resize and crop: the same rays, other intrinsics); those that land outside `to`'s image are
// dropped.
std::vector<DepthTarget> MoveTargets(const std::vector<DepthTarget>& targets,
                                     const PinholeCamera& from, const PinholeCamera& to);

// Targets as a tensor M x 4 (u, v, depth_m, weight), float, on the CPU; undefined when empty.
torch::Tensor TargetsToTensor(const std::vector<DepthTarget>& targets);

// The teacher term of a batch: sum over samples b and their targets i of
// w_i huber(log D_b(u_i, v_i) + s_b - log d_i, delta) / sum w_i, where D_b is sample b's depth
// (`depth` N x 1 x H x W, metres, the network's raw output) sampled bilinearly at the target's
// pixel, s_b = log_scales[b] the log factor from the network's scale to the run's, and huber the
// Huber function on the log-depth residual (quadratic below delta). `targets[b]` is sample b's
// M_b x 4 tensor on depth's device (undefined: none). *offsets[b] receives the median of
// log d_i - log D_b(u_i, v_i) over sample b's targets (NaN when it has none), from which the
// caller keeps each run's scale. A 0-dim zero when no sample has targets.
torch::Tensor TeacherDepthLoss(const torch::Tensor& depth,
                               const std::vector<torch::Tensor>& targets,
                               const std::vector<double>& log_scales, double delta,
                               std::vector<double>* offsets);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_TEACHER_H_
