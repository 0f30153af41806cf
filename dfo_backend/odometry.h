// dfo's whole system as one library class: the frontend (features, depth, tracking), the keyframe
// manager, the sliding-window bundle adjustment and every frame's pose, fed one frame at a time.
//
//   FrontendOptions frontend_options;   // e.g. features "handmade", depth "gt" or "learned"
//   OdometryOptions options;            // mode, keyframe rules, window, tracking depth
//   Odometry odometry(frontend_options, options);          // or with learned sources injected
//   for (const Frame& frame : frames) {
//     const OdometryFrame out = odometry.Process(frame);
//     // out.windowed_world_from_cam: the frame's pose now; out.keyframe: it became a keyframe
//   }
//   odometry.Flush();                                 // a solve still on the backend thread
//   Trajectory all = odometry.WindowedTrajectory();  // every frame, against the final keyframes
//
// Per frame: the frontend tracks the frame against the newest keyframe; the keyframe manager
// decides whether it becomes a keyframe (or, with reference.policy "internal", the frontend's own
// rule does); a keyframe goes to the window (modes windowed and both), whose optimised keyframe
// poses move every frame tracked against them (TrajectoryStore). After each window solve the
// newest keyframe is tracked against the window's optimised points (tracking.depth "window",
// dfo_backend/tracking_depth.h) instead of its own image's depth, so that what the window learns
// about depth and scale reaches the next frames at once (DSO, D3VO); a keyframe with too few
// window points, or a failed solve, keeps its source depth, brought to the window's scale when
// the window's points could tell it (OdometryFrame::tracking_depth says which). A new keyframe's
// points start at its source depth (or at the window's scale with tracking.initial_depth_scale
// "window") and are searched along their epipolar lines in the window's keyframes
// (WindowOptions::depth_search_range) before the solve.
//
// Reported poses. A keyframe's windowed pose (and with it every frame tracked against it) follows
// the window's solves while the keyframe is one of the newest window.max_keyframes keyframes, and
// is then kept; a keyframe that leaves the window earlier follows the window keyframes next to it
// (the nearest older and newer ones, by its pose relative to each when it left, interpolated by
// frame index) until it reaches that age, so that neighbours that leave at different ages do not
// tear the trajectory apart. DSO's marginalisation rule keeps a keyframe whose points the newest
// keyframe still sees; on a car moving forward, far points keep some keyframes in the window for
// over 100 frames, and the window's scale drift moves them metres away from the keyframes around
// them, which had left at the usual age. Reporting every keyframe from the solves of the same age
// keeps the trajectory free of such jumps (KITTI 03: the largest frame steps 6.2x the median step
// at the 99th percentile, 10.7x when old keyframes followed the window; docs/window.md). The window
// itself, the tracking and the poses of new keyframes use the window's current estimates.
//
// The frontend-only trajectory composes the same frame-to-keyframe poses on the frontend's own
// keyframe poses; in mode both with tracking.depth "window" those relative poses were tracked
// against the window's depths (run mode frontend runs no window and tracks against the source).
//
// Process throws InputError for bad frames exactly as Frontend::Process (nothing is booked for
// that frame; the state stays that of the previous frame); lost tracking and failed solves are
// statuses and messages, not throws. Synchronous by default, deterministic for
// window.num_threads = 1; with OdometryOptions::backend_thread the window solves on its own
// thread (deterministic as well with tracking.depth "source"). Not thread-safe: one thread calls
// Process.
// The frontend is included one way: dfo_backend uses dfo_frontend's public header, never the
// reverse.
#ifndef DFO_BACKEND_ODOMETRY_H_
#define DFO_BACKEND_ODOMETRY_H_

#include <deque>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "dfo_backend/keyframe_manager.h"
#include "dfo_backend/keyframe_stereo.h"
#include "dfo_backend/tracking_depth.h"
#include "dfo_backend/trajectory_store.h"
#include "dfo_backend/window_optimizer.h"
#include "dfo_core/frame.h"
#include "dfo_core/keyframe.h"
#include "dfo_core/trajectory.h"
#include "dfo_frontend/frontend.h"

namespace dfo {

// What the system estimates (run.mode).
enum class OdometryMode {
  kFrontend,  // no window: frame-to-keyframe tracking on the frontend's keyframe poses
  kWindowed,  // sliding-window bundle adjustment of the keyframes
  kBoth,      // the windowed estimate and, beside it, the frontend-only one
};

// "frontend", "windowed", "both".
const char* OdometryModeName(OdometryMode mode);

// Options of the system besides the frontend's.
struct OdometryOptions {
  OdometryMode mode = OdometryMode::kBoth;
  KeyframeOptions keyframe;       // the keyframe manager (frontend reference.policy "external")
  WindowOptions window;           // the sliding window (modes windowed and both)
  TrackingDepthOptions tracking;  // what the tracker aligns with (modes windowed and both)
  // A new keyframe's depth from stereo against the frames before it (modes windowed and both;
  // without a window it does nothing).
  KeyframeStereoOptions stereo;
  // run.backend_thread: window solves run on their own thread, so that a keyframe's solve does
  // not stall the frames behind it. Its results (poses, step scale, tracking depth) are applied
  // at the first Process call after it finished (OdometryFrame::solved_keyframe), and always
  // before the next keyframe enters the pose store or the window. With tracking.depth "source"
  // the frames are tracked against the keyframe's own depth whenever the solve ends, and the
  // step scale reaches the frames tracked before it was applied (TrajectoryStore's
  // rescale_added): the trajectories, keyframes and window are those of the sequential order,
  // only the live estimate of a frame (OdometryFrame::windowed_world_from_cam) depends on timing.
  // With "window" the frames until it finishes are tracked against the keyframe's source depth
  // at the window's scale, and results depend on timing (dfo_run: run.deterministic then forces
  // false).
  bool backend_thread = false;
  // For tests (fault injection): called on each keyframe's data just before the window gets it.
  std::function<void(KeyframeData*)> keyframe_filter;
  // For tests: called with the keyframe's frame index on the thread that solves (the backend
  // thread, or the caller's), just before the window's solve.
  std::function<void(int)> before_solve;

  // Throws ConfigError naming the key (the nested options' Check; the window's only when a
  // window runs).
  void Check() const;
  // The rules between these options and the tracker's (window.pyramid_level below
  // tracker.num_levels, one more level for window.coarse_iterations) when a window runs; throws
  // ConfigError naming both keys. The Odometry constructor calls it.
  void CheckAgainst(const TrackerOptions& tracker) const;
  bool has_window() const { return mode != OdometryMode::kFrontend; }
};

// What happened at one keyframe.
struct KeyframeRecord {
  int frame_index = 0;
  KeyframeReason reason = KeyframeReason::kNone;  // kNone: the frontend's own (internal) switch
  bool ba_ran = false;      // the keyframe went to the window (modes kWindowed, kBoth)
  WindowResult window;      // what WindowOptimizer::AddKeyframe returned (when ba_ran)
  double backend_ms = 0.0;  // wall time of the keyframe's backend work (window, tracking depth)
  // What the following frames are tracked against: "window", "source" or "scaled_source" (the
  // source's map at the window's scale: too few window points), and the why of a fallback.
  std::string tracking_depth = "source";
  std::string tracking_depth_note;
  int tracking_window_points = 0;  // window points inside the keyframe's image
  double tracking_covered = 0.0;   // fraction of the tracker's finest points on window depth
  // Median ratio of the window's depth to the source's over the window points seen from the
  // keyframe's starting pose (0: no window yet or too few points), the factor its points
  // started at (TrackingDepthOptions::initial_depth_scale; 1 = the source's depth), and the
  // factor its depth prior is centred at (TrackingDepthOptions::source_scale; 1 = raw).
  double window_scale = 0.0;
  double initial_depth_scale = 1.0;
  double source_scale = 1.0;
  // What the keyframe stereo (OdometryOptions::stereo) did to its depth; num_views 0 when it did
  // not run (off, no window scale yet, fewer than 2 earlier frames with a pose).
  KeyframeStereoResult stereo;
  // The factor on the steps of the frames tracked against the keyframe's source-based depth in
  // the windowed trajectory (TrackingDepthOptions::rescale_source_steps), set at the keyframe's
  // solve; 0: none (option off, no solve, too few window points, or no frame needs it).
  double step_scale = 0.0;
  // Keyframes that had left the window and whose reported poses this solve moved, with the
  // window keyframes next to them ("Reported poses" above), oldest first.
  std::vector<int> followers;
  // The window's points hosted by this keyframe as they were when it left the window (moved
  // here from window.marginalized_points of the solve it left in), or, for a keyframe still in
  // the window, as of the last Flush(); empty before either, and without a window.
  std::vector<SettledPoint> settled_points;
};

// Position in `records` of the record of keyframe `frame_index`, searched from the newest;
// -1 when there is none.
int FindKeyframeRecord(const std::vector<KeyframeRecord>& records, int frame_index);

// One processed frame.
struct OdometryFrame {
  TrackedFrame tracked;  // the frontend's result (its world_from_cam is the frontend chain)
  // The frame's estimates as of now (later window solves move frames; see the trajectories).
  SE3d frontend_world_from_cam;
  SE3d windowed_world_from_cam;  // equals the frontend one in mode kFrontend
  FrontendTimings timings;       // the frontend's stages
  bool keyframe = false;         // the frame became a keyframe
  KeyframeReason keyframe_reason = KeyframeReason::kNone;
  double backend_ms = 0.0;  // keyframe handling and window time (keyframes only, else 0)
  // The depth this frame was tracked against ("window", "source", "scaled_source"; "" for a
  // frame that was not tracked, e.g. the first).
  std::string tracking_depth;
  // The keyframe whose window solve was applied during this call (-1: none): the frame itself
  // when it became a keyframe (sequential mode), or an earlier keyframe (backend thread).
  int solved_keyframe = -1;
  // How the pose store holds the frame: relative to keyframe pose_keyframe_index with kf_from_cam
  // (-1: kf_from_cam is the absolute pose; a frame that became a keyframe by itself, e.g. a
  // restart, keeps -1).
  int pose_keyframe_index = -1;
  SE3d kf_from_cam;
  // The previous frame, made a keyframe during this call because this frame was lost against
  // the keyframe before and tracked against it (reason kRetrack; TrackedFrame::retracked_from);
  // -1: none.
  int promoted_keyframe = -1;
};

class Odometry {
 public:
  // Sources as Frontend's constructor: null ones are made by name from frontend_options. Throws
  // ConfigError on bad options, including window.pyramid_level not below tracker.num_levels.
  Odometry(const FrontendOptions& frontend_options, const OdometryOptions& options,
           std::unique_ptr<FeatureSource> features = nullptr,
           std::unique_ptr<DepthSource> depth = nullptr);
  ~Odometry();
  Odometry(const Odometry&) = delete;
  Odometry& operator=(const Odometry&) = delete;

  // Tracks the next frame, decides and handles its keyframe. See the file comment for throws
  // (with the backend thread, an error of an earlier keyframe's solve is rethrown here).
  OdometryFrame Process(const Frame& frame);
  // Waits for a solve still running on the backend thread and applies it; returns its keyframe's
  // frame index (-1: none). Then copies the points of the keyframes still in the window into
  // their records (KeyframeRecord::settled_points). Call it after the last frame, before reading
  // the results.
  int Flush();

  // Every processed frame's pose relative to its keyframe, both trajectories.
  const TrajectoryStore& poses() const { return poses_; }
  Trajectory FrontendTrajectory() const { return poses_.FrontendTrajectory(); }
  Trajectory WindowedTrajectory() const { return poses_.WindowedTrajectory(); }
  // Keyframes so far, in order.
  const std::vector<KeyframeRecord>& keyframes() const { return keyframes_; }
  const Frontend& frontend() const { return *frontend_; }
  // The window (null in mode kFrontend). Not while a solve runs on the backend thread: Flush()
  // first.
  const WindowOptimizer* window() const { return window_.get(); }
  const OdometryOptions& options() const { return options_; }
  bool has_window() const { return window_ != nullptr; }

 private:
  struct PendingSolve;
  // `tracked` becomes a keyframe. promoted: it is the previous frame (re-track), reported in
  // out->promoted_keyframe, with its keyframe data in *data; otherwise the frame of this call.
  void BecomeKeyframe(const TrackedFrame& tracked, KeyframeReason reason, OdometryFrame* out,
                      bool promoted = false, KeyframeData* data = nullptr);
  // Hands the new keyframe (keyframes_.back()) to the window: on the backend thread, or solved
  // at once; either way pending_ holds the result until ApplyPendingSolve. `given`: its keyframe
  // data (null: the frontend's last frame).
  void SubmitToWindow(const TrackedFrame& tracked, KeyframeData* given = nullptr);
  // Applies the pending solve (waiting for it when `wait`, else only when it has finished):
  // windowed poses, then the keyframe's tracking depth. Returns its frame index, -1 if none.
  int ApplyPendingSolve(bool wait);
  // ApplyPendingSolve(wait = true), noting its keyframe in out->solved_keyframe: before the pose
  // store gets a keyframe, whose windowed pose starts from the solved ones.
  void WaitForWindow(OdometryFrame* out);
  // tracker.depth "window": sets what the frames after the solved keyframe `*kf` are tracked
  // against (the window's depth from `points`, its points in the keyframe's camera, else the
  // source's at the window's scale) and records it in kf->tracking_depth and its note.
  void ChooseTrackingDepth(const PendingSolve& pending, const std::vector<Eigen::Vector3d>& points,
                           KeyframeRecord* kf);

  OdometryOptions options_;
  std::unique_ptr<Frontend> frontend_;
  KeyframeManager manager_;
  bool external_;  // the keyframe manager decides (reference.policy "external")
  std::unique_ptr<WindowOptimizer> window_;
  TrajectoryStore poses_;
  std::vector<KeyframeRecord> keyframes_;
  int last_keyframe_ = -1;
  TrackedFrame last_tracked_;  // the previous frame's result (for a re-track's keyframe)
  std::string reference_depth_ = "source";  // what the current reference is tracked against
  std::unique_ptr<PendingSolve> pending_;   // a keyframe's solve not yet applied
  // The newest frames' grey images (finest level), for the keyframe stereo; only when it is on.
  struct RecentFrame {
    int index = 0;
    bool lost = false;  // its pose is only the last good one: not a view
    ImageF grey;
  };
  std::deque<RecentFrame> recent_;
  // Every keyframe's window_scale > 0 so far (TrackingDepthOptions::source_scale "run_median").
  std::vector<double> window_scales_;
  // Keyframes that left the window while their poses are still reported: each follows the
  // window keyframes next to it (the nearest older and newer ones when it left), as the frames
  // tracked against a keyframe follow it.
  struct LeftKeyframe {
    int frame_index = 0;
    int older = -1;  // -1: none
    SE3d older_from_left;
    int newer = -1;
    SE3d newer_from_left;
  };
  std::vector<LeftKeyframe> left_;
  // The pose of `l` from its neighbours' windowed poses now: from each neighbour by the relative
  // pose when it left, interpolated on SE(3) by frame index between the two.
  SE3d FollowerPose(const LeftKeyframe& l) const;
};

}  // namespace dfo

#endif  // DFO_BACKEND_ODOMETRY_H_
