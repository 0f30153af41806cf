// Running the frontend over a whole sequence and writing what dfo_run promises:
//
//   io::Sequence sequence = io::OpenSequence(dataset_options);
//   SequenceFrameProvider provider(sequence);
//   Frontend frontend(frontend_options);
//   SequenceRunResult result = RunSequence(provider, &frontend, run_options);
//   RunOutputs outputs = WriteRunOutputs(result, "results/", /*plot=*/true);
//
// RunSequence never throws on bad data met during the run (an unreadable image, a depth map of
// the wrong size): it stops there and returns the frames processed so far with the error's
// message, so that the trajectory up to the failure is still written. Lost tracking is a status
// of the frame, not an error.
//
// Files written by WriteRunOutputs into the output folder:
//   frontend_kitti.txt    every processed frame's world_from_cam, KITTI format (12 numbers/line)
//   frontend_tum.txt      the same with timestamps, TUM format
//   frames.csv            per frame: index, timestamp_s, status, reference_index, new_reference,
//                         num_points, num_inliers, rmse, iterations, load_ms, features_ms,
//                         depth_ms, tracking_ms, total_ms
//   summary.json          see MakeRunSummary
//   frontend_trajectory.png  top view of ground truth and Sim3-aligned estimate coloured by ATE
//                         (only when at least 3 processed frames have ground truth and plot)
#ifndef DFO_APPS_COMMON_SEQUENCE_RUNNER_H_
#define DFO_APPS_COMMON_SEQUENCE_RUNNER_H_

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "apps/common/evaluation.h"
#include "apps/common/progress.h"
#include "dfo_core/frame.h"
#include "dfo_core/trajectory.h"
#include "dfo_frontend/frontend.h"
#include "dfo_io/dataset.h"
#include "dfo_io/json.h"

namespace dfo::apps {

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
};

// Frames of an io::Sequence (not owned; must outlive the provider).
class SequenceFrameProvider : public FrameProvider {
 public:
  explicit SequenceFrameProvider(const io::Sequence& sequence) : sequence_(sequence) {}
  std::string name() const override { return sequence_.name(); }
  size_t size() const override { return sequence_.size(); }
  io::LoadedFrame Load(size_t i) const override { return sequence_.Load(i); }

 private:
  const io::Sequence& sequence_;
};

// How RunSequence reports progress.
struct SequenceRunOptions {
  ProgressMode progress = ProgressMode::kAuto;  // see ProgressReporter
  double progress_interval_s = 5.0;             // spacing of plain progress lines, > 0
  std::FILE* progress_stream = stdout;          // not owned; nullptr = no progress
  std::string label = "dfo_run";                // first word of progress lines
};

// One processed frame.
struct FrameRecord {
  TrackedFrame tracked;              // the frontend's result
  std::optional<SE3d> ground_truth;  // world_from_cam from the dataset, when known
  double load_ms = 0.0;              // reading and resizing image (and depth)
  double features_ms = 0.0;          // FrontendTimings::features_ms
  double depth_ms = 0.0;             // FrontendTimings::depth_ms
  double tracking_ms = 0.0;          // FrontendTimings::tracking_ms
  double total_ms = 0.0;             // load + the whole Frontend::Process call
};

// Everything a run produced.
struct SequenceRunResult {
  std::string sequence_name;
  size_t frames_in_sequence = 0;    // frames the provider offered
  std::vector<FrameRecord> frames;  // frames processed, in order (all of them unless error)
  std::string error;                // what stopped the run early; "" when every frame ran
  double wall_s = 0.0;              // wall time of the loop (loading included)

  // Poses of the processed frames (world_from_cam, stamped), in order.
  Trajectory Estimate() const;
  // Number of processed frames with the given status.
  int CountStatus(TrackingStatus status) const;
};

// Runs `frontend` over every frame of `provider` in order, with a progress line. Stops at the
// first error thrown while loading or processing a frame (dfo::Error or another std::exception)
// and records its message in SequenceRunResult::error; never throws for those.
SequenceRunResult RunSequence(const FrameProvider& provider, Frontend* frontend,
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
RunEvaluation EvaluateRun(const SequenceRunResult& result);

// summary.json: {
//   "sequence", "frames" (processed), "frames_in_sequence", "frames_ok", "frames_degraded",
//   "frames_lost", "frames_reference" (frames with status reference), "references" (frames that
//   became a reference),
//   "frontend": the EvaluationToJson keys (Sim3) plus "ate_rmse_se3", "gt_path_length_m" and
//               "ate_rmse_pct_of_path" (100 * Sim3 ATE RMSE / ground-truth path length); null
//               without ground truth ("frontend_note" then says why),
//   "timing_ms": {"load", "features", "depth", "tracking", "total_per_frame"}, each
//               {"median", "p95", "mean", "max"},
//   "fps" (processed frames per second of wall time), "wall_s", "peak_rss_mb",
//   "error" (only when the run stopped early: the message) }
io::JsonValue MakeRunSummary(const SequenceRunResult& result, const RunEvaluation& evaluation);

// Paths written by WriteRunOutputs, and the summary.
struct RunOutputs {
  std::vector<std::string> files;  // every file written, in order
  std::string plot_path;           // "" when no plot was written
  io::JsonValue summary;
  RunEvaluation evaluation;
};

// Writes the files of the header comment into `output_dir` (created). Throws InputError when a
// file cannot be written.
RunOutputs WriteRunOutputs(const SequenceRunResult& result, const std::string& output_dir,
                           bool plot = true);

// Writes frames.csv (columns in the header comment) to `path`.
void WriteFramesCsv(const std::string& path, const SequenceRunResult& result);

// A LoadedFrame as the frontend's Frame (images moved, not copied).
Frame ToFrame(io::LoadedFrame loaded);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_SEQUENCE_RUNNER_H_
