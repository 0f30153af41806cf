#include "dfo_io/train_schema.h"

#include "dfo_core/device_name.h"

namespace dfo::io {
namespace {

ConfigSchema BuildTrainSchema() {
  ConfigSchema s;
  s.AddSection("data", "Training sequences (KITTI odometry layout, e.g. written by dfo_synth).");
  s.AddStringList("data.sequences", {},
                  "Sequence folders (each holding calib.txt, times.txt and image_2/ or image_0/)");
  s.AddInt("data.max_frames", -1, "Frames used per sequence from its start; -1 = all").Min(-1);
  s.AddStringList(
      "data.teachers", {},
      "Keyframe depth folders written by dfo_run (run.write_keyframe_depth): each is "
      "trained on as a sequence of its keyframes' images, with the depth its window "
      "settled on as sparse targets (loss.teacher_weight), one fitted scale per folder");
  s.AddInt("data.teacher_min_observations", 4,
           "A teacher point is a target when the window compared it in at least this many other "
           "keyframes (fewer leave its depth to one or two short baselines)")
      .Min(1);

  s.AddSection("network", "Shapes and widths of both networks (stored in the model file).");
  s.AddInt("network.input_width", 208, "Training width in pixels (divisible by 2^(levels-1))")
      .GreaterThan(0)
      .Max(4096);
  s.AddInt("network.input_height", 64, "Training height in pixels (divisible by 2^(levels-1))")
      .GreaterThan(0)
      .Max(4096);
  s.AddInt("network.num_levels", 4, "Pyramid levels of both networks (the paper: 4)").Min(1).Max(6);
  s.AddIntList("network.channels", {8, 8, 16, 16}, "Feature channels per level, finest first")
      .Min(1)
      .Max(256);
  s.AddIntList("network.patch_sizes", {3, 3, 3, 3}, "Patch side K per level (odd)").Min(1).Max(9);
  s.AddDoubleList("network.rho", {0.015, 0.04, 0.08, 0.16},
                  "Target mask density per level (inference keeps this fraction of pixels)")
      .GreaterThan(0)
      .Max(1);
  s.AddDoubleList("network.input_mean", {0.45, 0.45, 0.45}, "Input normalisation mean (RGB)");
  s.AddDoubleList("network.input_std", {0.225, 0.225, 0.225}, "Input normalisation std (RGB)")
      .GreaterThan(0);
  s.AddIntList("network.depth_encoder_widths", {16, 32, 64, 96, 128},
               "DepthNet encoder widths, stage i at 1/2^(i+1)")
      .Min(1)
      .Max(1024);
  s.AddIntList("network.depth_decoder_widths", {8, 16, 32, 64, 96},
               "DepthNet decoder widths at scale 1/2^i")
      .Min(1)
      .Max(1024);
  s.AddIntList("network.feature_encoder_widths", {16, 24, 32, 48},
               "FeatureNet encoder widths (num_levels entries)")
      .Min(1)
      .Max(1024);
  s.AddIntList("network.feature_decoder_widths", {8, 16, 24, 32},
               "FeatureNet decoder widths per output level, finest first")
      .Min(1)
      .Max(1024);
  s.AddInt("network.reconstruction_width", 16, "Hidden width of the reconstruction heads")
      .Min(1)
      .Max(1024);

  s.AddSection("loss", "Loss weights (DFO paper: lambda_sm 0.1, lambda_sp 0.01, lambda_ae 0.01).");
  s.AddDouble("loss.ssim_weight", 0.85, "Weight of DSSIM/2 in the appearance mix (L1: 1 - it)")
      .Min(0)
      .Max(1);
  s.AddDouble("loss.dssim_clamp", 0.15, "Robust clamp eps on DSSIM/2").GreaterThan(0);
  s.AddDouble("loss.l1_clamp", 0.3, "Robust clamp eps on L1").GreaterThan(0);
  s.AddDouble("loss.smooth_weight", 0.001, "lambda_sm (level l weighted lambda_sm / 2^l)").Min(0);
  s.AddDouble("loss.sparsity_weight", 0.01, "lambda_sp (KL of the masks toward network.rho)")
      .Min(0);
  s.AddDouble("loss.ae_weight", 0.01, "lambda_ae (autoencoder reconstruction in the joint stage)")
      .Min(0);
  s.AddDouble("loss.depth_mean_m", 10.0,
              "Scale gauge: depths normalised to this batch geometric mean (m) for alignment and "
              "warping; "
              "0 = off")
      .Min(0);
  s.AddDouble(
       "loss.depth_prior_weight", 0.01,
       "Weight of log(raw geometric mean depth / depth_mean_m)^2 (keeps the scale metric-ish)")
      .Min(0);
  s.AddString("loss.depth_gauge", "median",
              "What the gauge brings to depth_mean_m: each image's median depth, or the batch's "
              "geometric mean (every pixel then moves the others' scale)")
      .OneOf({"median", "geometric_mean"});
  s.AddBool("loss.automask", true,
            "Monodepth2 auto-masking: the unwarped sources join the per-pixel minimum (pixels no "
            "warp explains better than no motion stop pulling the depth to the ceiling)");
  s.AddBool("loss.full_resolution", true,
            "Monodepth2's full-resolution loss: every level's depth upsampled to the finest "
            "level, view synthesis there (false: each level at its own size)");
  s.AddDouble("loss.depth_consistency_weight", 0.0,
              "Geometry consistency (SC-SfMLearner): the target's depth moved into each source "
              "against the source's own depth, |z - d| / (z + d); ties consecutive frames' scale "
              "together (0 = off)")
      .Min(0);
  s.AddDouble("loss.teacher_weight", 1.0,
              "Weight of the depth targets of data.teachers: Huber on log(network depth x the "
              "folder's fitted scale / target) (0 = off)")
      .Min(0);
  s.AddDouble("loss.teacher_huber", 0.1,
              "Huber threshold of the depth-target term on the log-depth residual")
      .GreaterThan(0);

  s.AddSection("augment", "Augmentation, identical for the three frames of a snippet.");
  s.AddBool("augment.enabled", true, "Augment the training snippets");
  s.AddDouble("augment.max_scale", 1.15, "Random upscale in [1, max_scale], then crop")
      .Min(1)
      .Max(2);
  s.AddDouble("augment.color_probability", 0.5,
              "Chance of the gamma / brightness / colour augmentation")
      .Min(0)
      .Max(1);
  s.AddDouble("augment.color_min", 0.9, "Lower bound of the gamma, brightness, colour factors")
      .GreaterThan(0);
  s.AddDouble("augment.color_max", 1.1, "Upper bound of those factors").GreaterThan(0);

  s.AddSection("gn", "Differentiable Gauss-Newton alignment giving the training poses.");
  s.AddInt("gn.max_points", 300, "Most patches per level (tracker.max_points)").Min(1).Max(100000);
  s.AddIntList("gn.max_iterations", {6, 6, 8, 10},
               "Unrolled iterations per level, finest first (last repeats)")
      .Min(1)
      .Max(100);
  s.AddDouble("gn.min_gradient", 0.05, "Smallest feature gradient of a selected point").Min(0);
  s.AddBool("gn.outlier_rule", true, "Apply the paper's 0.5 (median + max) outlier rule");
  s.AddBool("gn.use_masks", false,
            "Weight the alignment's patches by the target's soft masks (selection stays the "
            "tracker's gradient rule)");
  s.AddBool("gn.source_feature_grad", true,
            "Backpropagate through the source views' feature network (slower)");
  s.AddInt("gn.handmade_iterations", 800,
           "Joint iterations at the start whose alignment runs on the tracker's hand-made "
           "features instead of the learned ones (bootstrapping; 0 = the paper's learned "
           "features from the start)")
      .Min(0);
  s.AddBool("gn.pose_gradient", true,
            "Backpropagate the appearance loss through the alignment's pose (false: the pose is "
            "a constant of each step)");
  s.AddString("gn.pose_source", "alignment",
              "Poses of the warp: alignment (the method) or ground_truth (DIAGNOSTIC only: the "
              "sequences' true poses, no GN; not self-supervised)")
      .OneOf({"alignment", "ground_truth"});

  s.AddSection("train", "Schedule, optimiser, batches, determinism, checkpoints.");
  s.AddDouble("train.initial_depth_m", 10.0,
              "A fresh run starts the depth network's output at this depth in metres (0 = "
              "zero biases: 0.2 m, next to the 0.1 m floor)")
      .Min(0)
      .Max(99.9);
  s.AddInt("train.batch_size", 4, "Snippets per iteration").Min(1).Max(1024);
  s.AddDouble("train.static_threshold", 0.01,
              "Skip snippets whose frames differ by less (mean absolute grey, 0..1)")
      .Min(0);
  s.AddInt("train.ae_iterations", 500, "Iterations of the autoencoder stage (feature net alone)")
      .Min(0);
  s.AddInt("train.iterations", 20000, "Total iterations (AE stage, then joint)").Min(1);
  s.AddDouble("train.learning_rate", 1e-4, "Adam learning rate at the start").GreaterThan(0);
  s.AddDouble("train.final_learning_rate", 1e-5,
              "Learning rate at the end (geometric decay over the run)")
      .GreaterThan(0);
  s.AddDouble("train.max_grad_norm", 10.0, "Gradient norm clip").GreaterThan(0);
  s.AddDouble("train.temperature_start", 1.0, "Gumbel-sigmoid temperature at the joint start")
      .GreaterThan(0);
  s.AddDouble("train.temperature_end", 0.1, "Gumbel-sigmoid temperature at the end").GreaterThan(0);
  s.AddInt("train.seed", 1, "Seed of weights, data order, augmentation and Gumbel noise").Min(0);
  s.AddInt("train.threads", 1, "Torch threads").Min(1).Max(64);
  s.AddInt("train.memory_limit_mb", 4096,
           "Largest peak memory (MiB) training may need: dfo_train estimates it from "
           "network.input_width/input_height, the network widths and train.batch_size "
           "(learned/network_options.h) and refuses to start above it; 0 = no limit")
      .Min(0);
  s.AddString("train.device", "cpu",
              "Where the networks train; cuda needs a LibTorch built with CUDA (Debian's is "
              "CPU-only and refuses cuda at start-up)")
      .Matches(IsDeviceName, kDeviceNameRule);
  s.AddBool("train.channels_last", true, "NHWC memory format (faster convolutions here)");
  s.AddInt("train.checkpoint_every", 500, "Iterations between checkpoints").Min(1);
  s.AddString("train.init_checkpoint", "",
              "Start from this checkpoint's network weights (fine-tuning); empty = fresh");
  s.AddString("train.progress", "auto", "Progress line: auto, terminal, plain or none")
      .OneOf({"auto", "terminal", "plain", "none"});
  s.AddDouble("train.progress_interval_s", 10.0, "Seconds between plain progress lines")
      .GreaterThan(0);
  return s;
}

}  // namespace

const ConfigSchema& TrainSchema() {
  static const ConfigSchema schema = BuildTrainSchema();
  return schema;
}

}  // namespace dfo::io
