// Self-supervised training of the DFO networks (dfo_train's engine): data (3-frame snippets from
// sequences held in memory, static frames skipped, the paper's augmentation), the stagewise loss
// (autoencoder first, then joint), the pose from the differentiable Gauss-Newton alignment, Adam
// with a geometric learning-rate schedule, checkpoints with resume, and the loss history.
//
// Internal header (includes <torch/torch.h>). dfo_frontend must not use dfo_io, so the caller
// (apps/dfo_train.cc) reads the sequences from disk and hands them over as TrainingSequence.
//
// One iteration of the joint stage, for a batch of snippets (I_{t-1}, I_t, I_{t+1}):
//   depth pyramid D_l = DepthNet(I_t); features and mask logits of all three frames (FeatureNet,
//   Siamese); soft masks of the target by Gumbel-sigmoid; per sample and source s, the pose
//   s_from_t = DifferentiableAlign(target features z-scored + D, source features z-scored) from
//   the identity; per level l: the sources warped into the target with D_l and that pose, the
//   per-pixel minimum over the two sources of the clamped DSSIM + L1 appearance error (Monodepth2's
//   minimum reprojection: a pixel occluded in one source is usually visible in the other), plus
//   lambda_sm / 2^l edge-aware smoothness of the disparity 1 / D_l; lambda_sp KL sparsity of every
//   level's mask toward rho_l; lambda_ae autoencoder reconstruction. Scale gauge (not in the
//   paper): D is normalised to a batch geometric mean of loss.depth_mean_m before the alignment
//   and the warping, and a weak prior holds the raw geometric mean there; without it the
//   unobservable scale drifted to the sigmoid's saturated end (0.1 m after 20 iterations).
// The autoencoder stage trains the feature network alone on reconstruction + sparsity.
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_TRAINING_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_TRAINING_H_

#include <torch/torch.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"
#include "dfo_core/lie.h"
#include "dfo_frontend/learned/internal/diff_gn.h"
#include "dfo_frontend/learned/internal/losses.h"
#include "dfo_frontend/learned/internal/networks.h"
#include "dfo_frontend/learned/internal/teacher.h"
#include "dfo_frontend/tracker.h"

namespace dfo::learned {

// One training sequence in memory: RGB frames (3 channels, all of the camera's size) in time
// order.
struct TrainingSequence {
  std::string name;             // for messages ("seq 101")
  std::vector<ImageU8> images;  // RGB, camera.width x camera.height each
  PinholeCamera camera;         // intrinsics of `images`
  // Ground-truth poses (camera-to-world), one per image, or empty when unknown. Never used by the
  // losses of the default training: only for the pose-error diagnostic (StepRecord) and the
  // diagnostic pose source TrainingOptions::PoseSource::kGroundTruth.
  std::vector<SE3d> world_from_cam;
  // Sparse depth targets per image (teacher.h), or empty when the sequence has none: the depths
  // one run of the system settled on, so they share one unknown scale, which the trainer fits
  // (Trainer::teacher_log_scales). Pixels in `camera`'s convention.
  std::vector<std::vector<DepthTarget>> depth_targets;
};

// A 3-frame snippet: frames index - 1, index, index + 1 of sequence `sequence`.
struct Snippet {
  int sequence = 0;
  int index = 0;  // the target (middle) frame
};

// Augmentation (SfMLearner / the DFO paper), applied identically to the three frames.
struct AugmentOptions {
  bool enabled = true;
  // Random upscale by s uniform in [1, max_scale] then a random crop back to the training size
  // (intrinsics follow). 1 = off. In [1, 2].
  double max_scale = 1.15;
  // Probability of the photometric augmentation, in [0, 1]; when drawn, gamma, brightness and a
  // per-channel colour factor are each uniform in [color_min, color_max] (the issue: [0.9, 1.1]).
  double color_probability = 0.5;
  double color_min = 0.9;  // > 0
  double color_max = 1.1;  // >= color_min

  // Throws ConfigError naming the field, value and rule.
  void Check() const;
};

// Everything a training run needs besides the data.
struct TrainingOptions {
  NetworkOptions network;  // shapes; input_width x input_height is the training size
  LossOptions loss;
  AugmentOptions augment;
  // The differentiable alignment: the tracker's options (its num_levels must equal
  // network.num_levels, its patch_size network.patch_sizes[0]); training uses short unrolls.
  TrackerOptions gn;
  // Weight the GN's patches by the target's soft (Gumbel-sigmoid) masks, so that the attention
  // branch learns which points help the alignment; points are selected by the tracker's gradient
  // rule either way. false: unweighted.
  bool gn_use_masks = true;
  // Backpropagate through the source views' feature network (false: sources are computed without
  // gradients, which saves about a third of the step; the target branch still learns).
  bool source_feature_grad = false;
  // Bootstrapping curriculum (not in the paper): for the first `gn_handmade_iterations` joint
  // iterations the alignment runs on the tracker's hand-made feature pyramid of the three frames
  // (HandmadeFeatureSource, fixed functions of the images) instead of the learned features; the
  // pose still comes from the differentiable GN, and the view-synthesis gradient still reaches the
  // depth through it (DDVO's direct alignment on intensities, Wang et al. CVPR 2018). This breaks
  // the depth/feature chicken-and-egg of a from-scratch start, where both networks are random. The
  // feature network learns from the reconstruction and sparsity terms meanwhile. 0 = the paper's
  // learned features from the first joint iteration.
  int gn_handmade_iterations = 0;
  // Where the warp's poses come from. kAlignment (the method): the differentiable GN.
  // kGroundTruth is a DIAGNOSTIC only (it breaks self-supervision): the warp uses the sequences'
  // ground-truth relative poses (every training sequence needs world_from_cam) and the GN is not
  // run, so the feature network learns only from the reconstruction and sparsity terms. The depth
  // keeps the scale gauge (batch geometric mean loss.depth_mean_m) while the true translation is
  // metric: a per-batch scale error, harmless for median-scaled metrics. It separates "the warp /
  // loss / depth pipeline cannot learn" from "the alignment's poses are wrong".
  enum class PoseSource { kAlignment, kGroundTruth };
  // Backpropagate the view-synthesis loss through the alignment's pose (the paper: the feature
  // net, its masks and the depth learn through the unrolled GN). false: the pose is a constant
  // of each step (alternating: the depth is fitted to the alignment's current pose).
  bool pose_gradient = true;
  PoseSource pose_source = PoseSource::kAlignment;

  // A fresh run starts the depth heads at this depth (DepthNet::SetInitialDepth), metres in
  // (0.1, 100); 0 = zero biases (sigmoid 0.5: 0.2 m, only 2x above the 0.1 m floor, so pixels
  // that want to be nearer than half the median saturate at the floor in the first iterations
  // and never come back: measured, the bottom rows of the road).
  double initial_depth_m = 10.0;
  int batch_size = 4;  // snippets per iteration, >= 1
  // Snippets whose target differs from either neighbour by less than this mean absolute grey
  // difference (0..1) are static and skipped. >= 0; 0 keeps all.
  double static_threshold = 0.01;
  // Iterations of the autoencoder stage (feature network alone), >= 0, then joint training up to
  // `iterations` in total (> ae_iterations unless only the AE stage is wanted).
  int ae_iterations = 500;
  int iterations = 20000;
  // Adam's learning rate decays geometrically from learning_rate to final_learning_rate over the
  // run (the paper: 1e-5 -> 1e-6; on this CPU's short runs 1e-4 -> 1e-5 learns much faster).
  double learning_rate = 1e-4;
  double final_learning_rate = 1e-5;
  double adam_beta1 = 0.9;
  double adam_beta2 = 0.999;
  // Gradient norm clip (all parameters together), > 0; unrolled GN can produce rare spikes.
  double max_grad_norm = 10.0;
  // Gumbel-sigmoid temperature, geometric from start to end over the joint stage (paper 1 -> 0.1).
  double temperature_start = 1.0;
  double temperature_end = 0.1;
  uint64_t seed = 1;           // data order, augmentation, Gumbel noise and initial weights
  int threads = 1;             // torch intra-op threads, >= 1
  bool channels_last = true;   // NHWC memory format (oneDNN's fast path on this CPU)
  int checkpoint_every = 500;  // iterations between checkpoints, >= 1
  // Where the networks train: "cpu", "cuda" or "cuda:N" (train.device). Data batches are made on
  // the CPU (the same draws on every device) and moved there once per batch; the initial weights
  // are drawn on the CPU and then moved, so a run starts from the same networks everywhere. On a
  // CUDA device the results differ from the CPU's in rounding (and need not be bit-reproducible).
  // A CUDA device needs a LibTorch built with CUDA (README, "A GPU"); Debian's is CPU-only and
  // the Trainer's constructor throws ConfigError naming train.device for "cuda".
  std::string device = "cpu";

  // Throws ConfigError naming the field ("train.batch_size = 0 violates >= 1").
  void Check() const;
};

// The losses of one iteration (0 for terms the stage does not use).
struct StepRecord {
  int iteration = 0;  // 1-based: the number of updates done after this step
  std::string stage;  // "ae" or "joint"
  double total = 0.0;
  double appearance = 0.0;
  double smoothness = 0.0;
  double sparsity = 0.0;
  double reconstruction = 0.0;
  double consistency = 0.0;  // geometry-consistency term (LossOptions::depth_consistency_weight)
  double teacher = 0.0;      // depth-target term (LossOptions::teacher_weight; teacher.h)
  double learning_rate = 0.0;
  double temperature = 0.0;
  double gn_ok_ratio = 0.0;  // fraction of alignments whose finest level succeeded
  double mean_depth = 0.0;   // median predicted depth of the batch's targets (m)
  double seconds = 0.0;      // wall time of the step
  // Diagnostic only (never in the loss): mean error of the alignment's source_from_target poses
  // against the ground truth over the batch's successful alignments, when the data has poses
  // (NaN otherwise, and in the AE stage): rotation angle (degrees) and the angle between the
  // translation directions (degrees, scale-free; > 90 means the motion's sign is wrong).
  double pose_rotation_error_deg = std::numeric_limits<double>::quiet_NaN();
  double pose_direction_error_deg = std::numeric_limits<double>::quiet_NaN();
};

// The run: networks, optimiser, data, history. Not thread-safe; deterministic for a given seed,
// data and thread count (the iteration's random draws depend only on seed and iteration, so a
// resumed run draws what an uninterrupted one would).
class Trainer {
 public:
  // Checks the options (ConfigError; also when options.device names a CUDA device this LibTorch
  // cannot use) and the data: at least one sequence with a non-static snippet, every image RGB of
  // its camera's size (InputError naming the sequence and frame). Images are resized to the
  // training size when the camera differs. Builds the networks from options.seed, on the CPU,
  // then moves them to options.device.
  Trainer(const TrainingOptions& options, std::vector<TrainingSequence> data);
  ~Trainer();

  // One iteration (AE or joint stage by iteration()); returns its record, also appended to
  // history(). Throws InternalError when the loss is not finite (after skipping one bad batch).
  StepRecord Step();

  // Runs Step() until `iterations` or until *stop becomes true; after each step calls on_step;
  // saves a checkpoint every checkpoint_every iterations and at the end (also when stopped) to
  // checkpoint_path (when not empty). Returns the number of steps done.
  int Run(const std::atomic<bool>* stop, const std::string& checkpoint_path,
          const std::function<void(const StepRecord&)>& on_step);

  // Checkpoint: network weights, Adam state, iteration, network options and the history. Written
  // to `path` + ".tmp" then renamed (a crash never leaves half a checkpoint). InputError when it
  // cannot be written. Tensors are saved on the training device; loading maps them to the
  // loader's (a checkpoint written on a GPU resumes on the CPU and back).
  void SaveCheckpoint(const std::string& path) const;
  // Restores a checkpoint written by SaveCheckpoint (on any device: its tensors are loaded onto
  // this trainer's); InputError naming the file when it is not one or its network shapes differ
  // from the options'.
  void LoadCheckpoint(const std::string& path);
  // Loads only the network weights of a checkpoint (fine-tuning at another size; fresh Adam,
  // iteration 0).
  void LoadWeights(const std::string& path);

  // Clips the gradients' norm and steps Adam on them, or, when the norm is not finite, drops them
  // and skips the update (weights and Adam state unchanged; a message on stderr). `iteration`
  // (0-based) is for the message. Step() calls it; public for tests.
  void ClippedStep(int iteration);
  int skipped_updates() const { return skipped_updates_; }
  // Per sequence: the log factor from the network's raw depth to its depth targets' scale (the
  // run's), kept as a running robust estimate (each joint step's median offset, averaged with
  // weight 0.1); NaN for a sequence without targets or before its first batch. In checkpoints.
  const std::vector<double>& teacher_log_scales() const { return teacher_log_scales_; }

  int iteration() const { return iteration_; }
  const std::vector<StepRecord>& history() const { return history_; }
  const std::vector<Snippet>& snippets() const { return snippets_; }
  Networks& networks() { return networks_; }
  const TrainingOptions& options() const { return options_; }
  // The device the networks train on (options().device).
  const torch::Device& device() const { return device_; }

  // Learning rate and Gumbel temperature at an iteration (0-based) by the schedules.
  double LearningRateAt(int iteration) const;
  double TemperatureAt(int iteration) const;

  // The batch of an iteration after augmentation: images N x 3 x H x W for the previous, target
  // and next frames, and intrinsics N x 4 (fx, fy, cx, cy) at the training size. Deterministic:
  // drawn and augmented on the CPU, then moved to device() (every tensor of the batch is there).
  struct Batch {
    torch::Tensor previous, target, next;
    torch::Tensor intrinsics;
    std::vector<PinholeCamera> cameras;  // per sample, training size
    std::vector<Snippet> snippets;       // per sample
    // Ground-truth source_from_target poses (index 0: previous, 1: next; rotation N x 3 x 3,
    // translation N x 3, float), defined only when every sample's sequence has poses.
    bool has_ground_truth = false;
    torch::Tensor gt_rotation[2], gt_translation[2];
    // Per sample: its target frame's depth targets at the augmented camera (TargetsToTensor,
    // on the device; undefined when it has none).
    std::vector<torch::Tensor> teacher_targets;
  };
  Batch MakeBatch(int iteration) const;

  // Evaluation helper: per-level depth (N x 1 x H_l x W_l, on the CPU) of RGB images
  // N x 3 x H x W in [0, 1] (any device) at the training size, without gradients.
  std::vector<torch::Tensor> PredictDepth(const torch::Tensor& images);

 private:
  StepRecord AeStep(const Batch& batch);
  StepRecord JointStep(const Batch& batch, int iteration);
  // The joint step's poses source_from_target (rotation[s] N x 3 x 3, translation[s] N x 3; s = 0
  // previous, 1 next): the differentiable alignment of each sample's target features (z-scored
  // target_z, or the hand-made ones during gn_handmade_iterations; masks with gn.use_masks; the
  // normalised depth) to each source's, or the ground truth with gn.pose_source ground_truth.
  // pose_ok[s][b] becomes 0 where the alignment failed (identity pose, no gradient); the record
  // gets the success ratio and, with ground truth at hand, the pose errors.
  void AlignSnippets(const Batch& batch, int iteration, const std::vector<torch::Tensor>& depth,
                     const std::vector<torch::Tensor>& masks,
                     const std::vector<torch::Tensor>& target_z,
                     const std::vector<torch::Tensor> source_z[2], torch::Tensor rotation[2],
                     torch::Tensor translation[2], torch::Tensor pose_ok[2], StepRecord* rec) const;
  // Each run's depth-target scale (teacher_log_scales()) moves toward the median of its samples'
  // offsets in this batch (weight 0.1; the first batch sets it).
  void UpdateTeacherScales(const Batch& batch, const std::vector<double>& offsets);

  TrainingOptions options_;
  torch::Device device_ = torch::kCPU;  // options_.device
  std::vector<TrainingSequence> data_;
  std::vector<Snippet> snippets_;
  Networks networks_{nullptr};
  std::unique_ptr<torch::optim::Adam> optimizer_;
  int iteration_ = 0;
  std::vector<StepRecord> history_;
  int skipped_updates_ = 0;  // updates skipped for a non-finite gradient (this process)
  std::vector<double> teacher_log_scales_;
};

// The view-synthesis (appearance) loss of the joint stage: per level l (images average-pooled
// to the depth's level size, intrinsics scaled by PinholeCamera::PyramidLevel's rule), both
// sources warped into the target with depth[l] (N x 1 x H_l x W_l, metres) and the poses
// source_from_target (rotations[s] N x 3 x 3, translations[s] N x 3; s = 0 previous, 1 next),
// the per-pixel minimum over the sources (and, with automask, the unwarped sources) of
// AppearanceMap, a source whose sample is outside its image (border-padded) or behind its camera
// adding 1, averaged over all pixels and then over the levels. 0-dim tensor.
torch::Tensor ViewSynthesisLoss(const Trainer::Batch& batch,
                                const std::vector<torch::Tensor>& depth,
                                const torch::Tensor rotations[2],
                                const torch::Tensor translations[2], const LossOptions& options);

// The joint stage's scale gauge: the depth pyramid `raw` (network output, metres) scaled by the
// factor that brings each image's finest-level median depth (options.depth_gauge kMedian) or the
// batch's geometric mean (kGeometricMean) to options.depth_mean_m, and *prior = log(raw batch
// geometric mean / depth_mean_m)^2. depth_mean_m = 0: `raw` unchanged and a zero prior. With
// kMedian a pixel's normalised depth depends on its own raw depth and its image's median pixel
// only. *factor (optional) receives the factor, N x 1 x 1 x 1 (ones when depth_mean_m = 0), so
// that other frames' depths can be brought into the same gauge.
std::vector<torch::Tensor> NormaliseDepthScale(const std::vector<torch::Tensor>& raw,
                                               const LossOptions& options, torch::Tensor* prior,
                                               torch::Tensor* factor = nullptr);

// Angles (degrees) between two poses b_from_a: rotation error and the angle between the
// translation directions (NaN when either translation is shorter than 1e-9).
struct PoseError {
  double rotation_deg = 0.0;
  double direction_deg = 0.0;
};
PoseError ComparePoses(const SE3d& estimate, const SE3d& truth);

// Converts an RGB (or grey, replicated) 8-bit image into a 1 x 3 x H x W float tensor in [0, 1].
torch::Tensor ImageToTensor(const ImageU8& image);

// Per-channel z-score of a C x H x W (or N x C x H x W, per sample) feature map over its pixels,
// as FeatureLevel::ZScore (population standard deviation; a constant channel becomes 0).
torch::Tensor ZScore(const torch::Tensor& features);

// The tracker's hand-made feature pyramid (HandmadeFeatureSource, default options) of one RGB
// image 3 x H x W in [0, 1] (quantised to 8 bits as the tracker sees frames) with `camera` of its
// size: num_levels tensors C x H_l x W_l (float, z-scored, no gradient), on the image's device
// (computed on the CPU).
std::vector<torch::Tensor> HandmadePyramid(const torch::Tensor& image, const PinholeCamera& camera,
                                           int num_levels);

// The history as CSV (header + one row per record) and back. ReadHistoryCsv throws InputError
// naming the file and line for a malformed row.
void WriteHistoryCsv(const std::string& path, const std::vector<StepRecord>& history);
std::vector<StepRecord> ReadHistoryCsv(const std::string& path);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_TRAINING_H_
