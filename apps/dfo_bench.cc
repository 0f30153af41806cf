// dfo_bench: speed of the frontend, printed (nothing is asserted; tests never time anything).
//
//   dfo_bench [--frames N] [--threads T] [--levels L] [--seed S]      tracker benchmark
//   dfo_bench --whole-run [--run-frames N] [--sequence DIR]            + whole dfo_run pipeline
//   dfo_bench --features learned --depth learned --model FILE          learned sources
//   dfo_bench --write-untrained-model FILE [--model-size WxH]          model file for tests
//
// 1. Tracker: renders N synthetic frames of 416 x 128 in memory first (not timed), then runs the
//    Frontend (hand-made features, ground-truth depth, default points) over them and prints the
//    median and 95th percentile of the feature, depth and tracking times per frame and the frames
//    per second of Frontend::Process alone.
// 2. Whole run (--whole-run): the same path as dfo_run (PNG loading and resizing, frontend,
//    progress) on a synthetic sequence on disk with ground-truth depth, default 500 frames,
//    rendered with dfo_synth's writer into a temporary folder unless --sequence names one.
// 3. --features / --depth learned: the sources of the model file --model (loaded once, shared,
//    as in dfo_run; any input size divisible by 2^(levels - 1), require_input_size off).
// --write-untrained-model writes an untrained model (WriteUntrainedModel, seed --seed) and exits:
// a model file with valid shapes for tests of the learned wiring, without training.
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "apps/common/cli.h"
#include "apps/common/evaluation.h"
#include "apps/common/run_stats.h"
#include "apps/common/sequence_runner.h"
#include "apps/learned_wiring.h"
#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_core/timing.h"
#include "dfo_frontend/frontend.h"
#include "dfo_io/dataset.h"
#include "dfo_io/synth_writer.h"

namespace dfo {
namespace {

constexpr const char* kUsage = R"(usage: dfo_bench [options]

Times dfo's frontend on the synthetic street sequence (416 x 128, default points; hand-made
features and ground-truth depth unless --features / --depth say learned). Prints figures; asserts
nothing.

options:
  --frames N        frames for the tracker benchmark, rendered in memory first (default 200)
  --threads T       FrontendOptions::num_threads (default 2)
  --levels L        pyramid levels (default 4)
  --seed S          synthetic sequence seed (default 1)
  --whole-run       also time the whole dfo_run path (loading PNGs from disk) on a sequence
  --run-frames N    frames of that sequence (default 500)
  --sequence DIR    use this KITTI-layout root (with depth_0) instead of rendering one
  --features NAME   feature source: handmade (default) or learned
  --depth NAME      depth source: gt (default) or learned
  --model FILE      model file of the learned sources (default models/default.dfo); frames of
                    any size the model's levels divide are accepted
  --write-untrained-model FILE
                    write an untrained model (valid shapes, weights from --seed) and exit; for
                    tests of the learned sources without a trained model
  --model-size WxH  input size recorded in that model (default 416x128)
  --help            this text
)";

using apps::UsageError;

struct Args {
  int frames = 200;
  int threads = 2;
  int levels = 4;
  uint64_t seed = 1;
  bool whole_run = false;
  int run_frames = 500;
  std::string sequence;
  std::string features = "handmade";
  std::string depth = "gt";
  std::string model = "models/default.dfo";
  std::string write_model;
  int model_width = 416;
  int model_height = 128;
  bool help = false;
};

Args ParseArgs(int argc, char** argv) {
  Args a;
  int seed = 1;
  apps::ArgParser parser;
  parser.Flag("--help", &a.help, "-h")
      .Int("--frames", &a.frames, 2, 100000)
      .Int("--threads", &a.threads, 1, 256)
      .Int("--levels", &a.levels, 1, 8)
      .Int("--seed", &seed, 0, 1 << 30)
      .Flag("--whole-run", &a.whole_run)
      .Int("--run-frames", &a.run_frames, 2, 100000)
      .Value("--sequence", &a.sequence)
      .Value("--features", &a.features)
      .Value("--depth", &a.depth)
      .Value("--model", &a.model)
      .Value("--write-untrained-model", &a.write_model)
      .Custom("--model-size", [&](const std::string& size) {
        const size_t x = size.find('x');
        if (x == std::string::npos) {
          throw UsageError("--model-size expects WxH (e.g. 416x128), got '" + size + "'");
        }
        a.model_width = static_cast<int>(
            apps::ParseIntArgument("--model-size width", size.substr(0, x), 8, 8192));
        a.model_height = static_cast<int>(
            apps::ParseIntArgument("--model-size height", size.substr(x + 1), 8, 8192));
      });
  parser.Parse(argc, argv);
  if (parser.Given("--seed")) a.seed = static_cast<uint64_t>(seed);
  return a;
}

FrontendOptions BenchFrontendOptions(const Args& args) {
  FrontendOptions o;  // default points; hand-made features and ground-truth depth by default
  o.features = args.features;
  o.depth = args.depth;
  o.tracker.num_levels = args.levels;
  o.num_threads = args.threads;
  o.Check();
  return o;
}

// The frontend's sources: a learned source loads --model (once per call).
apps::FrontendSources MakeBenchSources(const Args& args, const FrontendOptions& options) {
  LearnedModelOptions model;
  model.model_path = args.model;
  model.num_threads = args.threads;
  model.require_input_size = false;  // the benchmark renders 416 x 128 whatever the model's size
  apps::FrontendSources sources = apps::MakeFrontendSources(options, model);
  if (sources.model) {
    std::printf("learned sources: %s\n", apps::DescribeLearnedModel(*sources.model).c_str());
  }
  return sources;
}

// The frontend with its sources.
std::unique_ptr<Frontend> MakeBenchFrontend(const Args& args) {
  const FrontendOptions options = BenchFrontendOptions(args);
  apps::FrontendSources sources = MakeBenchSources(args, options);
  return std::make_unique<Frontend>(options, std::move(sources.features), std::move(sources.depth));
}

void WriteModel(const Args& args) {
  learned::NetworkOptions options;
  options.input_width = args.model_width;
  options.input_height = args.model_height;
  WriteUntrainedModel(args.write_model, options, args.seed, "untrained (dfo_bench)");
  std::printf("wrote an untrained %dx%d model to %s\n", args.model_width, args.model_height,
              args.write_model.c_str());
}

void PrintStage(const char* name, const std::vector<double>& ms) {
  const apps::TimingSummary s = apps::SummariseTimes(ms);
  std::printf("  %-10s median %7.3f ms   p95 %7.3f ms   mean %7.3f ms   max %7.3f ms\n", name,
              s.median_ms, s.p95_ms, s.mean_ms, s.max_ms);
}

void TrackerBenchmark(const Args& args) {
  SyntheticOptions synth;
  synth.seed = args.seed;
  synth.num_frames = args.frames;
  const SyntheticSequence sequence(synth);
  std::printf("rendering %d frames of %dx%d in memory (seed %llu)...\n", args.frames, synth.width,
              synth.height, static_cast<unsigned long long>(args.seed));
  std::fflush(stdout);
  std::vector<Frame> frames;
  frames.reserve(args.frames);
  for (int i = 0; i < args.frames; ++i) {
    const SyntheticFrame f = sequence.RenderFrame(i, 2);
    Frame frame;
    frame.index = i;
    frame.timestamp_ns = f.timestamp_ns;
    frame.image = f.gray;
    frame.depth_m = f.depth;
    frame.camera = sequence.camera();
    frames.push_back(std::move(frame));
  }

  const FrontendOptions options = BenchFrontendOptions(args);
  const std::unique_ptr<Frontend> frontend_ptr = MakeBenchFrontend(args);
  Frontend& frontend = *frontend_ptr;
  std::vector<double> features, depth, tracking, process;
  Trajectory estimate;
  int lost = 0;
  const apps::OtherLoadMeter other_load;
  const auto start = std::chrono::steady_clock::now();
  for (const Frame& frame : frames) {
    const auto t0 = std::chrono::steady_clock::now();
    const TrackedFrame tracked = frontend.Process(frame);
    process.push_back(MsSince(t0));
    const FrontendTimings& t = frontend.last_timings();
    features.push_back(t.features_ms);
    depth.push_back(t.depth_ms);
    tracking.push_back(t.tracking_ms);
    estimate.Add(tracked.timestamp_ns, tracked.world_from_cam);
    lost += tracked.status == TrackingStatus::kLost ? 1 : 0;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::printf(
      "tracker: %d frames %dx%d, features %s, depth %s, %d levels, max_points %d, patch %d, "
      "%d threads\n",
      args.frames, synth.width, synth.height, options.features.c_str(), options.depth.c_str(),
      options.tracker.num_levels, options.tracker.max_points, options.tracker.patch_size,
      options.num_threads);
  PrintStage("features", features);
  PrintStage("depth", depth);
  PrintStage("tracking", tracking);
  PrintStage("process", process);
  std::printf("  frames/s   %.1f (Frontend::Process only, frames in memory)\n",
              static_cast<double>(args.frames) / seconds);
  std::printf("  machine    %s\n", other_load.Describe().c_str());
  // Accuracy as a sanity check of what was timed.
  try {
    const dfo::TrajectoryEvaluation e = dfo::EvaluateTrajectory(sequence.GroundTruth(), estimate);
    std::printf("  accuracy   Sim3 ATE rmse %.4f m = %.3f %% of the %.1f m path, %d lost\n",
                e.ate.stats.rmse, 100.0 * e.ate.stats.rmse / e.gt_path_length_m, e.gt_path_length_m,
                lost);
  } catch (const InputError& error) {
    std::printf("  accuracy   not computed: %s\n", error.what());
  }
}

void WholeRunBenchmark(const Args& args) {
  std::string root = args.sequence;
  std::string temp;
  if (root.empty()) {
    temp = (std::filesystem::temp_directory_path() / ("dfo_bench_" + std::to_string(::getpid())))
               .string();
    SyntheticOptions synth;
    synth.seed = args.seed;
    synth.num_frames = args.run_frames;
    const SyntheticSequence sequence(synth);
    io::SynthWriteOptions write;
    write.output_dir = temp;
    write.num_threads = 2;
    write.write_rgb = false;
    std::printf("\nwriting a %d-frame synthetic sequence to %s...\n", args.run_frames,
                temp.c_str());
    std::fflush(stdout);
    io::WriteSyntheticSequence(sequence, write);
    root = temp;
  }
  io::DatasetOptions dataset;
  dataset.type = "kitti";
  dataset.path = root;
  dataset.sequence = "00";
  dataset.depth = args.depth == "gt";
  const io::Sequence sequence = io::OpenSequence(dataset);
  apps::SequenceFrameProvider provider(sequence);
  const FrontendOptions frontend_options = BenchFrontendOptions(args);
  apps::FrontendSources sources = MakeBenchSources(args, frontend_options);
  OdometryOptions odometry_options;
  odometry_options.mode = OdometryMode::kFrontend;  // the frontend's path, no window
  Odometry odometry(frontend_options, odometry_options, std::move(sources.features),
                    std::move(sources.depth));
  apps::SequenceRunOptions run;
  run.label = "dfo_bench whole run";
  run.progress_interval_s = 10.0;
  const apps::OtherLoadMeter other_load;
  const apps::SequenceRunResult result = apps::RunSequence(provider, &odometry, run);
  if (!result.error.empty()) throw InputError(result.error);
  std::vector<double> load, total;
  for (const apps::FrameRecord& f : result.frames) {
    load.push_back(f.load_ms);
    total.push_back(f.total_ms);
  }
  std::printf("whole run (as dfo_run: PNG image + depth loading, frontend): %zu frames\n",
              result.frames.size());
  PrintStage("load", load);
  PrintStage("per frame", total);
  std::printf("  frames/s   %.1f\n", static_cast<double>(result.frames.size()) / result.wall_s);
  std::printf("  machine    %s\n", other_load.Describe().c_str());
  const apps::RunEvaluation e = apps::EvaluateRun(result);
  if (e.available) {
    std::printf("  accuracy   Sim3 ATE rmse %.4f m = %.3f %% of the %.1f m path, %d lost\n",
                e.sim3.ate.stats.rmse, 100.0 * e.sim3.ate.stats.rmse / e.sim3.gt_path_length_m,
                e.sim3.gt_path_length_m, result.CountStatus(TrackingStatus::kLost));
  }
  std::printf("  peak RSS   %.1f MiB\n", apps::PeakRssMb());
  if (!temp.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(temp, ec);
  }
}

}  // namespace
}  // namespace dfo

int main(int argc, char** argv) {
  return dfo::apps::RunMain("dfo_bench", [&] {
    const dfo::Args args = dfo::ParseArgs(argc, argv);
    if (args.help) {
      std::cout << dfo::kUsage;
      return 0;
    }
    if (!args.write_model.empty()) {
      dfo::WriteModel(args);
      return 0;
    }
    dfo::TrackerBenchmark(args);
    if (args.whole_run) dfo::WholeRunBenchmark(args);
    return 0;
  });
}
