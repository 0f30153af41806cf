// dfo_bench_backend: speed of the sliding-window backend (feature-metric BA plus
// marginalisation per keyframe), printed; nothing is asserted (tests never time anything).
//
//   dfo_bench_backend [--keyframes N] [--step S] [--threads T] [--window W] [--points P]
//                     [--solver sparse_schur|dense_schur] [--no-marginalization] [--seed S]
//
// Renders N keyframes of the synthetic street sequence (416 x 128, every S-th frame) in memory
// first (not timed), computes the frontend's hand-made features (intensity + gradients, 4 levels)
// and ground-truth depth pyramids, perturbs each keyframe pose as a frontend estimate would be
// (1 cm, 0.1 deg per axis, seeded), then feeds them to WindowOptimizer with the given options
// (WindowOptions' defaults otherwise) and prints the median and 90th percentile of the BA time,
// the marginalisation time and their sum per keyframe, the window size, and the keyframe pose
// error against ground truth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "apps/common/cli.h"
#include "apps/common/run_stats.h"
#include "dfo_backend/window_optimizer.h"
#include "dfo_core/alignment.h"
#include "dfo_core/error.h"
#include "dfo_core/metrics.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_io/dataset.h"

namespace dfo {
namespace {

using apps::Percentile;

constexpr const char* kUsage = R"(usage: dfo_bench_backend [options]

Times dfo's sliding-window BA plus marginalisation per keyframe on the synthetic street sequence
(416 x 128, hand-made features, ground-truth depth). Prints figures; asserts nothing.

options:
  --keyframes N          keyframes (default 40)
  --step S               frames between keyframes (default 3)
  --threads T            WindowOptions::num_threads (default 2)
  --window W             WindowOptions::max_keyframes (default 7)
  --points P             WindowOptions::points_per_keyframe (default: the option's default)
  --iterations I         WindowOptions::max_iterations (default: the option's default)
  --time-limit S         WindowOptions::max_solver_time_s (default: the option's default)
  --depth-prior W        WindowOptions::depth_prior_weight (default 0)
  --depth-search R       WindowOptions::depth_search_range (default: the option's default; 1 = off)
  --level L              WindowOptions::pyramid_level (default 0)
  --patch K              WindowOptions::patch_size (default: the option's default)
  --max-stretch S        WindowOptions::max_patch_stretch (default: the option's default)
  --patch-depth-shape    WindowOptions::patch_depth_shape = true (patches warped as the depth
                         map's surface, not fronto-parallel)
  --zoom-blur S          WindowOptions::zoom_blur_sigma_px (default 0; the features' blur: --blur)
  --zoom-scaled-gradients  WindowOptions::zoom_scaled_gradients = true (the host's gradient
                         channels scaled by 1 / zoom in each block)
  --descriptor NAME      hand-made features: intensity, intensity_gradients (default) or rich
  --blur S               hand-made features: blur_sigma_px (default 1)
  --perturbation F       scale of the keyframe pose perturbation (default 1: 1 cm and 0.1 deg
                         per axis; 0 = ground-truth poses, to see where the BA's optimum lies)
  --fej                  WindowOptions::first_estimate_jacobians = true
  --prior-weight W       WindowOptions::prior_weight (default 1)
  --pose-prior W         WindowOptions::pose_prior_weight (default 0; large: relative poses held)
  --gate-factor F        WindowOptions::outlier_gate_factor
  --loss-scale S         WindowOptions::loss_scale
  --min-point-fraction F WindowOptions::min_point_fraction (1 = always the oldest leaves)
  --eigen-floor F        WindowOptions::relative_eigenvalue_floor
  --solver NAME          sparse_schur (default) or dense_schur
  --no-marginalization   drop instead of marginalising
  --seed S               synthetic sequence seed (default 1)
  --kitti ROOT           real frames instead: KITTI odometry root (sequences/NN/, poses/NN.txt),
                         keyframes at the ground-truth poses, depth from --depth-dir
  --sequence NN          KITTI sequence (default 00)
  --first F              first frame (default 0); keyframes F, F + step, ...
  --depth-dir DIR        depth maps named after the images (metres x 256, as `dfo_eval
                         stereo-depth` writes): the keyframes' depth
  --width W              processing width for --kitti (default 416; aspect ratio kept)
  --follow-window        each new keyframe enters as a tracker on the window's depth would hand
                         it over: the true motion from the previous keyframe at the window's
                         current scale, on the window's estimate of that keyframe, with its depth
                         at that scale (default: at its true pose and depth)
  --verbose              one line per keyframe (times, costs, window error)
  --help                 this text
)";

struct Args {
  int keyframes = 40;
  int step = 3;
  int seed = 1;
  double perturbation = 1.0;
  HandmadeFeatureOptions features;
  bool verbose = false;
  bool help = false;
  std::string kitti, sequence = "00", depth_dir;
  int first = 0, width = 416;
  bool follow_window = false;
  WindowOptions window;
};

Args Parse(int argc, char** argv) {
  Args args;
  const double inf = std::numeric_limits<double>::infinity();
  WindowOptions& w = args.window;
  bool no_marginalization = false;
  apps::ArgParser parser;
  parser.Flag("--help", &args.help, "-h")
      .Int("--keyframes", &args.keyframes, 2, 100000)
      .Int("--step", &args.step, 1, 100000)
      .Int("--threads", &w.num_threads, 1, 256)
      .Int("--window", &w.max_keyframes, 1, 1000)
      .Int("--points", &w.points_per_keyframe, 1, 1000000)
      .Int("--iterations", &w.max_iterations, 1, 100000)
      .Number("--time-limit", &w.max_solver_time_s, -inf, inf)
      .Number("--depth-prior", &w.depth_prior_weight, -inf, inf)
      .Number("--depth-search", &w.depth_search_range, -inf, inf)
      .Int("--level", &w.pyramid_level, 0, 16)
      .Int("--patch", &w.patch_size, 1, 99)
      .Number("--max-stretch", &w.max_patch_stretch, -inf, inf)
      .Number("--zoom-blur", &w.zoom_blur_sigma_px, -inf, inf)
      .Flag("--zoom-scaled-gradients", &w.zoom_scaled_gradients)
      .Flag("--patch-depth-shape", &w.patch_depth_shape)
      .Value("--descriptor", &args.features.descriptor)
      .Number("--blur", &args.features.blur_sigma_px, -inf, inf)
      .Number("--perturbation", &args.perturbation, 0.0, inf)
      .Flag("--fej", &w.first_estimate_jacobians)
      .Number("--prior-weight", &w.prior_weight, -inf, inf)
      .Number("--pose-prior", &w.pose_prior_weight, -inf, inf)
      .Number("--gate-factor", &w.outlier_gate_factor, -inf, inf)
      .Number("--loss-scale", &w.loss_scale, -inf, inf)
      .Number("--min-point-fraction", &w.min_point_fraction, -inf, inf)
      .Number("--eigen-floor", &w.relative_eigenvalue_floor, -inf, inf)
      .Value("--solver", &w.linear_solver)
      .Flag("--no-marginalization", &no_marginalization)
      .Flag("--verbose", &args.verbose)
      .Int("--seed", &args.seed, 0, std::numeric_limits<int>::max())
      .Value("--kitti", &args.kitti)
      .Value("--sequence", &args.sequence)
      .Int("--first", &args.first, 0, std::numeric_limits<int>::max())
      .Value("--depth-dir", &args.depth_dir)
      .Int("--width", &args.width, 8, 8192)
      .Flag("--follow-window", &args.follow_window);
  parser.Parse(argc, argv);
  if (args.help) return args;
  if (no_marginalization) w.marginalization = false;
  if (!args.kitti.empty() && args.depth_dir.empty()) {
    throw ConfigError("--kitti needs --depth-dir (KITTI has no depth maps of its own)");
  }
  args.window.Check();
  args.features.Check();
  return args;
}

// Sim3-aligned ATE RMSE (evo_ape -as) of `estimate` against `truth` (associated pose by pose).
double SimAte(const Trajectory& truth, const Trajectory& estimate) {
  TrajectoryAlignmentOptions options;
  options.type = AlignmentType::kSim3;
  return ComputeAte(truth, AlignTrajectory(estimate, truth, options).aligned_estimate).stats.rmse;
}

// The keyframes' frames (image, depth, camera) and their true poses: the synthetic street
// sequence rendered in memory, or real frames (--kitti) with depth maps from a folder.
struct Keyframes {
  std::vector<Frame> frames;
  std::map<int, SE3d> world_from_cam;  // by frame index
  std::string description;
};

Keyframes SyntheticKeyframes(const Args& args) {
  SyntheticOptions synthetic;
  synthetic.seed = static_cast<uint64_t>(args.seed);
  synthetic.num_frames = (args.keyframes - 1) * args.step + 1;
  const SyntheticSequence sequence(synthetic);
  Keyframes out;
  for (int k = 0; k < args.keyframes; ++k) {
    const SyntheticFrame rendered = sequence.RenderFrame(k * args.step, 2);
    Frame frame;
    frame.index = rendered.index;
    frame.timestamp_ns = rendered.timestamp_ns;
    frame.image = rendered.gray;
    frame.depth_m = rendered.depth;
    frame.camera = sequence.camera();
    out.world_from_cam[frame.index] = rendered.world_from_cam;
    out.frames.push_back(std::move(frame));
  }
  char text[128];
  std::snprintf(text, sizeof(text), "the synthetic street sequence (seed %d), %d x %d", args.seed,
                synthetic.width, synthetic.height);
  out.description = text;
  return out;
}

Keyframes KittiKeyframes(const Args& args) {
  io::DatasetOptions options;
  options.type = "kitti";
  options.path = args.kitti;
  options.sequence = args.sequence;
  options.first = args.first;
  options.last = args.first + (args.keyframes - 1) * args.step;
  options.step = args.step;
  options.depth = true;
  options.depth_dir = args.depth_dir;
  io::Sequence sequence = io::OpenSequence(options);
  const auto [width, height] = io::ProcessingSize(sequence.native_camera(), args.width, 8);
  sequence = sequence.WithOutputSize(width, height);  // OpenSequence took the depth folder
  Keyframes out;
  for (size_t i = 0; i < sequence.size(); ++i) {
    io::LoadedFrame loaded = sequence.Load(i);
    if (!loaded.world_from_cam) {
      throw InputError("KITTI " + args.sequence + " frame " +
                       std::to_string(sequence.frame(i).source_index) + " has no ground truth");
    }
    Frame frame;
    frame.index = sequence.frame(i).source_index;
    frame.timestamp_ns = loaded.timestamp_ns;
    frame.image = std::move(loaded.image);
    frame.depth_m = std::move(loaded.depth_m);
    frame.camera = loaded.camera;
    out.world_from_cam[frame.index] = *loaded.world_from_cam;
    out.frames.push_back(std::move(frame));
  }
  out.description = "KITTI " + args.sequence + " frames " + std::to_string(options.first) + "-" +
                    std::to_string(options.last) + ", " + std::to_string(width) + " x " +
                    std::to_string(height) + ", depth from " + args.depth_dir;
  return out;
}

int Run(const Args& args) {
  const Keyframes source = args.kitti.empty() ? SyntheticKeyframes(args) : KittiKeyframes(args);
  const auto true_pose = [&](int index) { return source.world_from_cam.at(index); };
  HandmadeFeatureSource features(args.features);
  auto depth = MakeDepthSource("gt");
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::printf("preparing %zu keyframes (every %d frames of %s)...\n", source.frames.size(),
              args.step, source.description.c_str());
  std::vector<KeyframeData> keyframes;
  for (size_t k = 0; k < source.frames.size(); ++k) {
    const Frame& frame = source.frames[k];
    KeyframeData kf;
    kf.frame_index = frame.index;
    kf.timestamp_ns = frame.timestamp_ns;
    kf.features = features.Compute(frame, 4);
    kf.depth = depth->Compute(frame, 4);
    Vector6d xi;
    for (int i = 0; i < 3; ++i) xi(i) = k == 0 ? 0.0 : args.perturbation * 0.01 * noise(rng);
    for (int i = 3; i < 6; ++i)
      xi(i) = k == 0 ? 0.0 : args.perturbation * 0.1 * M_PI / 180.0 * noise(rng);
    kf.world_from_cam = true_pose(frame.index) * SE3d::Exp(xi);
    keyframes.push_back(std::move(kf));
  }

  WindowOptimizer window(args.window);
  const apps::OtherLoadMeter other_load;
  std::vector<double> solve_ms, marg_ms, total_ms;
  int failures = 0, max_points = 0, max_blocks = 0;
  double last_trans_err = 0.0, last_rot_err = 0.0, last_scale = 1.0, last_scaled_err = 0.0;
  std::vector<double> window_trans_err, window_rot_err, window_scaled_err;  // full windows
  std::map<int, SE3d> final_pose;  // each keyframe's last estimate (as it left the window)
  std::map<int, int64_t> stamp;
  for (const KeyframeData& kf : keyframes) stamp[kf.frame_index] = kf.timestamp_ns;
  int previous_index = -1;
  SE3d previous_estimate;  // the window's latest estimate of the previous keyframe
  for (KeyframeData& kf : keyframes) {
    if (args.follow_window && previous_index >= 0) {
      // As a tracker on the window's depth would hand it over: the true motion from the previous
      // keyframe at the window's scale, composed on the window's estimate of that keyframe, and
      // the keyframe's depth at the window's scale (1 / last_scale: estimate over truth).
      const double scale = last_scale > 0.0 ? 1.0 / last_scale : 1.0;
      SE3d step = true_pose(previous_index).Inverse() * true_pose(kf.frame_index);
      step = SE3d(step.so3(), scale * step.translation());
      const SE3d perturbation = true_pose(kf.frame_index).Inverse() * kf.world_from_cam;
      kf.world_from_cam = previous_estimate * step * perturbation;
      kf.initial_depth_scale = kf.prior_depth_scale = scale;
    }
    previous_index = kf.frame_index;
    const WindowResult result = window.AddKeyframe(std::move(kf));
    if (!result.keyframe_poses.empty()) previous_estimate = result.keyframe_poses.back().second;
    if (window.num_keyframes() < 2) continue;
    if (!result.optimized) ++failures;
    // Steady state only: the window is full from here on.
    if (result.marginalized_frame_index >= 0) {
      solve_ms.push_back(result.solve_ms);
      marg_ms.push_back(result.marginalization_ms);
      total_ms.push_back(result.solve_ms + result.marginalization_ms);
    }
    max_points = std::max(max_points, result.num_points);
    max_blocks = std::max(max_blocks, result.num_residual_blocks);
    // Pose error of the window relative to its oldest keyframe (the gauge).
    const auto& poses = result.keyframe_poses;
    for (const auto& [index, pose] : poses) final_pose[index] = pose;
    const SE3d gt_ref = true_pose(poses.front().first);
    // The scale is a gauge freedom of the window without a depth prior: also the error after
    // the least-squares scale of the relative translations (est * scale ~ gt).
    last_trans_err = last_rot_err = last_scaled_err = 0.0;
    double dot = 0.0, est_sq = 0.0;
    for (const auto& [index, pose] : poses) {
      const SE3d est_rel = poses.front().second.Inverse() * pose;
      const SE3d gt_rel = gt_ref.Inverse() * true_pose(index);
      const SE3d err = gt_rel.Inverse() * est_rel;
      last_trans_err = std::max(last_trans_err, err.translation().norm());
      last_rot_err = std::max(last_rot_err, err.so3().Angle() * 180.0 / M_PI);
      dot += est_rel.translation().dot(gt_rel.translation());
      est_sq += est_rel.translation().squaredNorm();
    }
    last_scale = est_sq > 0.0 ? dot / est_sq : 1.0;
    for (const auto& [index, pose] : poses) {
      const Eigen::Vector3d est_t = (poses.front().second.Inverse() * pose).translation();
      const Eigen::Vector3d gt_t = (gt_ref.Inverse() * true_pose(index)).translation();
      last_scaled_err = std::max(last_scaled_err, (last_scale * est_t - gt_t).norm());
    }
    if (result.marginalized_frame_index >= 0) {
      window_trans_err.push_back(last_trans_err);
      window_rot_err.push_back(last_rot_err);
      window_scaled_err.push_back(last_scaled_err);
    }
    if (args.verbose) {
      std::printf(
          "keyframe %4d: %s cost %10.1f -> %10.1f  BA %6.1f ms  marg %5.1f ms  "
          "iterations %2d%s  points %5d  blocks %6d  gated %4d  window error %.4f m %.4f deg "
          "(scale %.4f: %.4f m) "
          "%s\n",
          poses.back().first, result.optimized ? "ok  " : "FAIL", result.initial_cost,
          result.final_cost, result.solve_ms, result.marginalization_ms, result.num_iterations,
          result.converged ? " converged" : "", result.num_points, result.num_residual_blocks,
          result.num_gated_blocks, last_trans_err, last_rot_err, last_scale, last_scaled_err,
          result.message.c_str());
    }
  }
  Trajectory estimate, truth;
  for (const auto& [index, pose] : final_pose) {
    estimate.Add(stamp.at(index), pose);
    truth.Add(stamp.at(index), true_pose(index));
  }
  const WindowOptions& o = args.window;
  std::printf(
      "window %d, level %d, %dx%d patches, %d points/keyframe, %s, %d threads, "
      "marginalization %s, max %d iterations\n",
      o.max_keyframes, o.pyramid_level, o.patch_size, o.patch_size, o.points_per_keyframe,
      o.linear_solver.c_str(), o.num_threads, o.marginalization ? "on" : "off", o.max_iterations);
  if (total_ms.empty()) {
    std::printf("the window never filled; use more --keyframes\n");
    return 0;
  }
  std::printf("per keyframe (%zu full-window steps):\n", total_ms.size());
  std::printf("  BA (both solves)    median %7.1f ms   p90 %7.1f ms\n", Percentile(solve_ms, 50),
              Percentile(solve_ms, 90));
  std::printf("  marginalisation     median %7.1f ms   p90 %7.1f ms\n", Percentile(marg_ms, 50),
              Percentile(marg_ms, 90));
  std::printf("  BA + marginalisation median %6.1f ms   p90 %7.1f ms\n", Percentile(total_ms, 50),
              Percentile(total_ms, 90));
  std::printf("machine: %s\n", other_load.Describe().c_str());
  std::printf("window size: at most %d points, %d residual blocks; %d failed solves\n", max_points,
              max_blocks, failures);
  std::printf(
      "last window vs ground truth (relative to its oldest keyframe): max %.4f m, "
      "%.4f deg; after the window's scale (%.4f): max %.4f m\n",
      last_trans_err, last_rot_err, last_scale, last_scaled_err);
  std::printf(
      "every full window vs ground truth (max over its keyframes, relative to its oldest): median "
      "%.4f m %.4f deg (%.4f m after its scale), p90 %.4f m %.4f deg (%.4f m)\n",
      Percentile(window_trans_err, 50), Percentile(window_rot_err, 50),
      Percentile(window_scaled_err, 50), Percentile(window_trans_err, 90),
      Percentile(window_rot_err, 90), Percentile(window_scaled_err, 90));
  if (estimate.size() >= 3) {
    std::printf(
        "keyframe trajectory (each keyframe's last estimate, %zu keyframes) vs ground truth: Sim3 "
        "ATE %.4f m\n",
        estimate.size(), SimAte(truth, estimate));
  }
  return 0;
}

}  // namespace
}  // namespace dfo

int main(int argc, char** argv) {
  return dfo::apps::RunMain("dfo_bench_backend", [&] {
    const dfo::Args args = dfo::Parse(argc, argv);
    if (args.help) {
      std::printf("%s", dfo::kUsage);
      return 0;
    }
    return dfo::Run(args);
  });
}
