// dfo_run: runs the frontend over a whole sequence, decides keyframes, optimises them in the
// sliding window, and writes the frontend-only and windowed trajectories (both from the same
// frontend outputs), the effective configuration, a summary with the evaluation of both against
// ground truth, a side-by-side table and trajectory plots.
//
//   dfo_run --config FILE.yaml [--set section.key=value ...] [--output DIR]
//
// Run `dfo_run --help` for the details. Errors print one line on stderr and exit with status 1
// (2 for command-line mistakes). An error in the middle of the sequence (an unreadable image)
// still writes everything computed up to that frame, with the message in summary.json's "error".
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <iostream>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "apps/common/backend_config.h"
#include "apps/common/cli.h"
#include "apps/common/evaluation.h"
#include "apps/common/frontend_config.h"
#include "apps/common/keyframe_depth_export.h"
#include "apps/common/lcm_streaming.h"
#include "apps/common/progress.h"
#include "apps/common/run_stats.h"
#include "apps/common/sequence_runner.h"
#include "apps/learned_wiring.h"
#include "dfo_backend/memory_estimate.h"
#include "dfo_core/error.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/frontend.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"
#include "dfo_io/dataset.h"
#include "dfo_io/file_writer.h"

namespace dfo {
namespace {

constexpr const char* kUsage =
    R"(usage: dfo_run --config FILE.yaml [--set section.key=value ...] [--output DIR]

Runs dfo over the sequence named in the configuration's `dataset` section: the frontend (direct
feature-metric tracking against the newest keyframe), the keyframe manager (section keyframe)
and, unless run.mode = frontend, the sliding-window feature-metric bundle adjustment (sections
window, backend). Both trajectories come from the same frontend outputs. Writes into the output
folder:
  frontend_kitti.txt      frontend-only pose of every frame, KITTI format (camera-to-world, 12
                          numbers a line); run.mode frontend or both
  frontend_tum.txt        the same with timestamps, TUM format
  windowed_kitti.txt      windowed (bundle-adjusted) pose of every frame; run.mode windowed or both
  windowed_tum.txt        the same, TUM format
  keyframes_tum.txt       the keyframes' poses, TUM format
  config_effective.yaml   every configuration key with its value (rerun with --config on it)
  summary.json            frames, frames_lost, frontend and windowed (evaluation, Sim3-aligned, as
                          `dfo_eval traj --json`, plus ate_rmse_se3), keyframes, timing_ms (with
                          backend_per_keyframe), fps, peak_rss_mb
  frames.csv              per frame: status, inliers, RMSE, keyframe and reason, stage times
  *_trajectory.png        top views against ground truth (when there is one): frontend and
                          windowed coloured by ATE, comparison = both estimates in one picture
The terminal ends with a side-by-side table of ATE (Sim3, SE3), RPE and snippet ATE.

options:
  --config FILE       YAML configuration (configs/default.yaml lists every key); without it
                      the defaults apply and dataset.path must come from --set
  --set KEY=VALUE     override one key, e.g. --set dataset.sequence=06 (repeatable; later wins)
  --output DIR        output folder (same as --set run.output_dir=DIR)
  --print-config      print the effective configuration and exit
  --help              this text
Flags also take their value after '=' (--output=DIR).

Sources (section frontend): features = handmade | learned, depth = auto | gt | learned, in any
mix.
  auto     (default) gt when the dataset has depth maps, else learned
  gt       the dataset's depth maps (TUM depth/, the depth_0/ folder dfo_synth writes)
  learned  the networks of the model file learned.model (default models/default.dfo, written by
           dfo_train), loaded once and shared by both learned sources; with
           learned.require_input_size (default) the frames must have the model's input size:
           frames are loaded at that size unless dataset.image_width / image_height differ
           from their defaults
  e.g. --set frontend.depth=learned --set learned.model=out/train_default/model.dfo

Streaming (section lcm): --set lcm.enable=true publishes every frame's pose, the window's
keyframe poses after each bundle adjustment, the run status and a stop message on lcm.url
(default udpm://239.255.76.67:7667?ttl=0, this host only); --set lcm.log_path=FILE writes the
same messages into an LCM event log. Watch with dfo_lcm_listen (--help), replay a log with
lcm-logplayer. A URL that cannot be opened stops dfo_run at start-up, saying why.
)";

using dfo::apps::UsageError;

struct Args {
  std::string config_path;
  std::vector<std::string> overrides;
  bool print_config = false;
  bool help = false;
};

Args ParseArgs(int argc, char** argv) {
  Args args;
  apps::ArgParser parser;
  parser.Flag("--help", &args.help, "-h")
      .Flag("--print-config", &args.print_config)
      .Value("--config", &args.config_path)
      .Values("--set", &args.overrides)
      .Custom("--output",
              [&](const std::string& v) { args.overrides.push_back("run.output_dir=" + v); });
  parser.Parse(argc, argv);
  return args;
}

// The keyframe line and the side-by-side table of both trajectories' figures.
void PrintComparison(const apps::SequenceRunResult& result, const apps::RunOutputs& outputs) {
  const io::JsonValue& k = outputs.summary["keyframes"];
  std::cout << "keyframes:   " << result.keyframes.size() << " (";
  bool first = true;
  for (const auto& [reason, count] : k["reasons"].members()) {
    std::cout << (first ? "" : ", ") << reason << " " << count.AsInt();
    first = false;
  }
  std::cout << ")";
  if (result.has_windowed()) {
    std::cout << "; window: " << k["ba_optimized"].AsInt() << " solves kept, "
              << k["ba_failed"].AsInt() << " not, " << k["ba_converged"].AsInt()
              << " converged (median " << k["ba_iterations_median"].AsNumber() << " iterations), "
              << k["marginalized"].AsInt() << " keyframes marginalised into the prior and "
              << k["dropped"].AsInt() << " dropped when leaving the window, at most "
              << k["max_points"].AsInt() << " points / " << k["max_residual_blocks"].AsInt()
              << " residual blocks";
  }
  std::cout << "\n";
  // What the frames were tracked against (tracker.depth).
  const io::JsonValue& t = outputs.summary["tracking_depth"];
  if (t["depth"].AsString() == "window") {
    int tracked = 0;
    for (const auto& [name, count] : t["frames"].members()) tracked += count.AsInt();
    const int window = t["frames"].Has("window") ? t["frames"]["window"].AsInt() : 0;
    std::cout << "tracking:    " << window << " of " << tracked
              << " tracked frames against the window's depths";
    if (!t["median_covered_fraction"].IsNull()) {
      std::cout << " (a window point under "
                << dfo::FormatFixed(100.0 * t["median_covered_fraction"].AsNumber(), 0)
                << " % of the tracker's points, median)";
    }
    std::cout << "; the rest against the depth source's (tracker.depth = window)\n";
  }

  struct Column {
    const char* name;
    const apps::RunEvaluation* evaluation;
  };
  std::vector<Column> columns;
  if (result.has_frontend()) columns.push_back({"frontend-only", &outputs.evaluation});
  if (result.has_windowed()) columns.push_back({"windowed", &outputs.windowed_evaluation});
  for (const Column& c : columns) {
    if (!c.evaluation->available) {
      const io::JsonValue& lengths = outputs.summary["path_length"];
      const std::string key = std::string(c.name) == "windowed" ? "windowed" : "frontend";
      std::cout << "evaluation:  " << c.name << ": none (" << c.evaluation->note
                << "); path length "
                << dfo::FormatFixed(lengths.Has(key) ? lengths[key].AsNumber() : 0.0, 2)
                << " in the estimate's scale\n";
    }
  }
  if (columns.empty() || !columns.front().evaluation->available) return;
  for (const Column& c : columns) {
    if (!c.evaluation->available) return;
  }
  const auto row = [&](const char* label, auto value, int decimals) {
    std::printf("  %-28s", label);
    for (const Column& c : columns) {
      // Exponent form outside 1e-3..1e6 (a Sim3 scale of 1e-5 is not 0.0000).
      std::printf(" %14s", dfo::FormatScale(value(*c.evaluation), decimals).c_str());
    }
    std::printf("\n");
  };
  std::cout.flush();
  std::printf("  %-28s", "");
  for (const Column& c : columns) std::printf(" %14s", c.name);
  std::printf("\n");
  const double path = columns.front().evaluation->sim3.gt_path_length_m;
  row(
      "ATE Sim3 rmse [m]", [](const apps::RunEvaluation& e) { return e.sim3.ate.stats.rmse; }, 4);
  row(
      "ATE Sim3 [% of path]",
      [&](const apps::RunEvaluation& e) {
        return path > 0 ? 100.0 * e.sim3.ate.stats.rmse / path : 0.0;
      },
      3);
  row(
      "ATE SE3 rmse [m]", [](const apps::RunEvaluation& e) { return e.ate_rmse_se3; }, 4);
  row(
      "Sim3 scale", [](const apps::RunEvaluation& e) { return e.sim3.alignment.transform.scale; },
      4);
  row(
      "RPE rmse [m/frame]",
      [](const apps::RunEvaluation& e) { return e.sim3.rpe.translation.rmse; }, 4);
  row(
      "RPE rmse [deg/frame]",
      [](const apps::RunEvaluation& e) { return e.sim3.rpe.rotation_deg.rmse; }, 4);
  row(
      "snippet ATE (5 frames) [m]",
      [](const apps::RunEvaluation& e) { return e.sim3.snippet.mean; }, 4);
  if (columns.front().evaluation->sim3.kitti.num_segments > 0) {
    row(
        "KITTI t_rel [%]", [](const apps::RunEvaluation& e) { return e.sim3.kitti.t_rel_pct; }, 2);
    row(
        "KITTI r_rel [deg/100m]",
        [](const apps::RunEvaluation& e) { return e.sim3.kitti.r_rel_deg_per_100m; }, 3);
  }
  if (columns.front().evaluation->sim3.scale_drift.ratios.size() >= 2) {
    row(
        "scale drift (log std, 50 m)",
        [](const apps::RunEvaluation& e) { return e.sim3.scale_drift.log_std; }, 3);
  }
  if (columns.front().evaluation->sim3.step_scale.ratios.size() >= 2) {
    row(
        "step scale (log std, 20 frames)",
        [](const apps::RunEvaluation& e) { return e.sim3.step_scale.log_std; }, 3);
  }
  row(
      "ATE, true step lengths [m]",
      [](const apps::RunEvaluation& e) { return e.sim3.ate_split.directions_rmse; }, 4);
  row(
      "ATE, true step directions [m]",
      [](const apps::RunEvaluation& e) { return e.sim3.ate_split.lengths_rmse; }, 4);
  std::fflush(stdout);
}

// What was published over LCM and what it cost per frame.
void PrintLcmLine(const apps::LcmRunStreamer& streamer, const std::vector<double>& total_ms) {
  const io::LcmPublisherStats& stats = streamer.stats();
  const double median_ms = apps::Percentile(streamer.publish_ms(), 50);
  const double frame_ms = apps::Percentile(total_ms, 50);
  const auto us = [](double ms) { return dfo::FormatFixed(1000.0 * ms, 1); };
  std::cout << "lcm:         " << stats.messages << " messages (" << stats.bytes / 1024
            << " KiB) to " << streamer.Describe() << "\n             publishing per frame: "
            << "median " << us(median_ms) << " us, p95 "
            << us(apps::Percentile(streamer.publish_ms(), 95)) << " us wall ("
            << dfo::FormatFixed(100.0 * median_ms / frame_ms, 2)
            << " % of the median frame time); CPU median "
            << us(apps::Percentile(streamer.publish_cpu_ms(), 50)) << " us, p95 "
            << us(apps::Percentile(streamer.publish_cpu_ms(), 95)) << " us\n";
  if (stats.failures > 0) {
    std::cerr << "dfo_run: warning: " << stats.failures
              << " LCM publications failed; first: " << stats.first_error << "\n";
  }
  if (!streamer.options().log_path.empty()) {
    std::cout << "             read the log with: dfo_lcm_listen --log "
              << streamer.options().log_path << " --tum poses_tum.txt\n";
  }
}

// The signal that asked the run to stop (0: none) and how many came. SIGINT, SIGTERM and SIGHUP
// end the run at the next frame with every output written. Further ones (an impatient second
// Ctrl-C; coreutils timeout, which signals the child and then its process group) skip the plots
// but still write every result: only SIGKILL ends the process at once.
std::atomic<int> g_stop_signal{0};
std::atomic<int> g_stop_signals{0};

extern "C" void OnStopSignal(int signal) {
  int none = 0;
  g_stop_signal.compare_exchange_strong(none, signal);
  if (g_stop_signals.fetch_add(1) == 1) {
    // Async-signal-safe: write(2) of a constant line.
    static const char kLine[] =
        "dfo_run: another stop signal: writing the results computed so far without the plots "
        "(SIGKILL would end it at once, keeping only frames.csv and the frontend trajectories)\n";
    const ssize_t written = write(STDERR_FILENO, kLine, sizeof(kLine) - 1);
    static_cast<void>(written);
  }
}

int Run(const Args& args) {
  io::Config config = io::LoadConfig(args.config_path, io::DfoSchema(), args.overrides);
  if (args.print_config) {
    std::cout << config.ToYaml();
    return 0;
  }
  io::DatasetOptions dataset = io::DatasetOptionsFromConfig(config);
  if (dataset.path.empty()) {
    throw ConfigError(
        "dataset.path is empty: name the sequence in the configuration or with --set "
        "dataset.path=DIR");
  }
  // frontend.depth = auto: the dataset's depth maps when it has them (resolved once the dataset
  // is open, below), else the network.
  const bool depth_auto = config.GetString("frontend.depth") == "auto";
  FrontendOptions frontend_options = apps::FrontendOptionsFromConfig(config);
  // keyframe.decided_by = manager: the keyframe manager switches the tracker's reference.
  frontend_options.reference.policy = apps::ReferencePolicyFromConfig(config);
  const OdometryOptions odometry_options = apps::OdometryOptionsFromConfig(config);
  const apps::RunMode mode = odometry_options.mode;
  // Before anything is loaded or written (the Odometry constructor checks it again).
  odometry_options.CheckAgainst(frontend_options.tracker);
  const std::string keyframe_depth_dir = config.GetString("run.write_keyframe_depth");
  if (!keyframe_depth_dir.empty() && mode == apps::RunMode::kFrontend) {
    throw ConfigError("run.write_keyframe_depth = " + keyframe_depth_dir + " (" +
                      config.Source("run.write_keyframe_depth") +
                      ") needs the window's points, and run.mode = frontend runs no window: "
                      "use run.mode windowed or both");
  }
  // The ground-truth depth source needs the dataset's depth maps loaded with the images.
  if (frontend_options.depth == "gt") dataset.depth = true;
  io::Sequence sequence = io::OpenSequence(dataset);
  if (depth_auto && !sequence.has_depth()) frontend_options.depth = "learned";
  if (frontend_options.depth == "gt" && !sequence.has_depth()) {
    throw InputError("no depth source: dataset " + sequence.name() + " (" + dataset.path +
                     ") has no depth maps; frontend.depth = gt needs ground-truth depth (TUM "
                     "depth/, KITTI-layout depth_0/), or use the depth network: --set "
                     "frontend.depth=learned (or auto)");
  }
  // dataset.processing_width: the frames at that width and their own aspect ratio, rounded so
  // that every tracker level halves exactly; the depth network at the model's input size.
  if (dataset.processing_width > 0) {
    const int multiple = 1 << (frontend_options.tracker.num_levels - 1);
    const auto [width, height] =
        io::ProcessingSize(sequence.native_camera(), dataset.processing_width, multiple);
    const std::string why =
        "dataset.processing_width = " + std::to_string(dataset.processing_width) + " for " +
        std::to_string(sequence.native_camera().width) + " x " +
        std::to_string(sequence.native_camera().height) + " frames, aspect ratio kept, sides " +
        "multiples of " + std::to_string(multiple) + " (2^(tracker.num_levels - 1))";
    config.Set("dataset.image_width", static_cast<int64_t>(width), why);
    config.Set("dataset.image_height", static_cast<int64_t>(height), why);
    dataset.image_width = width;
    dataset.image_height = height;
    sequence = sequence.WithOutputSize(width, height);
    if (apps::UsesLearnedSources(frontend_options)) {
      const std::string at_model_size =
          "dataset.processing_width: the depth network runs on a copy of each frame at the "
          "model's input size (area-averaged when shrinking), its depth resized back (bilinear)";
      config.Set("learned.require_input_size", false, at_model_size);
      config.Set("learned.depth_at_model_size", true, at_model_size);
    }
  }
  // The learned sources: one model for both, loaded before anything is written.
  apps::FrontendSources sources =
      apps::MakeFrontendSources(frontend_options, apps::LearnedModelOptionsFromConfig(config));
  // Unless the frame size is set to another than the default (configs/default.yaml lists the
  // default), learned sources get frames of the model's input size; config_effective.yaml then
  // records the size used and why.
  const io::DatasetOptions default_dataset;
  if (sources.model && sources.model->options().require_input_size && !dataset.keep_native &&
      dataset.image_width == default_dataset.image_width &&
      dataset.image_height == default_dataset.image_height) {
    const LearnedModelInfo& info = sources.model->info();
    const std::string source = "the input size of " + info.path;
    config.Set("dataset.image_width", static_cast<int64_t>(info.input_width), source);
    config.Set("dataset.image_height", static_cast<int64_t>(info.input_height), source);
    dataset.image_width = info.input_width;
    dataset.image_height = info.input_height;
    sequence = sequence.WithOutputSize(info.input_width, info.input_height);
  }
  // A size the model cannot take stops the run here, naming the keys, not at the first frame.
  if (sources.model) {
    sources.model->CheckFrameSize(sequence.output_width(), sequence.output_height(),
                                  frontend_options.features == "learned");
  }

  // The memory the run will need, from the sizes and options: refused before anything is written.
  MemoryEstimateInput memory_input;
  memory_input.width = sequence.output_width();
  memory_input.height = sequence.output_height();
  memory_input.feature_channels =
      frontend_options.features == "learned" && sources.model
          ? sources.model->info().channels.front()
          : HandmadeFeatureSource(frontend_options.handmade).num_channels();
  if (sources.model) {
    const LearnedModelInfo& info = sources.model->info();
    const bool at_model_size =
        frontend_options.features != "learned" && config.GetBool("learned.depth_at_model_size");
    memory_input.network_pixels =
        at_model_size ? static_cast<int64_t>(info.input_width) * info.input_height
                      : static_cast<int64_t>(memory_input.width) * memory_input.height;
  }
  const MemoryEstimate memory = EstimatePeakMemory(memory_input, odometry_options);
  const int64_t memory_limit_mb = config.GetInt("run.memory_limit_mb");
  if (memory_limit_mb > 0 && memory.total_mib > static_cast<double>(memory_limit_mb)) {
    throw InputError(
        "this run would need about " + memory.Describe() + " for " +
        std::to_string(memory_input.width) + " x " + std::to_string(memory_input.height) +
        " frames (dataset.image_width/image_height" +
        (dataset.keep_native ? ", dataset.keep_native" : "") + ", window.max_keyframes " +
        std::to_string(odometry_options.window.max_keyframes) + ", " +
        std::to_string(memory_input.feature_channels) +
        " feature channels), more than run.memory_limit_mb = " + std::to_string(memory_limit_mb) +
        " (" + config.Source("run.memory_limit_mb") +
        "): process smaller frames (dataset.processing_width), or raise run.memory_limit_mb");
  }

  const std::string output_dir = config.GetString("run.output_dir");
  io::CreateFolder(output_dir, "output folder");
  if (!keyframe_depth_dir.empty()) io::CreateFolder(keyframe_depth_dir, "keyframe depth folder");
  // A reused folder: the outputs of an earlier run (perhaps of another run.mode) go first.
  const std::vector<std::string> stale = apps::RemoveRunOutputs(output_dir);
  // Written first, so that even a run that fails half-way can be repeated.
  const std::string config_path = output_dir + "/config_effective.yaml";
  config.WriteYaml(config_path);
  // LCM: opened before the run, so that a URL that cannot be opened stops it at once.
  const apps::LcmStreamOptions lcm_options = apps::LcmStreamOptionsFromConfig(config);
  std::unique_ptr<apps::LcmRunStreamer> streamer;
  if (lcm_options.active()) streamer = std::make_unique<apps::LcmRunStreamer>(lcm_options, mode);

  std::cout << "dfo_run: " << sequence.name() << ", " << sequence.size() << " frames of "
            << sequence.output_width() << "x" << sequence.output_height() << ", features "
            << frontend_options.features << ", depth " << frontend_options.depth
            << (depth_auto ? " (auto)" : "") << ", " << frontend_options.tracker.num_levels
            << " levels, mode " << apps::RunModeName(mode) << ", keyframes by "
            << (frontend_options.reference.policy == "external" ? "the keyframe manager"
                                                                : "the frontend")
            << " -> " << output_dir << "\n";
  if (sources.model) std::cout << "  " << apps::DescribeLearnedModel(*sources.model) << "\n";
  // Damaged or missing video frames: the first few here, every one in summary.json.
  constexpr size_t kInputWarningsShown = 5;
  const std::vector<std::string>& input_warnings = sequence.warnings();
  for (size_t i = 0; i < input_warnings.size() && i < kInputWarningsShown; ++i) {
    std::cerr << "dfo_run: warning: " << input_warnings[i] << "\n";
  }
  if (input_warnings.size() > kInputWarningsShown) {
    std::cerr << "dfo_run: warning: " << input_warnings.size() - kInputWarningsShown
              << " more damaged or missing frames: summary.json input_warnings lists every one\n";
  }
  if (streamer) std::cout << "  lcm: publishing on " << streamer->Describe() << "\n";
  if (!stale.empty()) {
    std::cout << "  removed " << stale.size() << " output file(s) of an earlier run from "
              << output_dir << "\n";
  }
  for (const auto& key : config.schema().keys()) {
    if (!config.IsDefault(key.path)) {
      std::cout << "  " << key.path << " = " << io::FormatConfigValue(config.Get(key.path)) << "  ("
                << config.Source(key.path) << ")\n";
    }
  }
  std::cout.flush();

  apps::SequenceFrameProvider provider(sequence);
  Odometry odometry(frontend_options, odometry_options, std::move(sources.features),
                    std::move(sources.depth));
  apps::SequenceRunOptions run_options;
  run_options.progress = apps::ParseProgressMode(config.GetString("run.progress"));
  run_options.progress_interval_s = config.GetDouble("run.progress_interval_s");
  run_options.progress_stream = stdout;
  run_options.log_stream = stderr;
  if (streamer) {
    run_options.frame_observer =
        [&](const apps::FrameRecord& frame, const apps::SequenceRunResult& so_far,
            const Odometry& system) { streamer->OnFrame(frame, so_far, system.poses()); };
    run_options.solve_observer = [&](const KeyframeRecord& keyframe,
                                     const apps::SequenceRunResult& so_far,
                                     const Odometry& system) {
      streamer->PublishKeyframeBatch(keyframe.frame_index, so_far, system.poses());
    };
  }
  // frames.csv and the frontend trajectories are written as the run goes (a killed run keeps
  // them); a stop signal ends the run at the next frame with every output written; a closed
  // stdout (dfo_run ... | head) must not end it either.
  apps::LiveRunFiles live(output_dir, mode != apps::RunMode::kWindowed);
  run_options.frame_observer = [&, stream = run_options.frame_observer](
                                   const apps::FrameRecord& frame,
                                   const apps::SequenceRunResult& so_far, const Odometry& system) {
    live.Append(frame, system.poses().FrontendPose(frame.tracked.index));
    if (stream) stream(frame, so_far, system);
  };
  run_options.stop_signal = &g_stop_signal;  // a signal during start-up stops it at frame 0
  std::signal(SIGPIPE, SIG_IGN);
  apps::SequenceRunResult result = apps::RunSequence(provider, &odometry, run_options);
  result.stop_signals = g_stop_signals.load();
  result.memory_estimate_mib = memory.total_mib;
  if (streamer) streamer->Finish(result);
  apps::RunOutputs outputs = apps::WriteRunOutputs(
      result, output_dir, config.GetBool("run.plot") && g_stop_signals.load() < 2);
  if (!keyframe_depth_dir.empty()) {
    try {
      io::WriteKeyframeDepthFolder(keyframe_depth_dir, apps::KeyframeDepthOfRun(result, sequence));
      outputs.files.push_back(keyframe_depth_dir + "/ (keyframe depth)");
    } catch (const std::exception& e) {
      outputs.incomplete.push_back(keyframe_depth_dir + ": " + e.what());
    }
  }

  const int lost = result.CountStatus(TrackingStatus::kLost);
  std::cout << "frames:      " << result.frames.size() << " of " << result.frames_in_sequence
            << " processed, " << lost << " lost, " << result.CountStatus(TrackingStatus::kDegraded)
            << " degraded\n";
  std::vector<double> total_ms, tracking_ms;
  for (const apps::FrameRecord& f : result.frames) {
    total_ms.push_back(f.total_ms);
    tracking_ms.push_back(f.tracking_ms);
  }
  std::vector<double> backend_ms;
  for (const apps::KeyframeRecord& k : result.keyframes) {
    if (k.ba_ran) backend_ms.push_back(k.backend_ms);
  }
  const double fps = result.wall_s > 0 ? result.frames.size() / result.wall_s : 0.0;
  std::cout << "speed:       " << dfo::FormatFixed(fps, 1) << " frames/s; per frame median "
            << dfo::FormatFixed(apps::Percentile(total_ms, 50), 2) << " ms (tracking "
            << dfo::FormatFixed(apps::Percentile(tracking_ms, 50), 2) << " ms, p95 "
            << dfo::FormatFixed(apps::Percentile(tracking_ms, 95), 2) << " ms)";
  if (!backend_ms.empty()) {
    std::cout << "; window per keyframe median "
              << dfo::FormatFixed(apps::Percentile(backend_ms, 50), 1) << " ms, p95 "
              << dfo::FormatFixed(apps::Percentile(backend_ms, 95), 1) << " ms";
  }
  std::cout << "\n";
  if (streamer) PrintLcmLine(*streamer, total_ms);
  std::cout << "written:     " << config_path;
  for (const std::string& f : outputs.files) std::cout << "\n             " << f;
  std::cout << "\n";
  // Last: keyframes and the side-by-side table of both trajectories.
  PrintComparison(result, outputs);
  std::cout.flush();

  for (const std::string& what : live.problems()) std::cerr << "dfo_run: warning: " << what << "\n";
  const auto evaluation_warnings = [](const apps::RunEvaluation& e, const char* which) {
    if (!e.available) return;
    for (const std::string& w : dfo::EvaluationWarnings(e.sim3)) {
      std::cerr << "dfo_run: warning: " << which << " trajectory: " << w << "\n";
    }
  };
  if (result.has_frontend()) evaluation_warnings(outputs.evaluation, "frontend");
  if (result.has_windowed()) evaluation_warnings(outputs.windowed_evaluation, "windowed");
  for (const std::string& what : outputs.incomplete) {
    std::cerr << "dfo_run: error: not written completely: " << what << "\n";
  }
  if (result.interrupted_signal != 0) {
    std::cerr << "dfo_run: interrupted by " << apps::SignalName(result.interrupted_signal)
              << (g_stop_signals.load() > 1
                      ? " (" + std::to_string(g_stop_signals.load()) + " stop signals: no plots)"
                      : std::string())
              << " after " << result.frames.size() << " of " << result.frames_in_sequence
              << " frames; their results are in " << output_dir << "\n";
    return 128 + result.interrupted_signal;
  }
  if (!result.error.empty()) {
    std::cerr << "dfo_run: error: " << result.error << " (stopped after " << result.frames.size()
              << " of " << result.frames_in_sequence << " frames; their results are in "
              << output_dir << ")\n";
    return 1;
  }
  return outputs.incomplete.empty() ? 0 : 1;
}

}  // namespace
}  // namespace dfo

int main(int argc, char** argv) {
  // From the start: a stop signal during start-up (loading the model, opening the video) ends the
  // run before its first frame with the outputs written and a line saying so.
  dfo::apps::UsePassiveOpenMpWait(argv);  // may re-execute the process: handlers after it
  for (const int signal : {SIGINT, SIGTERM, SIGHUP}) std::signal(signal, dfo::OnStopSignal);
  return dfo::apps::RunMain("dfo_run", [&] {
    const dfo::Args args = dfo::ParseArgs(argc, argv);
    if (args.help) {
      std::cout << dfo::kUsage;
      return 0;
    }
    return dfo::Run(args);
  });
}
