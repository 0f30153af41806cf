// Running the frontend (and the sliding-window backend) over a whole sequence and writing what
// dfo_run promises:
//
//   io::Sequence sequence = io::OpenSequence(dataset_options);
//   SequenceFrameProvider provider(sequence);
//   Odometry odometry(frontend_options, odometry_options);
//   SequenceRunResult result = RunSequence(provider, &odometry, run_options);
//   RunOutputs outputs = WriteRunOutputs(result, "results/", /*plot=*/true);
//
// The system itself (frontend, keyframes, window, every frame's pose) is dfo::Odometry
// (dfo_backend/odometry.h); RunSequence feeds it the provider's frames, times the loading, keeps
// a record per frame and reports progress. A bundle adjustment that fails or diverges keeps the
// window's previous state; the run logs why and goes on.
//
// RunSequence never throws on bad data met during the run (an unreadable image, a depth map of
// the wrong size): it stops there and returns the frames processed so far with the error's
// message, so that the trajectory up to the failure is still written. Lost tracking is a status
// of the frame, not an error.
//
// Files written by WriteRunOutputs into the output folder:
//   frontend_kitti.txt    every processed frame's frontend-only pose (world_from_cam), KITTI format
//                         (12 numbers/line); modes frontend and both
//   frontend_tum.txt      the same with timestamps, TUM format
//   windowed_kitti.txt    every processed frame's windowed pose, KITTI format; modes windowed, both
//   windowed_tum.txt      the same, TUM format
//   keyframes_tum.txt     the keyframes' poses (windowed; frontend-only in mode frontend), TUM
//   frames.csv            per frame: index, timestamp_s, status, reference_index, new_reference,
//                         num_points, num_inliers, rmse, iterations, keyframe, keyframe_reason,
//                         load_ms, features_ms, depth_ms, tracking_ms, backend_ms, total_ms,
//                         tracking_depth (window, source or scaled_source: what the frame was
//                         tracked against; empty for frames not tracked), keyframe_depth_scale
//                         (keyframes in the window: the median ratio of the window's depth to the
//                         depth source's map seen from the keyframe; empty otherwise or unknown),
//                         lost_cause (lost frames: tracking, no_depth or few_points; LostCause),
//                         windowed_step_scale (keyframes: the factor on the windowed steps of the
//                         frames tracked against its source-based depth,
//                         window.rescale_source_steps; empty when none),
//                         keyframe_stereo_fraction (keyframes the keyframe stereo ran on,
//                         stereo.views: the share of the finest level's pixels that took the
//                         stereo depth; empty otherwise), keyframe_source_scale (keyframes
//                         with a window: the factor their depth map entered it at,
//                         window.source_scale; 1 = raw; empty otherwise)
//   summary.json          see MakeRunSummary
//   frontend_trajectory.png  top view of ground truth and Sim3-aligned estimate coloured by ATE
//                         (only when at least 3 processed frames have ground truth and plot);
//                         windowed_trajectory.png the same for the windowed estimate, and
//                         comparison_trajectory.png both over the ground truth (mode both);
//                         scale_along_the_run.png each estimate's step length over the
//                         truth's per 20-frame stretch (summary.json step_scale_ratios)
#ifndef DFO_APPS_COMMON_SEQUENCE_RUNNER_H_
#define DFO_APPS_COMMON_SEQUENCE_RUNNER_H_

#include <atomic>
#include <chrono>
#include <cstdio>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "apps/common/backend_config.h"
#include "apps/common/evaluation.h"
#include "apps/common/progress.h"
#include "dfo_backend/keyframe_manager.h"
#include "dfo_backend/odometry.h"
#include "dfo_backend/trajectory_store.h"
#include "dfo_backend/window_optimizer.h"
#include "dfo_core/frame.h"
#include "dfo_core/trajectory.h"
#include "dfo_frontend/frontend.h"
#include "dfo_io/dataset.h"
#include "dfo_io/json.h"

namespace dfo::apps {

using dfo::KeyframeRecord;  // what happened at one keyframe (dfo_backend/odometry.h)

// Where RunSequence gets its frames: a dataset on disk, or frames made in memory (tests,
// benchmarks).
class FrameProvider {
 public:
  virtual ~FrameProvider() = default;
  // Name used in messages and the summary ("KITTI 06", a folder path, ...).
  virtual std::string name() const = 0;
  // Number of frames.
  virtual size_t size() const = 0;
  // Frame i (0 <= i < size()) at the working resolution, with depth and ground truth when the
  // source has them. Throws InputError naming the frame and the file on bad data.
  virtual io::LoadedFrame Load(size_t i) const = 0;
  // What opening the source found that did not stop it (io::Sequence::warnings); none by default.
  virtual std::vector<std::string> warnings() const { return {}; }
};

// Frames of an io::Sequence (not owned; must outlive the provider).
class SequenceFrameProvider : public FrameProvider {
 public:
  explicit SequenceFrameProvider(const io::Sequence& sequence) : sequence_(sequence) {}
  std::string name() const override { return sequence_.name(); }
  size_t size() const override { return sequence_.size(); }
  io::LoadedFrame Load(size_t i) const override { return sequence_.Load(i); }
  std::vector<std::string> warnings() const override { return sequence_.warnings(); }

 private:
  const io::Sequence& sequence_;
};

struct FrameRecord;
struct SequenceRunResult;

// How RunSequence reports progress.
struct SequenceRunOptions {
  ProgressMode progress = ProgressMode::kAuto;  // see ProgressReporter
  double progress_interval_s = 5.0;             // spacing of plain progress lines, > 0
  std::FILE* progress_stream = stdout;          // not owned; nullptr = no progress
  std::string label = "dfo_run";                // first word of progress lines
  std::FILE* log_stream = stderr;  // one line per failed bundle adjustment; nullptr = silent
  // Called after each processed frame, once its keyframe handling (and bundle adjustment) is
  // done, with its record (already result.frames.back()), the result so far and the system (its
  // poses() are current), e.g. to stream poses over LCM. An exception thrown here ends the run
  // like a bad frame.
  std::function<void(const FrameRecord&, const SequenceRunResult&, const Odometry&)> frame_observer;
  // Called once after the last frame when a window solve still running on the backend thread
  // was applied then (Odometry::Flush), with its keyframe's record (already in result.keyframes).
  std::function<void(const KeyframeRecord&, const SequenceRunResult&, const Odometry&)>
      solve_observer;
  // When set (not owned), checked before each frame: a non-zero value (a signal number, e.g. set
  // by a SIGINT handler) ends the run there; SequenceRunResult::interrupted_signal records it and
  // everything computed so far is kept, as after an error.
  const std::atomic<int>* stop_signal = nullptr;
};

// One processed frame.
struct FrameRecord {
  TrackedFrame tracked;              // the frontend's result
  std::optional<SE3d> ground_truth;  // world_from_cam from the dataset, when known
  double load_ms = 0.0;              // reading and resizing image (and depth)
  double features_ms = 0.0;          // FrontendTimings::features_ms
  double depth_ms = 0.0;             // FrontendTimings::depth_ms
  double tracking_ms = 0.0;          // FrontendTimings::tracking_ms
  bool keyframe = false;             // the frame became a keyframe
  KeyframeReason keyframe_reason = KeyframeReason::kNone;
  double backend_ms = 0.0;  // window AddKeyframe time (keyframes only, else 0)
  double total_ms = 0.0;    // load + Frontend::Process + keyframe handling + backend
  // The depth the frame was tracked against (OdometryFrame::tracking_depth).
  std::string tracking_depth;
  // The keyframe whose window solve was applied while this frame was processed (-1: none;
  // OdometryFrame::solved_keyframe).
  int solved_keyframe = -1;
  // Keyframes that went to the window: the median ratio of the window's depth to the source's
  // seen from the keyframe (KeyframeRecord::window_scale); 0 otherwise or when unknown.
  double keyframe_depth_scale = 0.0;
  // Keyframes: the factor on the windowed steps of the frames tracked against the keyframe's
  // source-based depth (KeyframeRecord::step_scale); 0 otherwise or when none was set.
  double windowed_step_scale = 0.0;
  // Keyframes whose depth the keyframe stereo changed (stereo.views): the share of the finest
  // level's pixels that took the stereo depth (KeyframeRecord::stereo); -1 when it did not run.
  double keyframe_stereo_fraction = -1.0;
  // Keyframes with a window: the factor their depth map entered it at
  // (KeyframeRecord::source_scale, window.source_scale); 0 otherwise.
  double keyframe_source_scale = 0.0;
  // Keyframes whose window solve has been applied: KeyframeSolveName of their record
  // ("converged", "iteration_limit" or "kept_previous"); "" otherwise (no window, nothing to
  // solve yet, or the solve still running on the backend thread).
  std::string keyframe_solve;
  // How the pose store holds the frame before it may become a keyframe: relative to keyframe
  // pose_keyframe_index with kf_from_cam (-1: kf_from_cam is the absolute pose; a frame that
  // became a keyframe by itself, e.g. a restart, keeps -1).
  int pose_keyframe_index = -1;
  SE3d kf_from_cam;
};

// Everything a run produced.
struct SequenceRunResult {
  std::string sequence_name;
  size_t frames_in_sequence = 0;  // frames the provider offered
  // The provider's warnings (damaged video frames, frames missing from the file); summary.json
  // input_warnings.
  std::vector<std::string> input_warnings;
  // The up-front estimate of the run's peak memory (dfo_backend/memory_estimate.h); NaN = none.
  // summary.json memory_estimate_mb, beside peak_rss_mb.
  double memory_estimate_mib = std::numeric_limits<double>::quiet_NaN();
  std::vector<FrameRecord> frames;  // frames processed, in order (all of them unless error)
  std::string error;                // what stopped the run early; "" when every frame ran
  int interrupted_signal = 0;       // the SequenceRunOptions::stop_signal that ended it, or 0
  // Stop signals received in all (set by the caller): from the second on the plots are skipped.
  int stop_signals = 0;
  double wall_s = 0.0;  // wall time of the loop (loading included)
  RunMode mode = RunMode::kFrontend;
  TrajectoryStore poses;                  // every processed frame, relative to its keyframe
  std::vector<KeyframeRecord> keyframes;  // in order
  TrackingDepthOptions tracking;          // what the run tracked against (for the summary)
  // Keyframes whose window point selection left out more than 90 % of the pixels with depth as
  // depth edges (window.max_depth_edge_slope; a noisy depth map: a network's depth at 208 x 64
  // loses 38-75 %, true depth 6-32 %); the first one is logged.
  int depth_edge_warnings = 0;

  // Frontend-only poses of the processed frames (stamped), in order: the store's frontend
  // trajectory (the tracked world_from_cam when the store does not hold every frame, e.g. a
  // result assembled by hand).
  Trajectory Estimate() const;
  // Windowed poses of the processed frames, in order (the store's windowed trajectory; equal to
  // Estimate() when the store does not hold every frame).
  Trajectory WindowedEstimate() const;
  // True when the window ran (modes kWindowed, kBoth).
  bool has_windowed() const { return mode != RunMode::kFrontend; }
  // True when the frontend-only trajectory is an output (modes kFrontend, kBoth).
  bool has_frontend() const { return mode != RunMode::kWindowed; }
  // Number of processed frames with the given status.
  int CountStatus(TrackingStatus status) const;
};

// Runs `odometry` (fresh: no frame processed yet) over every frame of `provider` in order, with
// a progress line. Stops at the first error thrown while loading or processing a frame
// (dfo::Error or another std::exception) and records its message in SequenceRunResult::error;
// never throws for those.
SequenceRunResult RunSequence(const FrameProvider& provider, Odometry* odometry,
                              const SequenceRunOptions& options = {});

// Evaluation of the processed frames that have ground truth.
struct RunEvaluation {
  bool available = false;     // false: no (or too little) ground truth; see note
  std::string note;           // why the evaluation is missing, else ""
  TrajectoryEvaluation sim3;  // Sim3-aligned (monocular) figures
  double ate_rmse_se3 = 0.0;  // ATE RMSE after an SE3 alignment, metres
};

// Evaluates the estimate of the frames that have ground truth (paired by frame, format
// "frames"): Sim3 alignment for all metrics and the SE3-aligned ATE RMSE. Needs at least 3 such
// frames with a non-degenerate path; otherwise available = false with the reason in `note`.
// EvaluateRun uses the frontend-only Estimate(); EvaluateEstimate any trajectory with one pose
// per processed frame (e.g. WindowedEstimate()).
RunEvaluation EvaluateRun(const SequenceRunResult& result);
RunEvaluation EvaluateEstimate(const SequenceRunResult& result, const Trajectory& estimate);

// summary.json: {
//   "sequence", "mode" (frontend | windowed | both), "frames" (processed), "frames_in_sequence",
//   "input_warnings" (SequenceRunResult::input_warnings: damaged or missing video frames; [] when
//   none),
//   "frames_ok", "frames_degraded", "frames_lost", "frames_reference" (frames with status
//   reference), "references" (frames that became a reference),
//   "frontend": the EvaluationToJson keys (Sim3) plus "ate_rmse_se3", "gt_path_length_m" and
//               "ate_rmse_pct_of_path" (100 * Sim3 ATE RMSE / ground-truth path length); null
//               without ground truth ("frontend_note" then says why); absent in mode windowed,
//   "windowed": the same keys for the windowed trajectory ("windowed_note"); modes windowed and
//               both only,
//   "keyframes": {"count", "reasons": {reason: count} ("frontend" for the frontend's own
//               switches), "ba_runs" (keyframes with a solve: two or more in the window),
//               "ba_optimized", "ba_failed" (solves whose result was not kept),
//               "ba_converged" (steps whose solves all ended by Ceres's convergence tolerances
//               or window.stop_step_px, not at window.max_iterations), "ba_iterations_median"
//               (Levenberg-Marquardt iterations per step, both solves), "ba_last_step_px_median"
//               (image motion of each step's last accepted LM step, window.stop_step_px's
//               measure),
//               "marginalized" (keyframes whose information went into the marginalisation prior),
//               "dropped" (keyframes that left the window without: backend.marginalization false or
//               a rejected prior), "max_window_keyframes", "max_points", "max_residual_blocks",
//               "failures": [{"frame", "message"}] (at most 20)},
//   "tracking_depth": {"depth" (window | source: what keyframes are tracked against after their
//               window solve; source in mode frontend), "fill" (tracker.depth_fill, with
//               window), "frames": {depth: frames tracked against it}, "keyframes": {depth:
//               keyframes}, "median_window_points", "median_covered_fraction" (of the tracker's
//               finest points on a window point's depth), "median_window_scale" (median ratio
//               of window to source depth at new keyframes; null without samples), "fallbacks":
//               [{"frame", "depth", "message"}] (at most 20; with window)},
//   "timing_ms": {"load", "features", "depth", "tracking", "total_per_frame",
//               "backend_per_keyframe", "ba_solve_per_keyframe",
//               "marginalization_per_keyframe"}, each {"median", "p95", "mean", "max"} (null
//               without a sample),
//   "fps" (processed frames per second of wall time), "wall_s", "peak_rss_mb" (MiB),
//   "memory_estimate_mb" (MiB, SequenceRunResult::memory_estimate_mib; absent when none),
//   "error" (only when the run stopped early: the message) }
io::JsonValue MakeRunSummary(const SequenceRunResult& result, const RunEvaluation& evaluation,
                             const RunEvaluation* windowed = nullptr);

// Paths written by WriteRunOutputs, and the summary.
struct RunOutputs {
  std::vector<std::string> files;  // every file written, in order
  // Files that could not be written completely, with the reason ("<path>: <message>"); also in
  // summary.json "incomplete_files". The other files are written regardless.
  std::vector<std::string> incomplete;
  std::string plot_path;  // "" when no plot was written
  io::JsonValue summary;
  RunEvaluation evaluation;           // frontend-only (not evaluated in mode windowed)
  RunEvaluation windowed_evaluation;  // windowed (modes windowed and both)
};

// Writes the files of the header comment into `output_dir` (created), each independently: a file
// that cannot be written is listed in RunOutputs::incomplete (and summary.json
// "incomplete_files"), the others are still written. Each file is written under a temporary
// name and renamed when complete (summary.json is never half-written). Throws InputError only
// when the folder cannot be created.
RunOutputs WriteRunOutputs(const SequenceRunResult& result, const std::string& output_dir,
                           bool plot = true);

// "SIGINT", "SIGTERM", "SIGHUP", else "signal".
const char* SignalName(int signal);

// Removes the files WriteRunOutputs writes (every mode's, and their ".tmp" names) from
// `output_dir`, so that a reused folder holds no stale file of an earlier run; nothing else is
// touched. Returns the names removed.
std::vector<std::string> RemoveRunOutputs(const std::string& output_dir);

// Writes frames.csv (columns in the header comment) to `path`.
void WriteFramesCsv(const std::string& path, const SequenceRunResult& result);
// frames.csv's header line and one frame's line (each with its '\n').
std::string FramesCsvHeader();
// frames.csv's keyframe_solve for a keyframe's record: "converged" (every solve of the step ended
// by Ceres's tolerances or window.stop_step_px), "iteration_limit" (kept, but a solve stopped at
// window.max_iterations or the time limit), "kept_previous" (a solve failed or diverged and the
// window kept its state from before it: WindowResult::message says why); "" when no solve ran
// (no window, or the first keyframe alone in it).
std::string KeyframeSolveName(const KeyframeRecord& keyframe);
std::string FramesCsvLine(const FrameRecord& frame);

// The per-frame files of a run written as it goes, so that a run killed (SIGKILL, power loss)
// leaves every frame up to the last few: frames.csv and, for runs with a frontend-only output,
// frontend_kitti.txt and frontend_tum.txt (a frame's frontend pose is final when it is tracked;
// windowed poses change with later solves and are written at the end only). Lines are flushed to
// the OS after every frame and synced to the disk at most every `sync_interval_s`.
// WriteRunOutputs later replaces these files by their complete versions.
class LiveRunFiles {
 public:
  // Creates (truncates) the files in `output_dir`. Never throws: a file that cannot be created
  // or written is given up (the run goes on; WriteRunOutputs still writes it at the end) and
  // the reason is kept in problems().
  LiveRunFiles(const std::string& output_dir, bool frontend, double sync_interval_s = 2.0);
  ~LiveRunFiles();
  LiveRunFiles(const LiveRunFiles&) = delete;
  LiveRunFiles& operator=(const LiveRunFiles&) = delete;
  // Appends `frame` with its frontend pose.
  void Append(const FrameRecord& frame, const SE3d& frontend_world_from_cam);
  // "<path>: <reason>" for each file given up.
  const std::vector<std::string>& problems() const { return problems_; }

 private:
  struct File {
    std::string path;
    std::FILE* file = nullptr;
  };
  void Write(File* file, const std::string& text);
  File frames_csv_, kitti_, tum_;
  double sync_interval_s_;
  std::chrono::steady_clock::time_point last_sync_;
  std::vector<std::string> problems_;
};

// A LoadedFrame as the frontend's Frame (images moved, not copied).
Frame ToFrame(io::LoadedFrame loaded);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_SEQUENCE_RUNNER_H_
