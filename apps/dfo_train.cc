// dfo_train: self-supervised training of the DFO depth and feature networks on KITTI-layout
// sequences (configs/train_default.yaml), with checkpoints, resume, loss curves and the final
// model file; also predicts depth PNGs with a trained checkpoint for `dfo_eval depth`.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "apps/common/cli.h"
#include "dfo_core/error.h"
#include "dfo_frontend/learned/internal/device.h"
#include "dfo_frontend/learned/internal/model_file.h"
#include "dfo_frontend/learned/internal/training.h"
#include "dfo_frontend/learned/network_options.h"
#include "dfo_io/config.h"
#include "dfo_io/curve_plot.h"
#include "dfo_io/dataset.h"
#include "dfo_io/image_io.h"
#include "dfo_io/keyframe_depth_io.h"
#include "dfo_io/train_schema.h"

namespace dfo {
namespace {

constexpr const char* kUsage =
    R"(usage: dfo_train --config FILE.yaml [--set section.key=value ...] --output DIR [--resume]
       dfo_train --config FILE.yaml --output DIR --export [--model FILE]
       dfo_train --config FILE.yaml --output DIR --write-depth OUT_DIR --sequence SEQ_DIR
                 [--model FILE]

Trains the depth and feature networks self-supervised (3-frame snippets, poses from the
differentiable feature-metric Gauss-Newton, clamped DSSIM + L1 appearance loss, edge-aware
smoothness, mask sparsity, autoencoder stage first) on the sequences of data.sequences, and writes
into DIR:
  checkpoint.pt          weights, Adam state, iteration and loss history (every
                         train.checkpoint_every iterations, at the end and on SIGINT / SIGTERM)
  losses.csv, losses.png loss curves
  config_effective.yaml  every key with its value (rerun with --config on it)
  model.dfo              the final model (dfo model file, for dfo_run's learned frontend)

options:
  --config FILE        training configuration (configs/train_default.yaml lists every key)
  --set KEY=VALUE      override one key (repeatable; later wins)
  --output DIR         output folder (required)
  --resume             continue from DIR/checkpoint.pt (required when it exists: a finished or
                       stopped run is never overwritten by accident)
  --export             write the model file from DIR/checkpoint.pt without training
  --model FILE         model file name for --export and the end of training (default
                       DIR/model.dfo); with --write-depth, the model file to predict with
                       (its network shapes and input size; no checkpoint needed)
  --write-depth OUT    predict the depth of every frame of --sequence with DIR/checkpoint.pt (or
                       --model FILE) and write 16-bit PNGs (metres * 256, the sequence's native size, image file
                       names) into OUT, for `dfo_eval depth --gt SEQ/depth_0 --pred OUT`
  --sequence SEQ_DIR   KITTI-layout sequence folder for --write-depth, or a TUM RGB-D folder
                       (rgb.txt, depth.txt: predictions named as the associated depth maps, for
                       `dfo_eval depth --gt SEQ_DIR/depth --gt-scale 5000`)
  --print-config       print the effective configuration and exit
  --help               this text

Speed on a 2-core CPU: export GLIBC_TUNABLES=glibc.malloc.mmap_max=0:glibc.malloc.trim_threshold=68719476736
before starting (stops large buffers being returned to the OS each step; ~1.6x with channels_last),
and OMP_WAIT_POLICY=PASSIVE when other processes share the cores.
)";

using dfo::apps::UsageError;

struct Args {
  std::string config_path;
  std::vector<std::string> overrides;
  std::string output_dir;
  std::string model_path;
  std::string write_depth_dir;
  std::string sequence_dir;
  bool resume = false;
  bool export_model = false;
  bool print_config = false;
  bool help = false;
};

Args ParseArgs(int argc, char** argv) {
  Args args;
  dfo::apps::ArgParser parser;
  parser.Flag("--help", &args.help, "-h")
      .Flag("--resume", &args.resume)
      .Flag("--export", &args.export_model)
      .Flag("--print-config", &args.print_config)
      .Value("--config", &args.config_path)
      .Values("--set", &args.overrides)
      .Value("--output", &args.output_dir)
      .Value("--model", &args.model_path)
      .Value("--write-depth", &args.write_depth_dir)
      .Value("--sequence", &args.sequence_dir);
  parser.Parse(argc, argv);
  return args;
}

std::atomic<bool> g_stop(false);
extern "C" void OnSignal(int) { g_stop = true; }

learned::TrainingOptions OptionsFromConfig(const io::Config& c) {
  learned::TrainingOptions o;
  learned::NetworkOptions& n = o.network;
  n.input_width = c.GetInt("network.input_width");
  n.input_height = c.GetInt("network.input_height");
  n.num_levels = c.GetInt("network.num_levels");
  n.channels = c.GetIntList("network.channels");
  n.patch_sizes = c.GetIntList("network.patch_sizes");
  n.rho = c.GetDoubleList("network.rho");
  n.input_mean = c.GetDoubleList("network.input_mean");
  n.input_std = c.GetDoubleList("network.input_std");
  n.depth_encoder_widths = c.GetIntList("network.depth_encoder_widths");
  n.depth_decoder_widths = c.GetIntList("network.depth_decoder_widths");
  n.feature_encoder_widths = c.GetIntList("network.feature_encoder_widths");
  n.feature_decoder_widths = c.GetIntList("network.feature_decoder_widths");
  n.reconstruction_width = c.GetInt("network.reconstruction_width");
  o.loss.ssim_weight = c.GetDouble("loss.ssim_weight");
  o.loss.dssim_clamp = c.GetDouble("loss.dssim_clamp");
  o.loss.l1_clamp = c.GetDouble("loss.l1_clamp");
  o.loss.smooth_weight = c.GetDouble("loss.smooth_weight");
  o.loss.sparsity_weight = c.GetDouble("loss.sparsity_weight");
  o.loss.ae_weight = c.GetDouble("loss.ae_weight");
  o.loss.depth_mean_m = c.GetDouble("loss.depth_mean_m");
  o.loss.depth_prior_weight = c.GetDouble("loss.depth_prior_weight");
  o.loss.automask = c.GetBool("loss.automask");
  o.loss.depth_gauge = c.GetString("loss.depth_gauge") == "geometric_mean"
                           ? learned::LossOptions::DepthGauge::kGeometricMean
                           : learned::LossOptions::DepthGauge::kMedian;
  o.loss.full_resolution = c.GetBool("loss.full_resolution");
  o.loss.depth_consistency_weight = c.GetDouble("loss.depth_consistency_weight");
  o.loss.teacher_weight = c.GetDouble("loss.teacher_weight");
  o.loss.teacher_huber = c.GetDouble("loss.teacher_huber");
  o.augment.enabled = c.GetBool("augment.enabled");
  o.augment.max_scale = c.GetDouble("augment.max_scale");
  o.augment.color_probability = c.GetDouble("augment.color_probability");
  o.augment.color_min = c.GetDouble("augment.color_min");
  o.augment.color_max = c.GetDouble("augment.color_max");
  o.gn.num_levels = n.num_levels;
  o.gn.patch_size = n.patch_sizes.empty() ? 3 : n.patch_sizes[0];
  o.gn.max_points = c.GetInt("gn.max_points");
  o.gn.max_iterations = c.GetIntList("gn.max_iterations");
  o.gn.min_gradient = c.GetDouble("gn.min_gradient");
  o.gn.outlier_rule = c.GetBool("gn.outlier_rule");
  o.gn_use_masks = c.GetBool("gn.use_masks");
  o.source_feature_grad = c.GetBool("gn.source_feature_grad");
  o.pose_gradient = c.GetBool("gn.pose_gradient");
  o.gn_handmade_iterations = c.GetInt("gn.handmade_iterations");
  o.pose_source = c.GetString("gn.pose_source") == "ground_truth"
                      ? learned::TrainingOptions::PoseSource::kGroundTruth
                      : learned::TrainingOptions::PoseSource::kAlignment;
  o.initial_depth_m = c.GetDouble("train.initial_depth_m");
  o.batch_size = c.GetInt("train.batch_size");
  o.static_threshold = c.GetDouble("train.static_threshold");
  o.ae_iterations = c.GetInt("train.ae_iterations");
  o.iterations = c.GetInt("train.iterations");
  o.learning_rate = c.GetDouble("train.learning_rate");
  o.final_learning_rate = c.GetDouble("train.final_learning_rate");
  o.max_grad_norm = c.GetDouble("train.max_grad_norm");
  o.temperature_start = c.GetDouble("train.temperature_start");
  o.temperature_end = c.GetDouble("train.temperature_end");
  o.seed = static_cast<uint64_t>(c.GetInt64("train.seed"));
  o.threads = c.GetInt("train.threads");
  o.device = c.GetString("train.device");
  o.channels_last = c.GetBool("train.channels_last");
  o.checkpoint_every = c.GetInt("train.checkpoint_every");
  o.Check();
  return o;
}

// Opens a KITTI-layout sequence folder at the training size, RGB.
io::Sequence OpenTrainingSequence(const std::string& folder, int width, int height) {
  io::DatasetOptions d;
  d.type = "kitti";
  d.path = folder;
  d.image_width = width;
  d.image_height = height;
  d.color = true;
  return io::OpenSequence(d);
}

bool IsTumFolder(const std::string& folder) {
  return std::filesystem::exists(std::filesystem::path(folder) / "rgb.txt");
}

// A TUM RGB-D folder (rgb.txt, depth.txt) for --write-depth: RGB with the associated depth maps,
// at the training width and the height that keeps the images' aspect ratio (a multiple of
// 2^(levels - 1); the networks are fully convolutional).
io::Sequence OpenTumSequence(const std::string& folder, const learned::NetworkOptions& network) {
  io::DatasetOptions probe;
  probe.type = "tum";
  probe.path = folder;
  probe.depth = true;
  const PinholeCamera native = io::OpenSequence(probe).native_camera();
  const int divisor = 1 << (network.num_levels - 1);
  const double height = static_cast<double>(network.input_width) * native.height / native.width;
  io::DatasetOptions d = probe;
  d.color = true;
  d.image_width = network.input_width;
  d.image_height = std::max(divisor, static_cast<int>(std::lround(height / divisor)) * divisor);
  return io::OpenSequence(d);
}

ImageU8 ToRgb(ImageU8 image) {
  if (image.channels() == 3) return image;
  ImageU8 rgb(image.width(), image.height(), 3);
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      for (int c = 0; c < 3; ++c) rgb(x, y, c) = image(x, y);
    }
  }
  return rgb;
}

// A keyframe depth folder (dfo_run run.write_keyframe_depth) as a training sequence: its
// keyframes' images, RGB at the folder's image size (its camera), and as targets the points the
// window compared in at least `min_observations` other keyframes.
learned::TrainingSequence LoadTeacher(const std::string& folder, int min_observations) {
  const io::KeyframeDepthFolder kd = io::ReadKeyframeDepthFolder(folder);
  const std::string list = (std::filesystem::path(folder) / "keyframes.txt").string();
  if (kd.keyframes.size() < 3) {
    throw InputError("keyframe depth folder " + folder + ": " +
                     std::to_string(kd.keyframes.size()) +
                     " keyframes, training needs at least 3 (3-frame snippets)");
  }
  learned::TrainingSequence t;
  t.name = folder;
  t.camera = PinholeCamera(kd.fx, kd.fy, kd.cx, kd.cy, kd.image_width, kd.image_height);
  int native_width = 0, native_height = 0;
  size_t targets = 0;
  for (const io::KeyframeDepthEntry& kf : kd.keyframes) {
    const std::string where = list + ", frame " + std::to_string(kf.frame);
    if (kf.image == "-" || kf.image.find('#') != std::string::npos) {
      throw InputError(where + ": image '" + kf.image +
                       "' is not an image file (frames of videos cannot be trained on yet)");
    }
    std::error_code ec;
    if (!std::filesystem::is_regular_file(kf.image, ec)) {
      throw InputError(where + ": image file not found: " + kf.image);
    }
    const ImageU8 image = io::ReadRgb(kf.image);
    if (native_width == 0) {
      native_width = image.width();
      native_height = image.height();
    } else if (image.width() != native_width || image.height() != native_height) {
      throw InputError(where + ": image " + kf.image + " is " + std::to_string(image.width()) +
                       "x" + std::to_string(image.height()) + ", the folder's first image " +
                       std::to_string(native_width) + "x" + std::to_string(native_height));
    }
    t.images.push_back(io::Resize(image, kd.image_width, kd.image_height));
    std::vector<learned::DepthTarget> list_of_kf;
    for (const io::KeyframeDepthPoint& p : kf.points) {
      if (p.observations < min_observations) continue;
      list_of_kf.push_back(
          {static_cast<float>(p.u), static_cast<float>(p.v), static_cast<float>(p.depth_m), 1.0f});
    }
    targets += list_of_kf.size();
    t.depth_targets.push_back(std::move(list_of_kf));
  }
  if (targets == 0) {
    throw InputError("keyframe depth folder " + folder + ": no point with at least " +
                     std::to_string(min_observations) +
                     " observations (data.teacher_min_observations): nothing to teach");
  }
  return t;
}

std::vector<learned::TrainingSequence> LoadData(const io::Config& config,
                                                const learned::TrainingOptions& options) {
  const std::vector<std::string> folders = config.GetStringList("data.sequences");
  const std::vector<std::string> teachers = config.GetStringList("data.teachers");
  if (folders.empty() && teachers.empty()) {
    throw ConfigError(
        "data.sequences and data.teachers are empty: name at least one KITTI-layout sequence "
        "folder (e.g. --set 'data.sequences=[out/train_data/seq101]') or keyframe depth folder");
  }
  const int max_frames = config.GetInt("data.max_frames");
  std::vector<learned::TrainingSequence> data;
  for (const std::string& folder : folders) {
    const io::Sequence seq =
        OpenTrainingSequence(folder, options.network.input_width, options.network.input_height);
    learned::TrainingSequence t;
    t.name = folder;
    t.camera = seq.camera();
    const size_t n =
        max_frames < 0 ? seq.size() : std::min(seq.size(), static_cast<size_t>(max_frames));
    for (size_t i = 0; i < n; ++i) t.images.push_back(ToRgb(seq.LoadImage(i)));
    // Ground-truth poses, when the sequence has one for every used frame: only for the pose-error
    // diagnostic and the diagnostic gn.pose_source = ground_truth, never in the default loss.
    bool all_poses = true;
    for (size_t i = 0; i < n; ++i) all_poses = all_poses && seq.frame(i).world_from_cam.has_value();
    if (all_poses) {
      for (size_t i = 0; i < n; ++i) t.world_from_cam.push_back(*seq.frame(i).world_from_cam);
    }
    std::cout << "dfo_train: " << folder << ": " << n << " frames at " << t.camera.width << "x"
              << t.camera.height << "\n";
    data.push_back(std::move(t));
  }
  const int min_observations = config.GetInt("data.teacher_min_observations");
  for (const std::string& folder : teachers) {
    data.push_back(LoadTeacher(folder, min_observations));
    const learned::TrainingSequence& t = data.back();
    size_t targets = 0;
    for (const auto& list : t.depth_targets) targets += list.size();
    std::cout << "dfo_train: " << folder << ": " << t.images.size() << " keyframes at "
              << t.camera.width << "x" << t.camera.height << ", " << targets
              << " depth targets (at least " << min_observations << " observations)\n";
  }
  return data;
}

std::string FormatDuration(double s) {
  char buf[32];
  if (!(s >= 0.0) || s > 1e7) return "?";
  const int total = static_cast<int>(s);
  if (total >= 3600) {
    std::snprintf(buf, sizeof(buf), "%dh%02dm", total / 3600, (total % 3600) / 60);
  } else if (total >= 60) {
    std::snprintf(buf, sizeof(buf), "%dm%02ds", total / 60, total % 60);
  } else {
    std::snprintf(buf, sizeof(buf), "%ds", total);
  }
  return buf;
}

void WriteCurves(const std::string& dir, const std::vector<learned::StepRecord>& history) {
  learned::WriteHistoryCsv(dir + "/losses.csv", history);
  if (history.empty()) return;
  io::CurveSeries total{"total", {}, {}}, ap{"appearance", {}, {}},
      sm{"smoothness x lambda", {}, {}}, ae{"reconstruction", {}, {}},
      gc{"geometry consistency", {}, {}};
  for (const learned::StepRecord& r : history) {
    total.x.push_back(r.iteration);
    total.y.push_back(r.total);
    if (r.stage == "joint") {
      ap.x.push_back(r.iteration);
      ap.y.push_back(r.appearance);
      sm.x.push_back(r.iteration);
      sm.y.push_back(r.smoothness * 0.1);
      if (r.consistency > 0.0) {
        gc.x.push_back(r.iteration);
        gc.y.push_back(r.consistency);
      }
    }
    ae.x.push_back(r.iteration);
    ae.y.push_back(r.reconstruction);
  }
  io::CurvePlotOptions plot;
  plot.title = "dfo_train losses";
  plot.log_y = true;
  plot.smooth_window = std::max<int>(1, static_cast<int>(history.size() / 50));
  std::vector<io::CurveSeries> series = {total, ae};
  if (!ap.x.empty()) {
    series.push_back(ap);
    series.push_back(sm);
  }
  if (!gc.x.empty()) series.push_back(gc);
  io::WriteCurvePlot(dir + "/losses.png", series, plot);
}

std::string Notes(const Args& args, const learned::Trainer& trainer) {
  std::ostringstream s;
  s << "dfo_train, " << trainer.iteration() << " iterations; config " << args.config_path;
  for (const std::string& o : args.overrides) s << " --set " << o;
  return s.str();
}

// Depth PNGs of every frame of a sequence (predicted at the training size, resized bilinearly to
// the sequence's native size). KITTI layout: named as the images. TUM RGB-D folder: predicted at
// the training width with the images' aspect ratio, named as the associated depth maps (frames
// without one are skipped), so that `dfo_eval depth --gt FOLDER/depth --gt-scale 5000` pairs
// them.
void WriteDepth(learned::Trainer& trainer, const Args& args, const std::string& source) {
  const learned::TrainingOptions& o = trainer.options();
  const bool tum = IsTumFolder(args.sequence_dir);
  const io::Sequence seq =
      tum ? OpenTumSequence(args.sequence_dir, o.network)
          : OpenTrainingSequence(args.sequence_dir, o.network.input_width, o.network.input_height);
  const PinholeCamera native = seq.native_camera();
  std::filesystem::create_directories(args.write_depth_dir);
  double sum_median = 0.0;
  size_t written = 0;
  for (size_t i = 0; i < seq.size(); ++i) {
    if (tum && seq.frame(i).depth_path.empty()) continue;
    const torch::Tensor image = learned::ImageToTensor(ToRgb(seq.LoadImage(i)));
    torch::Tensor depth = trainer.PredictDepth(image)[0];
    depth = torch::nn::functional::interpolate(
                depth, torch::nn::functional::InterpolateFuncOptions()
                           .size(std::vector<int64_t>{native.height, native.width})
                           .mode(torch::kBilinear)
                           .align_corners(false))
                .squeeze()
                .contiguous();
    sum_median += depth.median().item<double>();
    ImageF out(native.width, native.height, 1);
    std::copy(depth.data_ptr<float>(), depth.data_ptr<float>() + depth.numel(), out.data());
    const std::string name =
        std::filesystem::path(tum ? seq.frame(i).depth_path : seq.frame(i).image_path)
            .filename()
            .string();
    io::WriteDepthPng(args.write_depth_dir + "/" + name, out, io::kDepthFolderScale);
    ++written;
  }
  std::cout << "dfo_train: wrote " << written << " depth maps to " << args.write_depth_dir
            << " (mean of the per-image median depths " << sum_median / std::max<size_t>(written, 1)
            << " m, " << source << ")\n";
}

int Run(const Args& args) {
  const io::Config config = io::LoadConfig(args.config_path, io::TrainSchema(), args.overrides);
  if (args.print_config) {
    std::cout << config.ToYaml();
    return 0;
  }
  if (args.output_dir.empty()) throw UsageError("--output DIR is required");
  const learned::TrainingOptions base_options = OptionsFromConfig(config);
  // A device this LibTorch cannot use stops the run here, before any data is read or file written
  // (the trainer checks it again).
  learned::ResolveDevice("train.device", base_options.device);
  // Training memory grows with the input size, the widths and the batch: refused before any
  // data is read or file written when it would exceed train.memory_limit_mb.
  const int64_t memory_limit_mb = config.GetInt("train.memory_limit_mb");
  const double memory_mib =
      learned::EstimateTrainingMemoryMib(base_options.network, base_options.batch_size);
  if (args.write_depth_dir.empty() && !args.export_model && memory_limit_mb > 0 &&
      memory_mib > static_cast<double>(memory_limit_mb)) {
    throw InputError("training would need about " +
                     std::to_string(static_cast<long long>(std::ceil(memory_mib))) + " MiB for " +
                     std::to_string(base_options.network.input_width) + " x " +
                     std::to_string(base_options.network.input_height) +
                     " inputs (network.input_width/input_height) in batches of " +
                     std::to_string(base_options.batch_size) +
                     " (train.batch_size), more than train.memory_limit_mb = " +
                     std::to_string(memory_limit_mb) + " (" +
                     config.Source("train.memory_limit_mb") +
                     "): train smaller inputs or batches, or raise train.memory_limit_mb");
  }
  const std::string dir = args.output_dir;
  const std::string checkpoint = dir + "/checkpoint.pt";
  const std::string model_path = args.model_path.empty() ? dir + "/model.dfo" : args.model_path;
  const bool have_checkpoint = std::filesystem::exists(checkpoint);
  const bool inference_only = args.export_model || !args.write_depth_dir.empty();
  if (!args.write_depth_dir.empty() && args.sequence_dir.empty()) {
    throw UsageError("--write-depth needs --sequence SEQ_DIR");
  }
  // --write-depth --model FILE: the networks (shapes, input size, weights) of a model file.
  const bool from_model = !args.write_depth_dir.empty() && !args.model_path.empty();
  std::optional<learned::LoadedModel> model;
  learned::TrainingOptions options = base_options;
  if (from_model) {
    model = learned::LoadModel(args.model_path);
    if (model->kind != learned::LoadedModel::Kind::kDfo) {
      throw InputError("model " + args.model_path +
                       ": a TorchScript model; --write-depth predicts with dfo model files only "
                       "(dfo_run runs TorchScript models)");
    }
    options.network = model->options;
    options.gn.num_levels = model->options.num_levels;
    options.gn.patch_size = model->options.patch_sizes[0];
  }
  if (inference_only && !from_model && !have_checkpoint) {
    throw InputError("no checkpoint " + checkpoint +
                     " to export or predict with (--write-depth "
                     "also takes --model FILE)");
  }
  if (!inference_only && have_checkpoint && !args.resume) {
    throw UsageError(checkpoint +
                     " exists: pass --resume to continue that run, or choose another --output");
  }

  // Inference modes do not need the training data: one synthetic-free stand-in snippet.
  std::vector<learned::TrainingSequence> data;
  if (inference_only) {
    learned::TrainingSequence stand_in;
    stand_in.name = "stand-in";
    stand_in.camera = PinholeCamera(100, 100, options.network.input_width / 2.0,
                                    options.network.input_height / 2.0, options.network.input_width,
                                    options.network.input_height);
    for (int i = 0; i < 3; ++i) {
      ImageU8 im(options.network.input_width, options.network.input_height, 3);
      std::fill(im.data(), im.data() + static_cast<size_t>(im.width()) * im.height() * 3,
                static_cast<uint8_t>(i * 100));
      stand_in.images.push_back(im);
    }
    data.push_back(stand_in);
  } else {
    data = LoadData(config, options);
  }
  learned::TrainingOptions effective = options;
  if (inference_only) {
    effective.static_threshold = 0.0;
    effective.pose_source = learned::TrainingOptions::PoseSource::kAlignment;  // no poses needed
  }
  // Per sequence: its name and the snippets it could give (frames - 2), for the static count.
  std::vector<std::pair<std::string, int>> candidates;
  for (const learned::TrainingSequence& t : data) {
    candidates.emplace_back(t.name, std::max(0, static_cast<int>(t.images.size()) - 2));
  }
  learned::Trainer trainer(effective, std::move(data));
  if (!inference_only) {
    std::vector<int> kept(candidates.size(), 0);
    for (const learned::Snippet& sn : trainer.snippets()) ++kept[sn.sequence];
    for (size_t s = 0; s < candidates.size(); ++s) {
      std::cout << "dfo_train: " << candidates[s].first << ": " << kept[s] << " snippets, "
                << candidates[s].second - kept[s] << " dropped as static (mean grey change < "
                << effective.static_threshold << ")\n";
    }
  }
  if (from_model) {
    torch::NoGradGuard no_grad;
    const auto source = model->networks->named_parameters();
    for (auto& p : trainer.networks()->named_parameters()) p.value().copy_(source[p.key()]);
    const auto buffers = model->networks->named_buffers();
    for (auto& b : trainer.networks()->named_buffers()) b.value().copy_(buffers[b.key()]);
  } else if (have_checkpoint) {
    trainer.LoadCheckpoint(checkpoint);
  } else if (!config.GetString("train.init_checkpoint").empty()) {
    trainer.LoadWeights(config.GetString("train.init_checkpoint"));
    std::cout << "dfo_train: initial weights from " << config.GetString("train.init_checkpoint")
              << "\n";
  }
  if (args.export_model) {
    learned::SaveModel(model_path, *trainer.networks(), Notes(args, trainer));
    std::cout << "dfo_train: wrote " << model_path << " (iteration " << trainer.iteration()
              << ")\n";
    return 0;
  }
  if (!args.write_depth_dir.empty()) {
    WriteDepth(trainer, args,
               from_model ? "model " + args.model_path
                          : "checkpoint iteration " + std::to_string(trainer.iteration()));
    return 0;
  }

  std::filesystem::create_directories(dir);
  config.WriteYaml(dir + "/config_effective.yaml");
  std::cout << "dfo_train: " << trainer.snippets().size() << " snippets, "
            << learned::NumParameters(*trainer.networks()->depth) << " depth + "
            << learned::NumParameters(*trainer.networks()->feature)
            << " feature parameters, training " << options.network.input_width << "x"
            << options.network.input_height << ", batch " << options.batch_size << ", "
            << options.threads << " thread(s), device " << options.device;
  if (trainer.iteration() > 0) std::cout << ", resuming at iteration " << trainer.iteration();
  std::cout << "\n";

  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  const std::string mode = config.GetString("train.progress");
  const bool terminal = mode == "terminal" || (mode == "auto" && isatty(fileno(stdout)));
  const bool quiet = mode == "none";
  const double interval = terminal ? 0.2 : config.GetDouble("train.progress_interval_s");
  const auto start = std::chrono::steady_clock::now();
  const int start_iteration = trainer.iteration();
  double last_print = -1e9;
  auto line = [&](const learned::StepRecord& r) {
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double rate = (r.iteration - start_iteration) / std::max(elapsed, 1e-9);
    char pose_error[96] = "";
    if (std::isfinite(r.pose_rotation_error_deg)) {
      // Diagnostic against the ground truth (not used by the loss).
      std::snprintf(pose_error, sizeof(pose_error), " (vs truth: rot %.2f deg, dir %.0f deg)",
                    r.pose_rotation_error_deg, r.pose_direction_error_deg);
    }
    char consistency[48] = "";
    if (r.consistency > 0.0)
      std::snprintf(consistency, sizeof(consistency), " gc %.4f", r.consistency);
    if (r.teacher > 0.0) {
      const size_t used = std::strlen(consistency);
      std::snprintf(consistency + used, sizeof(consistency) - used, " te %.4f", r.teacher);
    }
    char buf[460];
    std::snprintf(
        buf, sizeof(buf),
        "dfo_train: it %d/%d (%.1f%%) %s  loss %.4f (ap %.4f sm %.4f sp %.4f ae %.4f%s)  "
        "gn ok %.0f%%%s  median depth %.1f m  %.2f it/s  ETA %s",
        r.iteration, options.iterations, 100.0 * r.iteration / options.iterations, r.stage.c_str(),
        r.total, r.appearance, r.smoothness, r.sparsity, r.reconstruction, consistency,
        100.0 * r.gn_ok_ratio, pose_error, r.mean_depth, rate,
        FormatDuration((options.iterations - r.iteration) / std::max(rate, 1e-9)).c_str());
    return std::string(buf);
  };
  learned::StepRecord last;
  trainer.Run(&g_stop, checkpoint, [&](const learned::StepRecord& r) {
    last = r;
    if (r.iteration % options.checkpoint_every == 0) WriteCurves(dir, trainer.history());
    if (quiet) return;
    const double now =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (now - last_print < interval && r.iteration != options.iterations) return;
    last_print = now;
    if (terminal) {
      std::cout << "\r" << line(r) << "\033[K" << std::flush;
    } else {
      std::cout << line(r) << std::endl;
    }
  });
  if (terminal && !quiet) std::cout << "\n";
  WriteCurves(dir, trainer.history());
  if (g_stop) {
    std::cout << "dfo_train: stopped at iteration " << trainer.iteration() << "; checkpoint "
              << checkpoint << " (continue with --resume)\n";
    return 0;
  }
  learned::SaveModel(model_path, *trainer.networks(), Notes(args, trainer));
  std::cout << "dfo_train: finished " << trainer.iteration() << " iterations; wrote " << model_path
            << ", " << dir << "/losses.csv, " << dir << "/losses.png\n";
  return 0;
}

}  // namespace
}  // namespace dfo

int main(int argc, char** argv) {
  dfo::apps::UsePassiveOpenMpWait(argv);
  return dfo::apps::RunMain("dfo_train", [&] {
    const dfo::Args args = dfo::ParseArgs(argc, argv);
    if (args.help) {
      std::cout << dfo::kUsage;
      return 0;
    }
    return dfo::Run(args);
  });
}
