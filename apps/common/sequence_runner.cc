#include "apps/common/sequence_runner.h"

#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "apps/common/cli.h"
#include "apps/common/run_stats.h"
#include "dfo_core/error.h"
#include "dfo_core/timing.h"
#include "dfo_io/curve_plot.h"
#include "dfo_io/file_writer.h"
#include "dfo_io/plot.h"
#include "dfo_io/trajectory_io.h"

namespace dfo::apps {
namespace {

namespace fs = std::filesystem;

// Writes `text` to `path` under a temporary name, renamed when complete.
void WriteTextFile(const std::string& path, const std::string& text) {
  io::WriteFileAtomically(path, text, "output");
}

}  // namespace

const char* SignalName(int signal) {
  switch (signal) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    case SIGHUP:
      return "SIGHUP";
    default:
      return "signal";
  }
}

namespace {

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
  if (poses.num_frames() == static_cast<int>(frames.size())) return poses.FrontendTrajectory();
  Trajectory t;
  for (const FrameRecord& f : frames) t.Add(f.tracked.timestamp_ns, f.tracked.world_from_cam);
  return t;
}

Trajectory SequenceRunResult::WindowedEstimate() const {
  if (poses.num_frames() == static_cast<int>(frames.size())) return poses.WindowedTrajectory();
  return Estimate();
}

int SequenceRunResult::CountStatus(TrackingStatus status) const {
  int n = 0;
  for (const FrameRecord& f : frames) n += f.tracked.status == status ? 1 : 0;
  return n;
}

namespace {

// The window's figures of keyframe `kf` in the record of its frame.
void BookKeyframeWindow(const KeyframeRecord& kf, FrameRecord* f) {
  f->keyframe_depth_scale = kf.window_scale;
  f->keyframe_source_scale = kf.source_scale;
  f->windowed_step_scale = kf.step_scale;
  if (kf.stereo.num_views > 0) f->keyframe_stereo_fraction = kf.stereo.fraction;
  f->keyframe_solve = KeyframeSolveName(kf);
}

// Copies the record of keyframe `frame_index` once its window solve was applied, and logs a solve
// that was not kept.
void RefreshKeyframe(const Odometry& odometry, int frame_index, const SequenceRunOptions& options,
                     SequenceRunResult* result) {
  const int source = FindKeyframeRecord(odometry.keyframes(), frame_index);
  if (source < 0) return;
  const KeyframeRecord& kf = odometry.keyframes()[source];
  const int target = FindKeyframeRecord(result->keyframes, frame_index);
  if (target >= 0) result->keyframes[target] = kf;
  // A solve applied on the backend thread after the keyframe's own frame was booked.
  for (auto f = result->frames.rbegin(); f != result->frames.rend(); ++f) {
    if (f->tracked.index != frame_index) continue;
    f->windowed_step_scale = kf.step_scale;
    f->keyframe_solve = KeyframeSolveName(kf);
    break;
  }
  if (KeyframeSolveName(kf) == "kept_previous" && options.log_stream != nullptr) {
    std::fprintf(options.log_stream,
                 "%s: warning: bundle adjustment at keyframe %d kept the previous window "
                 "state: %s\n",
                 options.label.c_str(), kf.frame_index,
                 kf.window.message.empty() ? "no reason given" : kf.window.message.c_str());
  }
  if (kf.ba_ran && kf.window.depth_edge_fraction > 0.9 && target >= 0 &&
      result->depth_edge_warnings++ == 0 && options.log_stream != nullptr) {
    std::fprintf(options.log_stream,
                 "%s: warning: keyframe %d: the window's depth-edge rule left out %.0f %% of the "
                 "pixels with depth (a noisy depth map?); window.max_depth_edge_slope = 0 turns "
                 "it off (summary.json keyframes.depth_edge_warnings counts such keyframes)\n",
                 options.label.c_str(), kf.frame_index, 100.0 * kf.window.depth_edge_fraction);
  }
}

}  // namespace

SequenceRunResult RunSequence(const FrameProvider& provider, Odometry* odometry,
                              const SequenceRunOptions& options) {
  SequenceRunResult result;
  result.sequence_name = provider.name();
  result.frames_in_sequence = provider.size();
  result.input_warnings = provider.warnings();
  result.mode = odometry->options().mode;
  result.tracking = odometry->options().tracking;
  result.frames.reserve(provider.size());
  ProgressReporter progress(options.progress_stream, options.progress, provider.size(),
                            options.progress_interval_s, options.label);
  const auto start = std::chrono::steady_clock::now();
  int lost = 0;
  const auto status_text = [&]() {
    return "lost " + std::to_string(lost) + ", keyframes " +
           std::to_string(result.keyframes.size());
  };
  for (size_t i = 0; i < provider.size(); ++i) {
    if (options.stop_signal != nullptr && options.stop_signal->load() != 0) {
      result.interrupted_signal = options.stop_signal->load();
      break;
    }
    // Any error ends the run here; what was computed so far is kept (and written by the caller).
    try {
      const auto frame_start = std::chrono::steady_clock::now();
      io::LoadedFrame loaded = provider.Load(i);
      FrameRecord record;
      record.ground_truth = loaded.world_from_cam;
      record.load_ms = MsSince(frame_start);
      const Frame frame = ToFrame(std::move(loaded));
      OdometryFrame out = odometry->Process(frame);
      record.tracked = std::move(out.tracked);
      record.features_ms = out.timings.features_ms;
      record.depth_ms = out.timings.depth_ms;
      record.tracking_ms = out.timings.tracking_ms;
      record.keyframe = out.keyframe;
      record.keyframe_reason = out.keyframe_reason;
      record.backend_ms = out.backend_ms;
      record.pose_keyframe_index = out.pose_keyframe_index;
      record.kf_from_cam = out.kf_from_cam;
      record.tracking_depth = out.tracking_depth;
      lost += record.tracked.status == TrackingStatus::kLost ? 1 : 0;
      const LostCause cause = record.tracked.lost_cause;
      const LostCause previous_cause =
          result.frames.empty() ? LostCause::kNone : result.frames.back().tracked.lost_cause;
      if ((cause == LostCause::kNoDepth || cause == LostCause::kFewPoints) &&
          cause != previous_cause && options.log_stream != nullptr) {
        std::fprintf(options.log_stream,
                     "%s: warning: frame %d cannot start a tracking reference: %s; frames are "
                     "lost until one can (frames.csv lost_cause)\n",
                     options.label.c_str(), record.tracked.index,
                     cause == LostCause::kNoDepth
                         ? "its depth has too few valid pixels (a depth map of zeros or NaN?)"
                         : "too few textured points with depth");
      }
      record.solved_keyframe = out.solved_keyframe;
      if (out.promoted_keyframe >= 0) {
        // The previous frame became a keyframe (re-track): its record says so from now on.
        const int at = FindKeyframeRecord(odometry->keyframes(), out.promoted_keyframe);
        DFO_CHECK(at >= 0 && !result.frames.empty() &&
                  result.frames.back().tracked.index == out.promoted_keyframe)
            << "promoted keyframe " << out.promoted_keyframe;
        const KeyframeRecord& kf = odometry->keyframes()[at];
        FrameRecord& previous = result.frames.back();
        previous.keyframe = true;
        previous.keyframe_reason = kf.reason;
        if (odometry->has_window()) BookKeyframeWindow(kf, &previous);
        result.keyframes.push_back(kf);
      }
      if (out.keyframe) {
        const KeyframeRecord& kf = odometry->keyframes().back();
        result.keyframes.push_back(kf);
        if (odometry->has_window()) BookKeyframeWindow(kf, &record);
      }
      if (out.solved_keyframe >= 0)
        RefreshKeyframe(*odometry, out.solved_keyframe, options, &result);
      record.total_ms = MsSince(frame_start);
      result.frames.push_back(std::move(record));
      if (options.frame_observer) options.frame_observer(result.frames.back(), result, *odometry);
    } catch (const std::exception& e) {
      result.error = e.what();
      break;
    }
    progress.Update(result.frames.size(), status_text());
  }
  // A solve still running on the backend thread belongs to the run.
  try {
    const int solved = odometry->Flush();
    if (solved >= 0) {
      RefreshKeyframe(*odometry, solved, options, &result);
      const int position = FindKeyframeRecord(result.keyframes, solved);
      if (options.solve_observer && position >= 0) {
        options.solve_observer(result.keyframes[position], result, *odometry);
      }
    }
  } catch (const std::exception& e) {
    if (result.error.empty()) result.error = e.what();
  }
  result.keyframes = odometry->keyframes();  // complete, whatever was applied when
  result.poses = odometry->poses();
  result.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  progress.Finish(result.frames.size(), status_text());
  return result;
}

RunEvaluation EvaluateRun(const SequenceRunResult& result) {
  return EvaluateEstimate(result, result.Estimate());
}

RunEvaluation EvaluateEstimate(const SequenceRunResult& result, const Trajectory& estimate) {
  RunEvaluation e;
  DFO_CHECK(estimate.size() == result.frames.size())
      << estimate.size() << " poses for " << result.frames.size() << " frames";
  Trajectory gt, est;
  for (size_t i = 0; i < result.frames.size(); ++i) {
    const FrameRecord& f = result.frames[i];
    if (!f.ground_truth) continue;
    gt.Add(f.tracked.timestamp_ns, *f.ground_truth);
    est.Add(f.tracked.timestamp_ns, estimate[i].world_from_cam);
  }
  if (gt.size() < 3) {
    e.note = gt.empty() ? "no ground truth for the processed frames"
                        : "only " + std::to_string(gt.size()) +
                              " processed frames have ground truth, at least 3 are needed";
    return e;
  }
  // Lost frames keep the last good pose and restarts begin anew: with fewer than 2 tracked
  // frames there is no estimated motion to evaluate, only poses carried over.
  const int tracked =
      result.CountStatus(TrackingStatus::kOk) + result.CountStatus(TrackingStatus::kDegraded);
  if (tracked < 2) {
    e.note = "only " + std::to_string(tracked) + " of " + std::to_string(result.frames.size()) +
             " frames were tracked (the others lost or restarts): no estimated motion";
    return e;
  }
  try {
    TrajectoryEvaluationOptions sim3;
    sim3.alignment = AlignmentType::kSim3;  // monocular: the scale is arbitrary (evo_ape -as)
    e.sim3 = EvaluateTrajectory(gt, est, sim3);
    // What the alignment rests on: every processed frame is an estimated pose; those with ground
    // truth are evaluated, and of those the tracked ones carry a motion (EvaluationWarnings).
    e.sim3.num_est_poses = result.frames.size();
    e.sim3.num_tracked_poses = 0;
    for (const FrameRecord& f : result.frames) {
      if (f.ground_truth && f.tracked.status != TrackingStatus::kLost) ++e.sim3.num_tracked_poses;
    }
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

namespace {

// The "frontend" / "windowed" object of summary.json (or null plus a note).
void SetEvaluation(const RunEvaluation& evaluation, const std::string& key, io::JsonValue* s) {
  if (!evaluation.available) {
    s->Set(key, nullptr);
    s->Set(key + "_note", evaluation.note);
    return;
  }
  io::JsonValue out = EvaluationToJson(evaluation.sim3);
  out.Set("ate_rmse_se3", evaluation.ate_rmse_se3);
  out.Set("gt_path_length_m", evaluation.sim3.gt_path_length_m);
  const double length = evaluation.sim3.gt_path_length_m;
  out.Set("ate_rmse_pct_of_path", length > 0.0 ? 100.0 * evaluation.sim3.ate.stats.rmse / length
                                               : std::numeric_limits<double>::quiet_NaN());
  s->Set(key, std::move(out));
}

io::JsonValue KeyframesToJson(const SequenceRunResult& result) {
  io::JsonValue k = io::JsonValue::Object();
  k.Set("count", static_cast<int64_t>(result.keyframes.size()));
  std::map<std::string, int> reasons;
  int ba_runs = 0, optimized = 0, converged = 0, time_limited = 0, marginalized = 0, dropped = 0,
      max_keyframes = 0, max_points = 0, max_blocks = 0;
  std::vector<double> iterations, last_steps;
  io::JsonValue failures = io::JsonValue::Array();
  for (const KeyframeRecord& r : result.keyframes) {
    ++reasons[r.reason == KeyframeReason::kNone ? "frontend" : KeyframeReasonName(r.reason)];
    // A solve needs two keyframes; the first keyframe of a run only enters the window.
    if (!r.ba_ran || r.window.keyframe_poses.size() < 2) continue;
    ++ba_runs;
    optimized += r.window.optimized ? 1 : 0;
    converged += r.window.converged ? 1 : 0;
    time_limited += r.window.optimized && r.window.time_limited ? 1 : 0;
    iterations.push_back(r.window.num_iterations);
    last_steps.push_back(r.window.last_step_px);
    const bool left = r.window.marginalized_frame_index >= 0;
    marginalized += left && r.window.marginalized_into_prior ? 1 : 0;
    dropped += left && !r.window.marginalized_into_prior ? 1 : 0;
    max_keyframes = std::max(max_keyframes, static_cast<int>(r.window.keyframe_poses.size()));
    max_points = std::max(max_points, r.window.num_points);
    max_blocks = std::max(max_blocks, r.window.num_residual_blocks);
    if (!r.window.optimized && failures.size() < 20) {
      io::JsonValue f = io::JsonValue::Object();
      f.Set("frame", r.frame_index);
      f.Set("message", r.window.message);
      failures.Push(std::move(f));
    }
  }
  io::JsonValue reason_counts = io::JsonValue::Object();
  for (const auto& [name, count] : reasons) reason_counts.Set(name, count);
  k.Set("reasons", std::move(reason_counts));
  k.Set("ba_runs", ba_runs);
  k.Set("ba_optimized", optimized);
  k.Set("ba_failed", ba_runs - optimized);
  k.Set("ba_converged", converged);
  k.Set("ba_time_limited", time_limited);
  const auto median = [](std::vector<double> values) {
    if (values.empty()) return 0.0;
    const auto middle = values.begin() + values.size() / 2;
    std::nth_element(values.begin(), middle, values.end());
    return *middle;
  };
  k.Set("ba_iterations_median", median(iterations));
  k.Set("ba_last_step_px_median", median(last_steps));
  k.Set("marginalized", marginalized);
  k.Set("dropped", dropped);
  k.Set("max_window_keyframes", max_keyframes);
  k.Set("max_points", max_points);
  k.Set("max_residual_blocks", max_blocks);
  k.Set("depth_edge_warnings", result.depth_edge_warnings);
  k.Set("failures", std::move(failures));
  return k;
}

// The "tracking_depth" object: what the frames were tracked against.
io::JsonValue TrackingDepthToJson(const SequenceRunResult& result) {
  io::JsonValue t = io::JsonValue::Object();
  const bool window = result.has_windowed() && result.tracking.depth == "window";
  t.Set("depth", window ? "window" : "source");
  if (window) t.Set("fill", result.tracking.fill);
  std::map<std::string, int> frames, keyframes;
  for (const FrameRecord& f : result.frames) {
    if (!f.tracking_depth.empty()) ++frames[f.tracking_depth];
  }
  std::vector<double> points, covered, scales, stereo;
  io::JsonValue fallbacks = io::JsonValue::Array();
  for (const KeyframeRecord& k : result.keyframes) {
    ++keyframes[k.tracking_depth];
    if (!k.ba_ran) continue;
    if (k.window_scale > 0.0) scales.push_back(k.window_scale);
    if (k.stereo.num_views > 0) stereo.push_back(k.stereo.fraction);
    if (k.tracking_depth == "window") {
      points.push_back(k.tracking_window_points);
      covered.push_back(k.tracking_covered);
    } else if (window && fallbacks.size() < 20) {
      io::JsonValue f = io::JsonValue::Object();
      f.Set("frame", k.frame_index);
      f.Set("depth", k.tracking_depth);
      f.Set("message", k.tracking_depth_note);
      fallbacks.Push(std::move(f));
    }
  }
  io::JsonValue frame_counts = io::JsonValue::Object();
  for (const auto& [name, count] : frames) frame_counts.Set(name, count);
  t.Set("frames", std::move(frame_counts));
  io::JsonValue keyframe_counts = io::JsonValue::Object();
  for (const auto& [name, count] : keyframes) keyframe_counts.Set(name, count);
  t.Set("keyframes", std::move(keyframe_counts));
  const auto median = [](std::vector<double> v) -> io::JsonValue {
    if (v.empty()) return io::JsonValue(nullptr);
    return io::JsonValue(Percentile(v, 50));
  };
  t.Set("median_window_points", median(points));
  t.Set("median_covered_fraction", median(covered));
  t.Set("median_window_scale", median(scales));
  t.Set("median_stereo_fraction", median(stereo));
  if (window) t.Set("fallbacks", std::move(fallbacks));
  return t;
}

}  // namespace

io::JsonValue MakeRunSummary(const SequenceRunResult& result, const RunEvaluation& evaluation,
                             const RunEvaluation* windowed) {
  io::JsonValue s = io::JsonValue::Object();
  s.Set("sequence", result.sequence_name);
  s.Set("mode", RunModeName(result.mode));
  s.Set("frames", static_cast<int64_t>(result.frames.size()));
  s.Set("frames_in_sequence", static_cast<int64_t>(result.frames_in_sequence));
  io::JsonValue input_warnings = io::JsonValue::Array();
  for (const std::string& w : result.input_warnings) input_warnings.Push(w);
  s.Set("input_warnings", std::move(input_warnings));
  s.Set("frames_ok", result.CountStatus(TrackingStatus::kOk));
  s.Set("frames_degraded", result.CountStatus(TrackingStatus::kDegraded));
  s.Set("frames_lost", result.CountStatus(TrackingStatus::kLost));
  s.Set("frames_reference", result.CountStatus(TrackingStatus::kReference));
  io::JsonValue causes = io::JsonValue::Object();
  for (const LostCause cause : {LostCause::kTracking, LostCause::kNoDepth, LostCause::kFewPoints}) {
    int64_t n = 0;
    for (const FrameRecord& f : result.frames) n += f.tracked.lost_cause == cause ? 1 : 0;
    causes.Set(LostCauseName(cause), n);
  }
  s.Set("frames_lost_by_cause", causes);
  int references = 0;
  for (const FrameRecord& f : result.frames) references += f.tracked.is_new_reference ? 1 : 0;
  s.Set("references", references);

  if (result.has_frontend()) SetEvaluation(evaluation, "frontend", &s);
  if (result.has_windowed()) {
    SetEvaluation(
        windowed != nullptr ? *windowed : EvaluateEstimate(result, result.WindowedEstimate()),
        "windowed", &s);
  }
  s.Set("keyframes", KeyframesToJson(result));
  s.Set("tracking_depth", TrackingDepthToJson(result));

  std::vector<double> load, features, depth, tracking, total;
  for (const FrameRecord& f : result.frames) {
    load.push_back(f.load_ms);
    features.push_back(f.features_ms);
    depth.push_back(f.depth_ms);
    tracking.push_back(f.tracking_ms);
    total.push_back(f.total_ms);
  }
  std::vector<double> backend, solve, marginalization, stereo;
  for (const KeyframeRecord& k : result.keyframes) {
    if (!k.ba_ran) continue;
    backend.push_back(k.backend_ms);
    solve.push_back(k.window.solve_ms);
    if (k.stereo.num_views >= 2) stereo.push_back(k.stereo.milliseconds);
    marginalization.push_back(k.window.marginalization_ms);
  }
  io::JsonValue timing = io::JsonValue::Object();
  timing.Set("load", TimingToJson(SummariseTimes(load)));
  timing.Set("features", TimingToJson(SummariseTimes(features)));
  timing.Set("depth", TimingToJson(SummariseTimes(depth)));
  timing.Set("tracking", TimingToJson(SummariseTimes(tracking)));
  timing.Set("total_per_frame", TimingToJson(SummariseTimes(total)));
  timing.Set("backend_per_keyframe", TimingToJson(SummariseTimes(backend)));
  timing.Set("ba_solve_per_keyframe", TimingToJson(SummariseTimes(solve)));
  if (!stereo.empty()) {
    timing.Set("keyframe_stereo_per_keyframe", TimingToJson(SummariseTimes(stereo)));
  }
  timing.Set("marginalization_per_keyframe", TimingToJson(SummariseTimes(marginalization)));
  s.Set("timing_ms", std::move(timing));
  s.Set("fps", result.wall_s > 0.0 ? static_cast<double>(result.frames.size()) / result.wall_s
                                   : std::numeric_limits<double>::quiet_NaN());
  s.Set("wall_s", result.wall_s);
  s.Set("peak_rss_mb", PeakRssMb());
  if (std::isfinite(result.memory_estimate_mib)) {
    s.Set("memory_estimate_mb", result.memory_estimate_mib);
  }
  const std::string wait_policy = OpenMpWaitPolicyAtStart();
  if (wait_policy.empty()) {
    s.Set("openmp_wait_policy", io::JsonValue());
  } else {
    s.Set("openmp_wait_policy", wait_policy);
  }
  if (!result.error.empty()) s.Set("error", result.error);
  if (result.interrupted_signal != 0) {
    io::JsonValue interrupted = io::JsonValue::Object();
    interrupted.Set("signal", SignalName(result.interrupted_signal));
    interrupted.Set("frame", static_cast<int64_t>(result.frames.size()));
    interrupted.Set("signals", static_cast<int64_t>(std::max(result.stop_signals, 1)));
    interrupted.Set("plots_skipped", result.stop_signals > 1);
    s.Set("interrupted", std::move(interrupted));
  }
  return s;
}

std::vector<std::string> RemoveRunOutputs(const std::string& output_dir) {
  std::vector<std::string> removed;
  for (const char* name :
       {"frontend_kitti.txt", "frontend_tum.txt", "windowed_kitti.txt", "windowed_tum.txt",
        "keyframes_tum.txt", "frames.csv", "summary.json", "frontend_trajectory.png",
        "windowed_trajectory.png", "comparison_trajectory.png", "scale_along_the_run.png"}) {
    for (const std::string& file : {std::string(name), std::string(name) + ".tmp"}) {
      std::error_code ec;
      const fs::path p = fs::path(output_dir) / file;
      if (fs::is_regular_file(p, ec) && fs::remove(p, ec)) removed.push_back(file);
    }
  }
  return removed;
}

std::string FramesCsvHeader() {
  return "index,timestamp_s,status,reference_index,new_reference,num_points,num_inliers,rmse,"
         "iterations,keyframe,keyframe_reason,load_ms,features_ms,depth_ms,tracking_ms,backend_ms,"
         "total_ms,tracking_depth,keyframe_depth_scale,lost_cause,windowed_step_scale,"
         "keyframe_stereo_fraction,keyframe_source_scale,keyframe_solve\n";
}

std::string KeyframeSolveName(const KeyframeRecord& keyframe) {
  const WindowResult& w = keyframe.window;
  if (!keyframe.ba_ran) return "";
  if (!w.optimized) return w.keyframe_poses.size() >= 2 ? "kept_previous" : "";
  if (w.converged) return "converged";
  return w.time_limited ? "time_limit" : "iteration_limit";
}

std::string FramesCsvLine(const FrameRecord& f) {
  const TrackedFrame& t = f.tracked;
  const std::string reason = !f.keyframe ? ""
                                         : (f.keyframe_reason == KeyframeReason::kNone
                                                ? "frontend"
                                                : KeyframeReasonName(f.keyframe_reason));
  return std::to_string(t.index) + "," + io::FormatNsAsSeconds(t.timestamp_ns) + "," +
         TrackingStatusName(t.status) + "," + std::to_string(t.reference_index) + "," +
         (t.is_new_reference ? "1" : "0") + "," + std::to_string(t.num_points) + "," +
         std::to_string(t.num_inliers) + "," + Csv(t.rmse, 6) + "," + std::to_string(t.iterations) +
         "," + (f.keyframe ? "1" : "0") + "," + reason + "," + Csv(f.load_ms, 3) + "," +
         Csv(f.features_ms, 3) + "," + Csv(f.depth_ms, 3) + "," + Csv(f.tracking_ms, 3) + "," +
         Csv(f.backend_ms, 3) + "," + Csv(f.total_ms, 3) + "," + f.tracking_depth + "," +
         (f.keyframe_depth_scale > 0.0 ? Csv(f.keyframe_depth_scale, 6) : std::string()) + "," +
         LostCauseName(t.lost_cause) + "," +
         (f.windowed_step_scale > 0.0 ? Csv(f.windowed_step_scale, 6) : std::string()) + "," +
         (f.keyframe_stereo_fraction >= 0.0 ? Csv(f.keyframe_stereo_fraction, 4) : std::string()) +
         "," + (f.keyframe_source_scale > 0.0 ? Csv(f.keyframe_source_scale, 6) : std::string()) +
         "," + f.keyframe_solve + "\n";
}

void WriteFramesCsv(const std::string& path, const SequenceRunResult& result) {
  std::string text = FramesCsvHeader();
  for (const FrameRecord& f : result.frames) text += FramesCsvLine(f);
  WriteTextFile(path, text);
}

LiveRunFiles::LiveRunFiles(const std::string& output_dir, bool frontend, double sync_interval_s)
    : sync_interval_s_(sync_interval_s), last_sync_(std::chrono::steady_clock::now()) {
  const auto open = [&](File* f, const char* name, const std::string& header) {
    f->path = (fs::path(output_dir) / name).string();
    f->file = std::fopen(f->path.c_str(), "wb");
    if (f->file == nullptr) {
      problems_.push_back(f->path + ": cannot write it as the run goes (" + std::strerror(errno) +
                          ")");
      return;
    }
    Write(f, header);
  };
  open(&frames_csv_, "frames.csv", FramesCsvHeader());
  if (frontend) {
    open(&kitti_, "frontend_kitti.txt", "");
    open(&tum_, "frontend_tum.txt", io::kTumTrajectoryHeader);
  }
}

LiveRunFiles::~LiveRunFiles() {
  for (File* f : {&frames_csv_, &kitti_, &tum_}) {
    if (f->file != nullptr) std::fclose(f->file);
  }
}

void LiveRunFiles::Write(File* f, const std::string& text) {
  if (f->file == nullptr) return;
  if (std::fwrite(text.data(), 1, text.size(), f->file) != text.size() ||
      std::fflush(f->file) != 0) {
    // This file is given up for the rest of the run; the run goes on.
    problems_.push_back(f->path + ": writing it as the run goes failed (" + std::strerror(errno) +
                        ")");
    std::fclose(f->file);
    f->file = nullptr;
  }
}

void LiveRunFiles::Append(const FrameRecord& frame, const SE3d& frontend_world_from_cam) {
  Write(&frames_csv_, FramesCsvLine(frame));
  Write(&kitti_, io::KittiTrajectoryLine(frontend_world_from_cam));
  Write(&tum_, io::TumTrajectoryLine(frame.tracked.timestamp_ns, frontend_world_from_cam));
  const auto now = std::chrono::steady_clock::now();
  if (std::chrono::duration<double>(now - last_sync_).count() >= sync_interval_s_) {
    last_sync_ = now;
    for (File* f : {&frames_csv_, &kitti_, &tum_}) {
      if (f->file != nullptr) fsync(fileno(f->file));
    }
  }
}

RunOutputs WriteRunOutputs(const SequenceRunResult& result, const std::string& output_dir,
                           bool plot) {
  RunOutputs out;
  io::CreateFolder(output_dir, "output folder");
  const auto path = [&](const char* name) { return (fs::path(output_dir) / name).string(); };
  // Each file on its own: one that cannot be written is reported, the others are still written.
  const auto write = [&](const std::string& file, const std::function<void()>& body) {
    try {
      body();
      out.files.push_back(file);
    } catch (const std::exception& e) {
      out.incomplete.push_back(file + ": " + e.what());
    }
  };

  // Every processed frame gets a pose line, lost ones included (their pose is the last good one):
  // users ask for the poses of every frame, and the gap stays visible in frames.csv.
  const Trajectory estimate = result.Estimate();
  const Trajectory windowed = result.WindowedEstimate();
  if (result.has_frontend()) {
    write(path("frontend_kitti.txt"),
          [&] { io::WriteKittiTrajectory(path("frontend_kitti.txt"), estimate); });
    write(path("frontend_tum.txt"),
          [&] { io::WriteTumTrajectory(path("frontend_tum.txt"), estimate); });
  }
  if (result.has_windowed()) {
    write(path("windowed_kitti.txt"),
          [&] { io::WriteKittiTrajectory(path("windowed_kitti.txt"), windowed); });
    write(path("windowed_tum.txt"),
          [&] { io::WriteTumTrajectory(path("windowed_tum.txt"), windowed); });
  }
  if (result.poses.num_frames() == static_cast<int>(result.frames.size())) {
    write(path("keyframes_tum.txt"), [&] {
      io::WriteTumTrajectory(path("keyframes_tum.txt"),
                             result.poses.KeyframeTrajectory(result.has_windowed()));
    });
  }
  write(path("frames.csv"), [&] { WriteFramesCsv(path("frames.csv"), result); });

  const size_t lost = static_cast<size_t>(result.CountStatus(TrackingStatus::kLost));
  const std::string counts = " (" + std::to_string(result.frames.size()) + " frames, " +
                             std::to_string(lost) + " lost, " +
                             std::to_string(result.keyframes.size()) + " keyframes)";
  if (result.has_frontend()) out.evaluation = EvaluateEstimate(result, estimate);
  if (result.has_windowed()) out.windowed_evaluation = EvaluateEstimate(result, windowed);
  const auto single_plot = [&](const RunEvaluation& ev, const char* what, const char* file) {
    const TrajectoryEvaluation& e = ev.sim3;
    io::TrajectoryPlotOptions options;
    options.title = std::string("dfo_run ") + what + ": " + result.sequence_name;
    options.text_lines = EvaluationPlotLines(e);
    options.text_lines.insert(options.text_lines.begin(), counts.substr(2, counts.size() - 3));
    const std::string p = path(file);
    write(p, [&] {
      io::WriteTrajectoryPlot(p, e.ground_truth, e.alignment.aligned_estimate, e.ate.errors,
                              options);
      if (out.plot_path.empty()) out.plot_path = p;
    });
  };
  if (plot && result.has_frontend() && out.evaluation.available) {
    single_plot(out.evaluation, "frontend", "frontend_trajectory.png");
  }
  if (plot && result.has_windowed() && out.windowed_evaluation.available) {
    single_plot(out.windowed_evaluation, "windowed", "windowed_trajectory.png");
  }
  if (plot && result.has_frontend() && result.has_windowed() && out.evaluation.available &&
      out.windowed_evaluation.available) {
    // Both Sim3-aligned estimates over the ground truth.
    io::TrajectoryPlotOptions options;
    options.title = "dfo_run frontend-only vs windowed: " + result.sequence_name;
    options.text_lines = {
        counts.substr(2, counts.size() - 3),
        "frontend-only: Sim3 ATE rmse " + FormatFixed(out.evaluation.sim3.ate.stats.rmse, 4) +
            " m, RPE " + FormatFixed(out.evaluation.sim3.rpe.translation.rmse, 4) + " m",
        "windowed:      Sim3 ATE rmse " +
            FormatFixed(out.windowed_evaluation.sim3.ate.stats.rmse, 4) + " m, RPE " +
            FormatFixed(out.windowed_evaluation.sim3.rpe.translation.rmse, 4) + " m"};
    const std::string p = path("comparison_trajectory.png");
    write(p, [&] {
      io::WriteTrajectoriesPlot(
          p, out.evaluation.sim3.ground_truth,
          {{"frontend-only (Sim3-aligned)", out.evaluation.sim3.alignment.aligned_estimate},
           {"windowed (Sim3-aligned)", out.windowed_evaluation.sim3.alignment.aligned_estimate}},
          options);
      out.plot_path = p;
    });
  }
  // The scale along the run: each estimate's step length over the truth's per 20-frame stretch.
  std::vector<io::CurveSeries> scale_curves;
  const auto add_scale = [&](const RunEvaluation& ev, const char* label) {
    const ScaleDriftResult& steps = ev.sim3.step_scale;
    if (steps.ratios.empty()) return;
    io::CurveSeries c;
    c.name = std::string(label) + " (log std " + FormatFixed(steps.log_std, 3) + ")";
    for (size_t i = 0; i < steps.ratios.size(); ++i) {
      c.x.push_back(static_cast<double>(steps.first_index[i]));
      c.y.push_back(steps.ratios[i]);
    }
    scale_curves.push_back(std::move(c));
  };
  if (plot && result.has_frontend() && out.evaluation.available) {
    add_scale(out.evaluation, "frontend-only");
  }
  if (plot && result.has_windowed() && out.windowed_evaluation.available) {
    add_scale(out.windowed_evaluation, "windowed");
  }
  if (!scale_curves.empty()) {
    const std::string p = path("scale_along_the_run.png");
    write(p, [&] {
      io::CurvePlotOptions options;
      options.title = "dfo_run: " + result.sequence_name + ", scale per 20 frames (Sim3-aligned)";
      options.x_label = "first pose of the stretch";
      options.y_label = "estimated / true step length";
      io::WriteCurvePlot(p, scale_curves, options);
    });
  }
  // Without ground truth: the estimated path(s) from above, in the estimate's own frame and scale,
  // under the same file names, so that a user's own video also gives a picture.
  const bool no_frontend_truth = !result.has_frontend() || !out.evaluation.available;
  const bool no_windowed_truth = !result.has_windowed() || !out.windowed_evaluation.available;
  if (plot && no_frontend_truth && no_windowed_truth && !result.frames.empty()) {
    std::vector<io::LabelledTrajectory> paths;
    std::vector<std::string> lines = {counts.substr(2, counts.size() - 3) +
                                      ", no ground truth: the estimate's own frame and scale"};
    const auto add = [&](const char* label, const Trajectory& t) {
      paths.push_back({label, t});
      lines.push_back(std::string(label) + ": path length " + FormatFixed(t.PathLength(), 2) +
                      " (network-depth units, metres if its scale is right)");
    };
    if (result.has_frontend()) add("frontend-only", estimate);
    if (result.has_windowed()) add("windowed", windowed);
    const char* file = result.has_frontend() && result.has_windowed() ? "comparison_trajectory.png"
                       : result.has_frontend()                        ? "frontend_trajectory.png"
                                                                      : "windowed_trajectory.png";
    const std::string p = path(file);
    write(p, [&] {
      io::TrajectoryPlotOptions options;
      options.title = "dfo_run: " + result.sequence_name + ", top view";
      options.text_lines = lines;
      io::WriteTrajectoriesPlot(p, Trajectory(), paths, options);
      out.plot_path = p;
    });
  }
  out.summary = MakeRunSummary(result, out.evaluation, &out.windowed_evaluation);
  {
    io::JsonValue lengths = io::JsonValue::Object();
    if (result.has_frontend()) lengths.Set("frontend", estimate.PathLength());
    if (result.has_windowed()) lengths.Set("windowed", windowed.PathLength());
    out.summary.Set("path_length", std::move(lengths));
  }
  if (!out.incomplete.empty()) {
    io::JsonValue incomplete = io::JsonValue::Array();
    for (const std::string& what : out.incomplete) incomplete.Push(what);
    out.summary.Set("incomplete_files", std::move(incomplete));
  }
  write(path("summary.json"),
        [&] { WriteTextFile(path("summary.json"), out.summary.Dump(2) + "\n"); });
  return out;
}

}  // namespace dfo::apps
