#include "apps/common/sequence_runner.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <utility>

#include "apps/common/run_stats.h"
#include "dfo_core/error.h"
#include "dfo_io/plot.h"
#include "dfo_io/trajectory_io.h"

namespace dfo::apps {
namespace {

namespace fs = std::filesystem;

void WriteTextFile(const std::string& path, const std::string& text) {
  std::ofstream file(path);
  if (!file) throw InputError("cannot write " + path);
  file << text;
  if (!file) throw InputError("error while writing " + path);
}

std::string Csv(double v, int decimals) {
  if (!std::isfinite(v)) return "nan";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

}  // namespace

Frame ToFrame(io::LoadedFrame loaded) {
  Frame frame;
  frame.index = loaded.index;
  frame.timestamp_ns = loaded.timestamp_ns;
  frame.image = std::move(loaded.image);
  frame.depth_m = std::move(loaded.depth_m);
  frame.camera = loaded.camera;
  return frame;
}

Trajectory SequenceRunResult::Estimate() const {
  Trajectory t;
  for (const FrameRecord& f : frames) t.Add(f.tracked.timestamp_ns, f.tracked.world_from_cam);
  return t;
}

int SequenceRunResult::CountStatus(TrackingStatus status) const {
  int n = 0;
  for (const FrameRecord& f : frames) n += f.tracked.status == status ? 1 : 0;
  return n;
}

SequenceRunResult RunSequence(const FrameProvider& provider, Frontend* frontend,
                              const SequenceRunOptions& options) {
  SequenceRunResult result;
  result.sequence_name = provider.name();
  result.frames_in_sequence = provider.size();
  result.frames.reserve(provider.size());
  ProgressReporter progress(options.progress_stream, options.progress, provider.size(),
                            options.progress_interval_s, options.label);
  const auto start = std::chrono::steady_clock::now();
  int lost = 0;
  for (size_t i = 0; i < provider.size(); ++i) {
    // Any error ends the run here; what was computed so far is kept (and written by the caller).
    try {
      const auto frame_start = std::chrono::steady_clock::now();
      io::LoadedFrame loaded = provider.Load(i);
      FrameRecord record;
      record.ground_truth = loaded.world_from_cam;
      record.load_ms = MillisecondsSince(frame_start);
      const Frame frame = ToFrame(std::move(loaded));
      record.tracked = frontend->Process(frame);
      record.total_ms = MillisecondsSince(frame_start);
      const FrontendTimings& t = frontend->last_timings();
      record.features_ms = t.features_ms;
      record.depth_ms = t.depth_ms;
      record.tracking_ms = t.tracking_ms;
      lost += record.tracked.status == TrackingStatus::kLost ? 1 : 0;
      result.frames.push_back(std::move(record));
    } catch (const std::exception& e) {
      result.error = e.what();
      break;
    }
    progress.Update(result.frames.size(), "lost " + std::to_string(lost));
  }
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.Finish(result.frames.size(), "lost " + std::to_string(lost));
  return result;
}

RunEvaluation EvaluateRun(const SequenceRunResult& result) {
  RunEvaluation e;
  Trajectory gt, est;
  for (const FrameRecord& f : result.frames) {
    if (!f.ground_truth) continue;
    gt.Add(f.tracked.timestamp_ns, *f.ground_truth);
    est.Add(f.tracked.timestamp_ns, f.tracked.world_from_cam);
  }
  if (gt.size() < 3) {
    e.note = gt.empty() ? "no ground truth for the processed frames"
                        : "only " + std::to_string(gt.size()) +
                              " processed frames have ground truth, at least 3 are needed";
    return e;
  }
  try {
    TrajectoryEvaluationOptions sim3;
    sim3.alignment = AlignmentType::kSim3;  // monocular: the scale is arbitrary (evo_ape -as)
    e.sim3 = EvaluateTrajectory(gt, est, sim3);
    TrajectoryAlignmentOptions se3;
    se3.type = AlignmentType::kSe3;  // metric-scale view of the same estimate (evo_ape -a)
    e.ate_rmse_se3 = ComputeAte(gt, AlignTrajectory(est, gt, se3).aligned_estimate).stats.rmse;
    e.available = true;
  } catch (const InputError& error) {
    // Degenerate geometry (e.g. an estimate that never moved): no alignment exists.
    e.note = std::string("evaluation impossible: ") + error.what();
  }
  return e;
}

io::JsonValue MakeRunSummary(const SequenceRunResult& result, const RunEvaluation& evaluation) {
  io::JsonValue s = io::JsonValue::Object();
  s.Set("sequence", result.sequence_name);
  s.Set("frames", static_cast<int64_t>(result.frames.size()));
  s.Set("frames_in_sequence", static_cast<int64_t>(result.frames_in_sequence));
  s.Set("frames_ok", result.CountStatus(TrackingStatus::kOk));
  s.Set("frames_degraded", result.CountStatus(TrackingStatus::kDegraded));
  s.Set("frames_lost", result.CountStatus(TrackingStatus::kLost));
  s.Set("frames_reference", result.CountStatus(TrackingStatus::kReference));
  int references = 0;
  for (const FrameRecord& f : result.frames) references += f.tracked.is_new_reference ? 1 : 0;
  s.Set("references", references);

  if (evaluation.available) {
    io::JsonValue frontend = EvaluationToJson(evaluation.sim3);
    frontend.Set("ate_rmse_se3", evaluation.ate_rmse_se3);
    frontend.Set("gt_path_length_m", evaluation.sim3.gt_path_length_m);
    const double length = evaluation.sim3.gt_path_length_m;
    frontend.Set("ate_rmse_pct_of_path", length > 0.0
                                             ? 100.0 * evaluation.sim3.ate.stats.rmse / length
                                             : std::numeric_limits<double>::quiet_NaN());
    s.Set("frontend", std::move(frontend));
  } else {
    s.Set("frontend", nullptr);
    s.Set("frontend_note", evaluation.note);
  }

  std::vector<double> load, features, depth, tracking, total;
  for (const FrameRecord& f : result.frames) {
    load.push_back(f.load_ms);
    features.push_back(f.features_ms);
    depth.push_back(f.depth_ms);
    tracking.push_back(f.tracking_ms);
    total.push_back(f.total_ms);
  }
  io::JsonValue timing = io::JsonValue::Object();
  timing.Set("load", TimingToJson(SummariseTimes(load)));
  timing.Set("features", TimingToJson(SummariseTimes(features)));
  timing.Set("depth", TimingToJson(SummariseTimes(depth)));
  timing.Set("tracking", TimingToJson(SummariseTimes(tracking)));
  timing.Set("total_per_frame", TimingToJson(SummariseTimes(total)));
  s.Set("timing_ms", std::move(timing));
  s.Set("fps", result.wall_s > 0.0 ? static_cast<double>(result.frames.size()) / result.wall_s
                                   : std::numeric_limits<double>::quiet_NaN());
  s.Set("wall_s", result.wall_s);
  s.Set("peak_rss_mb", PeakRssMb());
  if (!result.error.empty()) s.Set("error", result.error);
  return s;
}

void WriteFramesCsv(const std::string& path, const SequenceRunResult& result) {
  std::string text =
      "index,timestamp_s,status,reference_index,new_reference,num_points,num_inliers,rmse,"
      "iterations,load_ms,features_ms,depth_ms,tracking_ms,total_ms\n";
  for (const FrameRecord& f : result.frames) {
    const TrackedFrame& t = f.tracked;
    text += std::to_string(t.index) + "," + io::FormatNsAsSeconds(t.timestamp_ns) + "," +
            TrackingStatusName(t.status) + "," + std::to_string(t.reference_index) + "," +
            (t.is_new_reference ? "1" : "0") + "," + std::to_string(t.num_points) + "," +
            std::to_string(t.num_inliers) + "," + Csv(t.rmse, 6) + "," +
            std::to_string(t.iterations) + "," + Csv(f.load_ms, 3) + "," + Csv(f.features_ms, 3) +
            "," + Csv(f.depth_ms, 3) + "," + Csv(f.tracking_ms, 3) + "," + Csv(f.total_ms, 3) +
            "\n";
  }
  WriteTextFile(path, text);
}

RunOutputs WriteRunOutputs(const SequenceRunResult& result, const std::string& output_dir,
                           bool plot) {
  RunOutputs out;
  std::error_code ec;
  fs::create_directories(output_dir, ec);
  if (!fs::is_directory(output_dir, ec)) {
    throw InputError("cannot create output folder " + output_dir);
  }
  const auto path = [&](const char* name) { return (fs::path(output_dir) / name).string(); };

  // Every processed frame gets a pose line, lost ones included (their pose is the last good one):
  // users ask for the poses of every frame, and the gap stays visible in frames.csv.
  const Trajectory estimate = result.Estimate();
  io::WriteKittiTrajectory(path("frontend_kitti.txt"), estimate);
  out.files.push_back(path("frontend_kitti.txt"));
  io::WriteTumTrajectory(path("frontend_tum.txt"), estimate);
  out.files.push_back(path("frontend_tum.txt"));
  WriteFramesCsv(path("frames.csv"), result);
  out.files.push_back(path("frames.csv"));

  out.evaluation = EvaluateRun(result);
  if (plot && out.evaluation.available) {
    const TrajectoryEvaluation& e = out.evaluation.sim3;
    io::TrajectoryPlotOptions options;
    options.title = "dfo_run frontend: " + result.sequence_name + " (" +
                    std::to_string(result.frames.size()) + " frames, " +
                    std::to_string(result.CountStatus(TrackingStatus::kLost)) + " lost)";
    options.text_lines = EvaluationPlotLines(e);
    out.plot_path = path("frontend_trajectory.png");
    io::WriteTrajectoryPlot(out.plot_path, e.ground_truth, e.alignment.aligned_estimate,
                            e.ate.errors, options);
    out.files.push_back(out.plot_path);
  }
  out.summary = MakeRunSummary(result, out.evaluation);
  WriteTextFile(path("summary.json"), out.summary.Dump(2) + "\n");
  out.files.push_back(path("summary.json"));
  return out;
}

}  // namespace dfo::apps
