#include "dfo_io/config_schema.h"

#include "dfo_core/device_name.h"

namespace dfo::io {
namespace {

ConfigSchema BuildSchema() {
  ConfigSchema s;

  // Defaults mirror DatasetOptions (dfo_io/dataset.h); a test checks that they agree.
  s.AddSection("dataset", "Input sequence: which recording to read and how to load its frames.");
  s.AddString("dataset.type", "kitti",
              "Dataset layout: KITTI odometry, TUM RGB-D, an image folder or a video file")
      .OneOf({"kitti", "tum", "folder", "video"});
  s.AddString("dataset.path", "",
              "Dataset root (KITTI: folder holding sequences/ and poses/; TUM: sequence folder; "
              "folder: image folder with camera.yaml; video: the video file, read with FFmpeg)");
  s.AddString("dataset.camera", "",
              "camera.yaml (intrinsics, size, lens model) of a folder, TUM sequence or video; \"\" "
              "= camera.yaml in the folder (video: beside the video file); KITTI reads calib.txt "
              "and takes none");
  s.AddString("dataset.sequence", "00", "KITTI sequence name (folder under sequences/)");
  s.AddInt("dataset.first", 0, "First frame used (index in the recording)").Min(0);
  s.AddInt("dataset.last", -1, "Last frame used, inclusive; -1 = the recording's last frame")
      .Min(-1);
  s.AddInt("dataset.step", 1,
           "Take every step-th frame from dataset.first up to dataset.last (1 = every frame)")
      .Min(1);
  s.AddInt("dataset.image_width", 416, "Width of loaded images in pixels (intrinsics rescaled)")
      .GreaterThan(0)
      .Max(8192);
  s.AddInt("dataset.image_height", 128, "Height of loaded images in pixels (intrinsics rescaled)")
      .GreaterThan(0)
      .Max(8192);
  s.AddInt("dataset.processing_width", 0,
           "Processing width in pixels: frames are loaded at this width rounded down to a "
           "multiple of 2^(tracker.num_levels - 1) and at the height that keeps their aspect "
           "ratio, rounded to the nearest multiple (replacing image_width/image_height; "
           "config_effective.yaml records the size); the depth network then runs on a copy at "
           "the model's input size and its depth is resized back (learned.depth_at_model_size); "
           "0 = off")
      .Min(0)
      .Max(8192);
  s.AddBool("dataset.keep_native", false,
            "Load images at their native size and ignore image_width/image_height");
  s.AddBool("dataset.color", false, "Load RGB images (KITTI image_2 when present) instead of gray");
  s.AddBool("dataset.depth", false,
            "Load the dataset's ground-truth depth maps with the images (TUM depth/, KITTI "
            "depth_0/), for depth metrics");
  s.AddString("dataset.depth_dir", "",
              "Folder of depth maps named after the images (<image stem>.png, 16-bit, metres x "
              "256, 0 = none; as dfo_eval stereo-depth writes them), of the images' size, used "
              "instead of the dataset's own (and by frontend.depth auto); every frame used needs "
              "one; \"\" = the dataset's own; not for video");
  s.AddDouble("dataset.tum_max_depth_diff", 0.02,
              "TUM: max time difference in seconds between an rgb and its depth image "
              "(associate.py)")
      .GreaterThan(0);
  s.AddString("dataset.tum_gt_mode", "interpolate",
              "TUM: ground truth per frame by interpolating the bracketing poses or taking the "
              "nearest")
      .OneOf({"interpolate", "nearest"});
  s.AddDouble("dataset.tum_max_gt_diff", 0.02,
              "TUM: max time difference in seconds to the nearest ground-truth pose")
      .GreaterThan(0);
  s.AddDouble("dataset.tum_max_gt_gap", 0.1,
              "TUM: max spacing in seconds of two ground-truth poses interpolated between")
      .GreaterThan(0);

  // Defaults mirror SyntheticOptions (dfo_core/synthetic/options.h).
  s.AddSection("synth", "Procedural synthetic street sequence (dfo_synth).");
  s.AddInt("synth.seed", 1, "Seed of the world, the drive and the textures").Min(0);
  s.AddInt("synth.frames", 500, "Number of frames").Min(1).Max(100000);
  s.AddInt("synth.width", 416, "Image width in pixels").Min(16).Max(4096);
  s.AddInt("synth.height", 128, "Image height in pixels").Min(16).Max(4096);
  s.AddDouble("synth.fov_deg", 80.0, "Horizontal field of view in degrees")
      .GreaterThan(10)
      .LessThan(150);

  // Defaults mirror FrontendOptions (dfo_frontend/frontend.h), TrackerOptions
  // (dfo_frontend/tracker.h), ReferenceOptions (dfo_frontend/reference_options.h) and
  // HandmadeFeatureOptions (dfo_frontend/feature_source.h); dfo_io cannot include them (no
  // dependency on the frontend), so a test in tests/apps builds FrontendOptions from the default
  // Config and compares every field with FrontendOptions{}. The structs' Check() enforces the rules
  // that do not fit a range (odd patch size, ok thresholds stricter than lost ones).
  s.AddSection("frontend", "Frontend: where features and depth come from.");
  s.AddString("frontend.features", "handmade",
              "Feature source: hand-made z-scored intensity and gradients, or the feature network "
              "of the model file learned.model")
      .OneOf({"handmade", "learned"});
  s.AddString("frontend.depth", "auto",
              "Depth source: the dataset's ground-truth depth maps (TUM depth/, KITTI-layout "
              "depth_0/), the depth network of learned.model, or auto = the maps when the dataset "
              "has them, else the network (frames then at the model's input size unless "
              "dataset.image_width/image_height differ from their defaults)")
      .OneOf({"auto", "gt", "learned"});
  s.AddString("frontend.handmade_descriptor", "intensity_gradients",
              "Hand-made channels: intensity alone (1), intensity and its x/y gradients (3), or "
              "rich = those plus a 3x3-blurred intensity and the gradient magnitude (5)")
      .OneOf({"intensity", "intensity_gradients", "rich"});
  s.AddDouble("frontend.handmade_blur_sigma_px", 1.0,
              "Gaussian blur (pixels) of each level's grey image before the hand-made channels "
              "(widens the convergence basin); "
              "0 = none")
      .Min(0)
      .Max(3);
  s.AddDouble("frontend.handmade_keyframe_blur_sigma_px", -1.0,
              "Blur (pixels) of the hand-made features keyframes hand to the window; less than "
              "the tracker's shrinks the window's zoom bias (a pixel blur is a different surface "
              "blur in views at different distances); < 0 = handmade_blur_sigma_px")
      .Max(3);
  s.AddString("frontend.depth_scale", "none",
              "Depth scale of a new reference: none (the source's maps as they are) or propagate "
              "(rescaled to agree with the old reference's points; measured worse with the "
              "default learned model, see models/README.md)")
      .OneOf({"none", "propagate"});
  s.AddBool("frontend.retrack_on_loss", true,
            "A frame lost against the reference is tracked again against the previous frame, "
            "which becomes a keyframe (reason retrack); false: the next frame restarts from the "
            "last good pose");
  s.AddDouble("frontend.retrack_residual_ratio", 2.0,
              "A frame tracked with an RMS residual above this times that of the first frame "
              "tracked against the reference is tracked again against the previous frame, and "
              "the better fit is kept (the previous frame then becomes a keyframe, reason "
              "retrack); 0 = off, otherwise >= 1")
      .Min(0);

  // Defaults mirror LearnedModelOptions (dfo_frontend/learned/learned_sources.h) except the model
  // path (required there) and the threads (run.threads there); a test in tests/apps compares them
  // (apps/learned_wiring.h). Read only when frontend.features or frontend.depth is "learned".
  s.AddSection("learned",
               "Model of the learned sources (frontend.features/depth = learned): one model, one "
               "run per frame.");
  s.AddString("learned.model", "models/default.dfo",
              "Model file: dfo's model format (dfo_train) or TorchScript following the contract "
              "in learned_sources.h; a relative path starts at the working directory");
  s.AddInt("learned.threads", 0,
           "LibTorch intra-op threads (process-wide); 0 = run.threads (0 there = all hardware "
           "threads)")
      .Min(0)
      .Max(1024);
  s.AddInt("learned.num_levels", 0,
           "Pyramid levels the model must have; 0 = whatever the file has (at least "
           "tracker.num_levels with learned features)")
      .Min(0)
      .Max(6);
  s.AddIntList("learned.channels", {},
               "Feature channels per level the model must have; [] = whatever the file has")
      .Min(1);
  s.AddDoubleList("learned.rho", {},
                  "Mask density per model level replacing the file's (fraction of pixels "
                  "selectable, in (0, 1]); [] = the file's")
      .GreaterThan(0)
      .Max(1);
  s.AddBool("learned.depth_at_model_size", false,
            "The depth network runs on the frame resized to the model's input size and its depth "
            "is resized back to the frame's (with require_input_size false: a model trained at "
            "one size gives depth to frames of another); dfo model files only");
  s.AddBool("learned.require_input_size", true,
            "Frames must have the model's input size (set dataset.image_width/height to it); "
            "false = any size whose sides are divisible by 2^(levels - 1)");
  s.AddString("learned.device", "cpu",
              "Where the networks run: cpu, cuda or cuda:N (needs a LibTorch built with CUDA; "
              "Debian's is CPU-only and refuses cuda at start-up)")
      .Matches(IsDeviceName, kDeviceNameRule);

  s.AddSection("tracker",
               "Direct feature-metric tracker: coarse-to-fine Gauss-Newton, inverse "
               "compositional, level 0 = finest.");
  s.AddInt("tracker.num_levels", 4, "Pyramid levels used (the paper: 4)").Min(1).Max(8);
  s.AddInt("tracker.patch_size", 3, "Patch side K in pixels (K x K patches), odd").Min(1).Max(7);
  s.AddInt("tracker.max_points", 600, "Most points (patch centres) selected per level")
      .Min(1)
      .Max(100000);
  s.AddInt("tracker.min_cell_px", 2, "Smallest point-selection grid cell side in pixels").Min(1);
  s.AddDouble("tracker.min_gradient", 0.05,
              "Least feature gradient norm of a selected point (z-score units per pixel)")
      .Min(0);
  s.AddDouble("tracker.max_patch_depth_ratio", 0.0,
              "Reject a point whose patch (grown by a pixel) spans depths with max / min above "
              "this (a depth edge); 0 = off, else > 1")
      .Min(0);
  s.AddIntList("tracker.max_iterations", {10, 15, 20, 30},
               "Gauss-Newton iteration limit per level, index = level (the last value repeats)")
      .Min(1)
      .Max(1000);
  s.AddDoubleList("tracker.convergence_threshold", {1e-6, 1e-5, 1e-5, 1e-5},
                  "Stop a level when the update norm falls below this, index = level (the last "
                  "value repeats)")
      .GreaterThan(0);
  s.AddBool("tracker.outlier_rule", true,
            "Drop patches whose squared residual norm exceeds 0.5 * (median + max) (the paper)");
  s.AddDouble("tracker.rotation_hypotheses_deg", 0.0,
              "Extra initial hypotheses: rotations of this many degrees about each axis; 0 = "
              "none (constant velocity, zero, half and double motion are always tried)")
      .Min(0)
      .Max(10);
  s.AddDouble("tracker.hypothesis_abandon_ratio", 1.5,
              "Abandon a hypothesis whose level RMSE exceeds this times the best (DSO: 1.5)")
      .GreaterThan(1);
  s.AddDouble("tracker.good_enough_rmse", 0.25,
              "Try no further hypotheses once one ends below this RMSE; 0 = try all")
      .Min(0);
  s.AddInt("tracker.min_inliers_ok", 100, "Status ok needs at least this many inliers").Min(0);
  s.AddDouble("tracker.min_inlier_ratio_ok", 0.5, "Status ok needs at least this inlier ratio")
      .Min(0)
      .Max(1);
  s.AddDouble("tracker.max_rmse_ok", 0.5, "Status ok needs an RMSE of at most this").GreaterThan(0);
  s.AddInt("tracker.min_inliers_lost", 30, "Status lost below this many inliers").Min(0);
  s.AddDouble("tracker.max_rmse_lost", 1.0, "Status lost above this RMSE").GreaterThan(0);
  s.AddString("tracker.depth", "window",
              "Depth the frames are tracked against after each window solve: the window's "
              "optimised points projected into the newest keyframe, pixels without one filled as "
              "tracker.depth_fill says (window), or the depth source's map of the keyframe as it "
              "is (source); run.mode frontend always uses the source")
      .OneOf({"window", "source"});
  s.AddString("tracker.depth_fill", "scaled_source",
              "With tracker.depth window, pixels no window point covers: the source's depth "
              "times the median window/source depth ratio (scaled_source), or none (only window "
              "points, as DSO)")
      .OneOf({"scaled_source", "none"});
  s.AddInt("tracker.min_window_points", 50,
           "Fewest window points inside the newest keyframe for a window depth (and for a depth "
           "scale estimate); fewer: the keyframe's source depth")
      .Min(1);
  s.AddInt("tracker.splat_radius_px", 1,
           "Half side of the square of pixels each window point gives its depth to, at every "
           "level (1: 3 x 3)")
      .Min(0)
      .Max(8);

  s.AddSection("stereo",
               "A new keyframe's depth from stereo against the frames before it, at their "
               "windowed poses (plane sweep, ZNCC): where it is confident it replaces the depth "
               "source's, for the window's new points and the tracker. Needs a window (run.mode "
               "windowed or both); docs/window.md \"Keyframe stereo\".");
  s.AddInt("stereo.views", 0,
           "How many of the frames before a new keyframe it is matched against; 0 = off")
      .Min(0)
      .Max(12);
  s.AddInt("stereo.depth_samples", 64,
           "Inverse depths tried, from 1/12 to 8 times the inverse of the source's median depth")
      .Min(8)
      .Max(1024);
  s.AddInt("stereo.window_radius", 2, "Half side of the ZNCC window in pixels").Min(1).Max(8);
  s.AddDouble("stereo.min_epipolar_px", 7.0,
              "A pixel gets a stereo depth only when its depth range spans at least this many "
              "pixels in some view")
      .Min(0);
  s.AddDouble("stereo.max_cost", 0.3, "Largest accepted 1 - mean ZNCC").GreaterThan(0).Max(2);
  s.AddDouble("stereo.uniqueness", 1.5,
              "The second local minimum of the cost must be at least this times the best")
      .Min(1);
  s.AddDouble("stereo.max_source_ratio", 0.0,
              "A stereo depth more than this factor from the source's (at the window's scale) is "
              "not taken; 0 = no limit, else > 1")
      .Min(0);

  s.AddSection("reference",
               "The frontend's own reference-switch rule (any rule that fires switches); used only "
               "when keyframe.decided_by = frontend.");
  s.AddDouble("reference.translation_ratio", 0.15,
              "Switch when |t_ref_cur| / parallax depth (1 / mean inverse depth of the tracked "
              "points) of the reference exceeds this")
      .GreaterThan(0);
  s.AddDouble("reference.rotation_deg", 10.0,
              "Switch when the rotation from the reference exceeds this many degrees")
      .GreaterThan(0);
  s.AddDouble("reference.min_inlier_ratio", 0.6,
              "Switch when the finest-level inlier ratio falls below this")
      .Min(0)
      .Max(1);
  s.AddInt("reference.max_interval", 10,
           "Switch after this many frames against one reference (1 = frame to frame)")
      .Min(1);

  // Defaults mirror KeyframeOptions (dfo_backend/keyframe_manager.h); a test in tests/apps
  // compares them (apps/common/backend_config.h).
  s.AddSection("keyframe",
               "When a tracked frame becomes a keyframe (the tracker's new reference and the "
               "window's newest keyframe); any rule that fires makes one.");
  s.AddString("keyframe.decided_by", "manager",
              "Who decides: the keyframe manager with the rules below (manager), or the "
              "frontend's own reference rule, section reference (frontend)")
      .OneOf({"manager", "frontend"});
  s.AddDouble("keyframe.translation_ratio", 0.10,
              "New keyframe when |t_kf->cur| / parallax depth (1 / mean inverse depth of the "
              "tracked points) of the keyframe exceeds this")
      .GreaterThan(0);
  s.AddDouble("keyframe.rotation_deg", 5.0,
              "New keyframe when the rotation from the keyframe exceeds this many degrees")
      .GreaterThan(0)
      .Max(180);
  s.AddDouble("keyframe.residual_ratio", 2.0,
              "New keyframe when the tracking RMSE exceeds this times the RMSE of the first frame "
              "after the keyframe (DSO: 2)")
      .Min(1);
  s.AddDouble("keyframe.min_inlier_ratio", 0.5,
              "New keyframe when the finest-level inlier ratio falls below this; 0 = off")
      .Min(0)
      .Max(1);
  s.AddInt("keyframe.min_interval", 1,
           "No keyframe fewer than this many frames after the last (except after a loss)")
      .Min(1);
  s.AddInt("keyframe.max_interval", 10,
           "New keyframe at the latest this many frames after the last; >= min_interval")
      .Min(1);

  // Defaults mirror WindowOptions (dfo_backend/window_optimizer.h); a test in tests/apps
  // compares them. Its num_threads is run.threads; run.deterministic makes it 1 and lifts
  // max_solver_time_s (apps/common/backend_config.h).
  s.AddSection("window",
               "Sliding window of keyframes with feature-metric bundle adjustment (Ceres): "
               "points, patches, loss, solver.");
  s.AddInt("window.max_keyframes", 7, "Keyframes kept in the window (DSO: 5-7)").Min(5).Max(64);
  s.AddInt("window.pyramid_level", 0,
           "Pyramid level of the feature and depth maps the BA works on (0 = finest; coarser "
           "levels measured biased: windows drift); below tracker.num_levels")
      .Min(0);
  s.AddInt("window.coarse_iterations", 0,
           "Levenberg-Marquardt iterations of a warm-up solve of the newest keyframe on "
           "pyramid_level + 1 (a wider basin for poorly tracked keyframes; measured harmful with "
           "well-tracked ones); 0 = none")
      .Min(0)
      .Max(1000);
  s.AddInt("window.patch_size", 3, "Patch side K in pixels at that level (K x K), odd")
      .Min(1)
      .Max(9);
  s.AddDouble("window.max_patch_stretch", 1.5,
              "Blocks only where the target sees the patch at a similar scale: both singular "
              "values of the warp's derivative within [1 / this, this] (features compared at "
              "different scales disagree: measured decimetres of bias with forward motion)")
      .GreaterThan(1);
  s.AddInt("window.points_per_keyframe", 150, "Points selected per keyframe").Min(1).Max(100000);
  s.AddString("window.loss", "huber", "Robust loss of each residual block")
      .OneOf({"huber", "cauchy"});
  s.AddDouble("window.loss_scale", 0.5,
              "Loss scale per feature value (z-score units): the Ceres parameter is this times "
              "sqrt(C K^2)")
      .GreaterThan(0);
  s.AddString("window.linear_solver", "sparse_schur",
              "Ceres linear solver: SPARSE_SCHUR with SuiteSparse, or DENSE_SCHUR")
      .OneOf({"sparse_schur", "dense_schur"});
  s.AddInt("window.max_iterations", 2,
           "Levenberg-Marquardt iterations per solve (up to two solves per keyframe)")
      .Min(1)
      .Max(1000);
  s.AddDouble("window.stop_step_px", 0.0,
              "A solve stops when its last step moved the keyframes by less than this in the "
              "image (RMS of fx * (rotation + translation * mean inverse depth), pixels at the "
              "window's level; DSO's rule); 0 = only Ceres's tolerances and max_iterations")
      .Min(0);
  s.AddDouble("window.max_solver_time_s", 0.1,
              "Wall-time limit of one solve in seconds (ignored with run.deterministic: true)")
      .GreaterThan(0);
  s.AddDouble("window.min_inverse_depth", 1e-3,
              "Lower bound of every point's inverse depth in 1/m (1e-3: up to 1 km)")
      .Min(0);
  s.AddDouble("window.depth_prior_weight", 0.0,
              "Weight of the prior of each inverse depth toward its keyframe's depth (relative "
              "error); 0 = off")
      .Min(0);
  s.AddDouble("window.zoom_blur_sigma_px", 0.0,
              "Blur in px the features already carry (the hand-made features' blur_sigma_px): "
              "where a block's target sees the patch zoomed by s, its features are compared "
              "blurred by a further this x sqrt(s^2 - 1) (the host's for 1 / s), so that both "
              "sides have the same blur on the surface; 0 = off")
      .Min(0)
      .Max(10);
  s.AddBool("window.zoom_scaled_gradients", false,
            "Scale the host patch's gradient channels by 1 / s where a block's target sees the "
            "patch zoomed by s, so that both sides of a block compare gradients at the same "
            "steepness on the surface (hand-made features; learned features are unchanged)");
  s.AddBool("window.patch_depth_shape", false,
            "Warp each point's patch as the surface of its keyframe's depth map (every patch pixel "
            "at the map's depth relative to the centre's) instead of as a fronto-parallel plane");
  s.AddDouble("window.depth_prior_scale_fraction", 1.0,
              "Share of the depth prior's weight on each keyframe's overall depth scale: 1 = "
              "every inverse depth toward its keyframe's depth as it is; below 1 each keyframe's "
              "prior depths share a free scale factor whose own prior keeps this fraction of the "
              "scale information (0 = the prior constrains only the shape of each keyframe's "
              "depth, the scale comes from the geometry)")
      .Min(0)
      .Max(1);
  s.AddDouble("window.pose_prior_weight", 0.0,
              "Weight of the prior of consecutive keyframes' relative pose toward the "
              "frontend's; 0 = off")
      .Min(0);
  s.AddDouble("window.outlier_gate_percentile", 0.9,
              "Outlier gate after the first solve: a block is dropped when its cost exceeds "
              "outlier_gate_factor x this quantile of the block costs of its target keyframe")
      .GreaterThan(0)
      .Max(1);
  s.AddDouble("window.outlier_gate_factor", 2.0,
              "Factor of the outlier gate (see outlier_gate_percentile); then a second solve")
      .Min(1);
  s.AddDouble("window.min_point_fraction", 0.05,
              "A keyframe with fewer than this fraction of its points left leaves the window "
              "first (DSO: 5 %)")
      .Min(0)
      .Max(1);
  s.AddDouble("window.max_depth_edge_slope", 6.0,
              "A pixel is not a window point where the depth across its 3 x 3 neighbourhood "
              "changes faster than this: (largest / smallest - 1) per radian of viewing angle (6: "
              "5 % across it at fx = 240 px, 10 % at 120 px); a depth edge mixes surfaces with "
              "different parallax. 0 = off")
      .Min(0);
  s.AddDouble("window.depth_search_range", 2.0,
              "Depth search of a new keyframe's points along their epipolar lines in the window's "
              "keyframes, over inverse depths within this factor of the start (a wrong source "
              "depth corrected by parallax before the solve); 1 = off")
      .Min(1)
      .Max(10);
  s.AddDouble("window.depth_search_uniqueness", 2.0,
              "The search finds a depth only when its best cost is this many times below every "
              "other local minimum (more than 2 px away)")
      .Min(1);
  s.AddBool("window.searched_points_only", false,
            "Points enter the window only once the depth search finds their depth, searched "
            "against every other window keyframe at each keyframe while their host stays (DSO's "
            "immature points); false: they enter at once, at the depth found or the start");
  s.AddString("window.initial_depth_scale", "source",
              "Where a new keyframe's points start: the source's depth (source; the depth search "
              "and the solve bring them to the window's scale), or that depth times the median "
              "ratio of the window's points seen from the keyframe to it (window; measured to feed "
              "the window's scale error back on real video)")
      .OneOf({"window", "source"});
  s.AddString("window.source_scale", "raw",
              "The scale at which each new keyframe's depth map enters the window (its points' "
              "start and its depth prior's centre): the depth source's own (raw), or that times "
              "the median over the run's keyframes so far of the window's depth over the "
              "source's seen from the keyframe (run_median: the source gives the shape and its "
              "change of scale from image to image, the window's scale is not pulled toward the "
              "source's), or that times the keyframe's own ratio (window: the window's scale "
              "carried by the points it shares with the keyframe, the source giving only the "
              "shape)")
      .OneOf({"raw", "run_median", "window"});
  s.AddBool("window.rescale_source_steps", true,
            "A frame tracked against its keyframe's source depth: its translation from the "
            "keyframe, in the windowed trajectory, times the window's depth over that depth "
            "(median over the window's points seen from the keyframe after its solve), so that "
            "it is in the scale of the keyframe's windowed pose");
  s.AddInt("window.min_marginalized_observations", 2,
           "Points of a leaving keyframe with at least this many residual blocks are "
           "marginalised, the rest dropped")
      .Min(1);

  s.AddSection("backend",
               "Marginalisation of a keyframe leaving the window into a prior on the kept poses "
               "(VINS-Mono's recipe, DSO's choices).");
  s.AddBool("backend.marginalization", true,
            "Marginalise into a prior (true) or only drop the leaving keyframe (false)");
  s.AddBool("backend.first_estimate_jacobians", false,
            "Keep the prior's Jacobian and linearise prior-connected poses at their first "
            "estimates");
  s.AddDouble("backend.prior_weight", 1.0,
              "Weight of the marginalisation prior in each solve, in (0, 1]")
      .GreaterThan(0)
      .Max(1);
  s.AddDouble("backend.relative_eigenvalue_floor", 1e-8,
              "Prior eigenvalues below this fraction of the largest are dropped, in (0, 1)")
      .GreaterThan(0)
      .LessThan(1);
  s.AddDouble("backend.prior_scale_memory", 0.0,
              "With a depth prior (window.depth_prior_weight > 0): the fraction of the scale "
              "information a marginalisation keeps in the prior (0 = the scale is removed with "
              "the gauge, 1 = all kept; older keyframes' scale fades by this factor per "
              "marginalisation)")
      .Min(0)
      .Max(1);

  s.AddSection("run", "Running dfo: where results go and how.");
  s.AddString("run.mode", "both",
              "What dfo_run estimates from the one frontend pass: the frontend-only trajectory, "
              "the sliding-window (bundle-adjusted) one, or both side by side")
      .OneOf({"frontend", "windowed", "both"});
  s.AddString("run.output_dir", "results",
              "Folder for trajectories, metrics and config_effective.yaml (created)");
  s.AddBool("run.deterministic", true,
            "Identical results run to run (fixed seeds, ordered reductions; the window solves "
            "with one thread and no time limit), possibly slower");
  s.AddBool("run.backend_thread", false,
            "Window solves on their own thread, so that a keyframe's solve does not stall the "
            "frames behind it. With tracker.depth: source the trajectories and every figure but "
            "the timings are those of the sequential order (only the poses streamed live "
            "differ); with "
            "tracker.depth: window they depend on timing, and run.deterministic: true keeps the "
            "sequential order instead");
  s.AddInt("run.threads", 2,
           "Worker threads of the frontend and of the window's Ceres solves (1 for Ceres with "
           "run.deterministic); 0 = all hardware threads")
      .Min(0)
      .Max(1024);
  s.AddString("run.progress", "auto",
              "Progress line: auto = redrawn in place on a terminal, plain periodic lines "
              "otherwise; none = silent")
      .OneOf({"auto", "terminal", "plain", "none"});
  s.AddDouble("run.progress_interval_s", 5.0, "Seconds between plain progress lines")
      .GreaterThan(0);
  s.AddBool("run.plot", true,
            "Write the trajectory pictures (frontend, windowed, both compared; top views coloured "
            "by ATE) when ground truth exists");
  s.AddString("run.write_keyframe_depth", "",
              "Folder for the depth each keyframe's window points settled on (with their "
              "observations and residual) and the keyframes' windowed poses and images, for "
              "training a depth network on the run's geometry (dfo_io/keyframe_depth_io.h); "
              "needs a window (run.mode windowed or both); \"\" = none");
  s.AddInt("run.memory_limit_mb", 4096,
           "Largest peak memory (MiB) a run may need: dfo_run estimates it from the frame size and "
           "the options before the first frame (dfo_backend/memory_estimate.h; summary.json "
           "memory_estimate_mb beside peak_rss_mb) and refuses a run above it; 0 = no limit")
      .Min(0);

  // Defaults mirror apps::LcmStreamOptions and io::LcmChannels (dfo_io/lcm/messages.h); a test
  // checks that they agree.
  s.AddSection("lcm", "LCM streaming of poses, keyframe updates and run status; LCM event log.");
  s.AddBool("lcm.enable", false,
            "Publish live on lcm.url while running (nobody needs to listen; dfo_run stops at "
            "start-up when the URL cannot be opened)");
  s.AddString("lcm.url", "udpm://239.255.76.67:7667?ttl=0",
              "LCM URL to publish on; the default is UDP multicast that stays on this host "
              "(ttl=0)");
  s.AddString("lcm.log_path", "",
              "LCM event log of the same messages, written by dfo_run itself (also without "
              "enable); read it with dfo_lcm_listen --log, replay it with lcm-logplayer; "
              "\"\" = none");
  s.AddString("lcm.pose_channel", "DFO_POSE",
              "Channel of dfo.pose_t: every frame's frontend-only and/or windowed pose");
  s.AddString("lcm.keyframes_channel", "DFO_KEYFRAMES",
              "Channel of dfo.keyframe_batch_t: the window keyframes' poses after each bundle "
              "adjustment");
  s.AddString("lcm.status_channel", "DFO_STATUS",
              "Channel of dfo.run_status_t: frames done, fps, keyframes, lost, after each frame");
  s.AddString("lcm.stop_channel", "DFO_STOP",
              "Channel of dfo.stop_t: published once when the run ends");
  return s;
}

}  // namespace

const ConfigSchema& DfoSchema() {
  static const ConfigSchema schema = BuildSchema();
  return schema;
}

DatasetOptions DatasetOptionsFromConfig(const Config& config) {
  DatasetOptions o;
  o.type = config.GetString("dataset.type");
  o.path = config.GetString("dataset.path");
  o.camera = config.GetString("dataset.camera");
  o.sequence = config.GetString("dataset.sequence");
  o.first = config.GetInt("dataset.first");
  o.last = config.GetInt("dataset.last");
  o.step = config.GetInt("dataset.step");
  o.image_width = config.GetInt("dataset.image_width");
  o.image_height = config.GetInt("dataset.image_height");
  o.keep_native = config.GetBool("dataset.keep_native");
  o.processing_width = config.GetInt("dataset.processing_width");
  o.color = config.GetBool("dataset.color");
  o.depth = config.GetBool("dataset.depth");
  o.depth_dir = config.GetString("dataset.depth_dir");
  o.tum_max_depth_diff = config.GetDouble("dataset.tum_max_depth_diff");
  o.tum_gt_mode = config.GetString("dataset.tum_gt_mode");
  o.tum_max_gt_diff = config.GetDouble("dataset.tum_max_gt_diff");
  o.tum_max_gt_gap = config.GetDouble("dataset.tum_max_gt_gap");
  if (!o.path.empty()) o.Check();
  return o;
}

}  // namespace dfo::io
