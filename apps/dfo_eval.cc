// dfo_eval: trajectory and depth evaluation from the command line.
//
//   dfo_eval traj --gt FILE --est FILE [options]   ATE, RPE, KITTI t_rel/r_rel, snippet ATE
//   dfo_eval depth --gt DIR --pred DIR [options]   AbsRel, SqRel, RMSE, RMSE log, delta < 1.25^k
//   dfo_eval stereo-depth --path ROOT --output DIR  reference depth of real frames from their
//                                                    ground-truth poses (plane-sweep stereo)
//   dfo_eval keyframe-depth --folder DIR --gt DIR   a run's keyframe depth (dfo_run
//                                                    run.write_keyframe_depth) against reference
//                                                    depth maps
//
// Figures follow evo (ATE/RPE), the KITTI devkit (t_rel, r_rel), SfMLearner (snippet ATE) and
// Monodepth2 (depth); see dfo_core/metrics.h and dfo_core/depth_metrics.h. Errors print one line
// on stderr and exit with status 1 (2 for command-line mistakes).
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <limits>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "apps/common/args.h"
#include "apps/common/evaluation.h"
#include "apps/common/keyframe_depth_export.h"
#include "apps/common/progress.h"
#include "dfo_core/alignment.h"
#include "dfo_core/depth_metrics.h"
#include "dfo_core/error.h"
#include "dfo_core/metrics.h"
#include "dfo_core/plane_sweep.h"
#include "dfo_io/dataset.h"
#include "dfo_io/depth_colour.h"
#include "dfo_io/file_writer.h"
#include "dfo_io/image_io.h"
#include "dfo_io/json.h"
#include "dfo_io/keyframe_depth_io.h"
#include "dfo_io/plot.h"
#include "dfo_io/trajectory_io.h"

namespace dfo {
namespace {

// A command-line mistake: printed with a hint to --help, exit status 2.
using apps::UsageError;

constexpr const char* kMainHelp =
    "usage: dfo_eval <command> [options]\n"
    "\n"
    "commands:\n"
    "  traj    evaluate an estimated trajectory against ground truth (ATE, RPE, KITTI, snippet)\n"
    "  depth   evaluate predicted depth maps against ground truth (AbsRel, RMSE, delta, ...)\n"
    "  stereo-depth  reference depth maps of real frames from their ground-truth poses\n"
    "  keyframe-depth  a run's keyframe depth (dfo_run run.write_keyframe_depth) against\n"
    "                  reference depth maps\n"
    "\n"
    "`dfo_eval <command> --help` lists the options of a command.\n";

constexpr const char* kTrajHelp =
    "usage: dfo_eval traj --gt FILE --est FILE [options]\n"
    "\n"
    "Aligns the estimate onto the ground truth (Umeyama) and prints ATE (evo APE, translation),\n"
    "RPE (evo RPE), KITTI t_rel / r_rel (devkit, 100..800 m segments; needs a path over 100 m)\n"
    "and 5-frame snippet ATE (SfMLearner). All metrics use the aligned estimate.\n"
    "\n"
    "options:\n"
    "  --gt FILE              ground-truth trajectory (camera-to-world)\n"
    "  --est FILE             estimated trajectory (camera-to-world)\n"
    "  --format F             kitti | tum | auto (default auto: 12 numbers per line = kitti,\n"
    "                         8 = tum). KITTI files are paired line by line (equal counts\n"
    "                         required); TUM files are associated by nearest timestamp.\n"
    "  --align A              none | se3 | sim3 (default sim3: monocular scale is arbitrary)\n"
    "  --delta N              RPE delta (default 1)\n"
    "  --delta-unit U         frames | m (default frames; m = travelled path length, as evo)\n"
    "  --all-pairs            RPE over all pairs (i, i + delta) instead of consecutive pairs\n"
    "  --max-diff SECONDS     TUM association: largest time difference (default 0.01, as evo)\n"
    "  --json                 print one JSON object on stdout instead of text\n"
    "  --plot FILE.png        write a top-view plot coloured by ATE\n"
    "  --help                 this text\n";

constexpr const char* kDepthHelp =
    "usage: dfo_eval depth --gt DIR --pred DIR [options]\n"
    "\n"
    "Pairs the 16-bit PNG depth maps of the two folders by file name (every ground-truth file\n"
    "needs a prediction of the same size) and prints the Monodepth2 / SfMLearner errors averaged\n"
    "over images. Metres = PNG value / scale; 0 = no depth.\n"
    "\n"
    "options:\n"
    "  --gt DIR               ground-truth depth PNGs\n"
    "  --pred DIR             predicted depth PNGs, same file names\n"
    "  --gt-scale S           ground-truth PNG units per metre (default 256; TUM uses 5000)\n"
    "  --pred-scale S         prediction PNG units per metre (default 256)\n"
    "  --min-depth M          ground truth counts when > M metres (default 0.001)\n"
    "  --max-depth M          ... and < M metres; predictions clamped to [min, max] (default 80)\n"
    "  --median-scaling       scale each prediction by median(gt) / median(pred) first\n"
    "  --per-image FILE       also write one CSV line per image: image, pixels, the medians of\n"
    "                         the ground truth and of the raw prediction (metres, over the\n"
    "                         valid pixels), their ratio, abs_rel, rmse_log, a1 (errors after\n"
    "                         median scaling when it is asked for); an image without valid\n"
    "                         ground truth has pixels 0 and empty fields\n"
    "  --json                 print one JSON object on stdout instead of text\n"
    "  --help                 this text\n";

constexpr const char* kKeyframeDepthHelp =
    "usage: dfo_eval keyframe-depth --folder DIR --gt DIR [options]\n"
    "\n"
    "How close the depth of a run's keyframe points (the folder of dfo_run\n"
    "--set run.write_keyframe_depth=DIR) is to reference depth maps: --gt DIR/<image name>.png\n"
    "for each keyframe's image (16-bit, metres x --gt-scale, 0 = none, any size), e.g. the\n"
    "depth_0 folder of a synthetic sequence or the output of dfo_eval stereo-depth; keyframes\n"
    "without a map are skipped. The estimates are scaled by one factor for the whole run (the\n"
    "median ratio over all points: a monocular run's scale is arbitrary, but one) and, beside\n"
    "it, by each keyframe's own median; the same for the depths the points started at (the\n"
    "depth source's map, scaled), so that the two say whether the window improved on its\n"
    "source.\n"
    "\n"
    "options:\n"
    "  --gt-scale S           reference PNG value per metre (default 256; TUM: 5000)\n"
    "  --min-depth M          reference depths above this count (default 0.001)\n"
    "  --max-depth M          reference depths below this count (default 80)\n"
    "  --json                 print one JSON object on stdout instead of text\n"
    "  --help                 this text\n";

constexpr const char* kStereoDepthHelp =
    "usage: dfo_eval stereo-depth --path ROOT --output DIR [options]\n"
    "\n"
    "Depth maps of a sequence's frames from its ground-truth poses, for depth metrics on real\n"
    "video that has poses but no depth (KITTI odometry): each reference frame is matched against\n"
    "its neighbours by plane-sweep stereo (ZNCC over a window, inverse depths between --min-depth\n"
    "and --max-depth) at the images' native size (or --size), and only confident pixels keep a\n"
    "depth (dfo_core/plane_sweep.h). Writes DIR/<image name>.png (16-bit, metres x 256, 0 =\n"
    "none; the format of dfo_train --write-depth, so `dfo_eval depth --gt DIR --pred PRED`\n"
    "compares them) and DIR/pictures/<image name>.png (the frame above its depth, log colours\n"
    "2-150 m).\n"
    "\n"
    "options:\n"
    "  --path ROOT            dataset root (as dataset.path)\n"
    "  --type T               kitti | tum | folder (default kitti; as dataset.type)\n"
    "  --sequence NAME        KITTI sequence (default 00)\n"
    "  --camera FILE          camera.yaml of tum / folder (default: the dataset's own)\n"
    "  --frames A-B           reference frames, recording indices, inclusive (default: all)\n"
    "  --every N              every N-th frame of --frames (default 10)\n"
    "  --neighbours N         views: the frames i-N..i-1 and i+1..i+N that exist (default 3)\n"
    "  --size WxH             match (and write the maps) at this image size instead of the\n"
    "                         native one\n"
    "  --min-depth M          nearest depth tried in metres (default 2)\n"
    "  --max-depth M          farthest depth tried in metres (default 120)\n"
    "  --depths N             inverse-depth samples (default 192)\n"
    "  --window-radius R      ZNCC window half side in pixels (default 3)\n"
    "  --max-cost C           largest accepted 1 - mean ZNCC (default 0.3)\n"
    "  --uniqueness U         second minimum / best cost, at least (default 1.5)\n"
    "  --min-texture S        window grey-level standard deviation, at least (default 4)\n"
    "  --min-epipolar PX      epipolar length of the depth range in some view (default 20)\n"
    "  --threads N            worker threads (default 2; the maps do not depend on it)\n"
    "  --help                 this text\n";

// Parsed "--key value" and "--flag" options of one command (apps::ArgParser: each at most once,
// no positional arguments).
class Options {
 public:
  Options(const std::string& command, int argc, char** argv,
          const std::set<std::string>& with_value, const std::set<std::string>& flags)
      : command_(command) {
    apps::ArgParser parser;
    bool help = false;  // the commands look for --help before parsing
    parser.Flag("--help", &help, "-h");
    for (const std::string& key : with_value) {
      parser.Custom(key, [this, key](const std::string& v) { values_[key] = v; });
    }
    std::map<std::string, bool> flag_values;
    for (const std::string& key : flags) parser.Flag(key, &flag_values[key]);
    parser.Parse(argc, argv, 0);
    for (const auto& [key, on] : flag_values) {
      if (on) values_[key] = "";
    }
  }

  bool Has(const std::string& key) const { return values_.count(key) != 0; }

  std::string Get(const std::string& key, const std::string& fallback) const {
    const auto it = values_.find(key);
    return it == values_.end() ? fallback : it->second;
  }

  std::string Required(const std::string& key) const {
    if (!Has(key)) throw UsageError(key + " is required");
    return values_.at(key);
  }

  double Number(const std::string& key, double fallback) const {
    if (!Has(key)) return fallback;
    const double inf = std::numeric_limits<double>::infinity();
    return apps::ParseNumberArgument(key, values_.at(key), -inf, inf);
  }

 private:
  std::string command_;
  std::map<std::string, std::string> values_;
};

bool WantsHelp(int argc, char** argv) {
  for (int i = 0; i < argc; ++i) {
    if (std::string(argv[i]) == "--help" || std::string(argv[i]) == "-h") return true;
  }
  return false;
}

std::string Fixed(double v, int decimals = 6) { return dfo::FormatFixed(v, decimals); }

int RunTraj(int argc, char** argv) {
  if (WantsHelp(argc, argv)) {
    std::cout << kTrajHelp;
    return 0;
  }
  const Options opt(
      "traj", argc, argv,
      {"--gt", "--est", "--format", "--align", "--delta", "--delta-unit", "--max-diff", "--plot"},
      {"--json", "--all-pairs"});
  const std::string gt_path = opt.Required("--gt");
  const std::string est_path = opt.Required("--est");
  const std::string format_name = opt.Get("--format", "auto");
  io::TrajectoryFormat format;
  if (format_name == "auto") {
    format = io::DetectTrajectoryFormat(gt_path, "ground-truth trajectory");
  } else {
    try {
      format = io::ParseTrajectoryFormat(format_name);
    } catch (const InputError& e) {
      throw UsageError(std::string("--format: ") + e.what());
    }
  }
  TrajectoryAlignmentOptions align_options;
  try {
    align_options.type = ParseAlignmentType(opt.Get("--align", "sim3"));
  } catch (const InputError& e) {
    throw UsageError(std::string("--align: ") + e.what());
  }
  RpeOptions rpe_options;
  rpe_options.delta = opt.Number("--delta", 1.0);
  const std::string delta_unit = opt.Get("--delta-unit", "frames");
  if (delta_unit == "frames") {
    rpe_options.delta_unit = DeltaUnit::kFrames;
  } else if (delta_unit == "m") {
    rpe_options.delta_unit = DeltaUnit::kMeters;
  } else {
    throw UsageError("--delta-unit '" + delta_unit + "' is unknown, expected frames or m");
  }
  rpe_options.all_pairs = opt.Has("--all-pairs");
  try {
    rpe_options.Check();
  } catch (const ConfigError& e) {
    throw UsageError(std::string("--delta: ") + e.what());
  }
  const double max_diff_s = opt.Number("--max-diff", 0.01);
  if (max_diff_s < 0.0) throw UsageError("--max-diff must be >= 0 seconds");
  const bool json = opt.Has("--json");

  const Trajectory gt_raw = io::ReadTrajectory(gt_path, format);
  const Trajectory est_raw = io::ReadTrajectory(est_path, format);
  if (gt_raw.empty()) throw InputError("ground-truth trajectory " + gt_path + " has no pose");
  if (est_raw.empty()) throw InputError("estimated trajectory " + est_path + " has no pose");

  Trajectory gt, est;
  std::string pairing;
  if (format == io::TrajectoryFormat::kKitti) {
    if (gt_raw.size() != est_raw.size()) {
      throw InputError("KITTI trajectories are paired line by line but " + gt_path + " has " +
                       std::to_string(gt_raw.size()) + " poses and " + est_path + " has " +
                       std::to_string(est_raw.size()) + "; expected equal counts");
    }
    gt = gt_raw;
    est = est_raw;
    pairing = "paired by line";
  } else {
    const auto pairs = AssociateByTimestamp(gt_raw, est_raw, SecondsToNs(max_diff_s));
    if (pairs.empty()) {
      throw InputError("no matching timestamps between " + gt_path + " and " + est_path +
                       " within " + Fixed(max_diff_s, 4) + " s (--max-diff)");
    }
    ApplyAssociation(pairs, gt_raw, est_raw, &gt, &est);
    pairing = "associated by timestamp within " + Fixed(max_diff_s, 4) + " s, " +
              std::to_string(pairs.size()) + " of " +
              std::to_string(std::min(gt_raw.size(), est_raw.size())) + " possible";
  }

  dfo::TrajectoryEvaluationOptions eval_options;
  eval_options.alignment = align_options.type;
  eval_options.rpe = rpe_options;
  dfo::TrajectoryEvaluation evaluation;
  try {
    evaluation = dfo::EvaluateTrajectory(gt, est, eval_options);
  } catch (const ConfigError&) {
    throw;
  } catch (const InputError& e) {
    // Degenerate or out-of-range geometry: say which files, on one line.
    throw InputError("cannot evaluate " + est_path + " against " + gt_path + ": " + e.what());
  }
  evaluation.num_gt_poses = gt_raw.size();
  evaluation.num_est_poses = est_raw.size();
  evaluation.format = io::TrajectoryFormatName(format);
  const TrajectoryAlignment& alignment = evaluation.alignment;
  const Trajectory& aligned = alignment.aligned_estimate;
  const AteResult& ate = evaluation.ate;
  const RpeResult& rpe = evaluation.rpe;
  const KittiOdometryResult& kitti = evaluation.kitti;
  const SnippetAteResult& snippet = evaluation.snippet;

  const std::string align_name = AlignmentTypeName(align_options.type);
  if (opt.Has("--plot")) {
    io::TrajectoryPlotOptions plot;
    plot.title = "dfo_eval: " + std::filesystem::path(est_path).filename().string() + " vs " +
                 std::filesystem::path(gt_path).filename().string();
    plot.text_lines = apps::EvaluationPlotLines(evaluation);
    io::WriteTrajectoryPlot(opt.Get("--plot", ""), gt, aligned, ate.errors, plot);
  }

  for (const std::string& w : dfo::EvaluationWarnings(evaluation)) {
    std::cerr << "dfo_eval traj: warning: " << w << "\n";
  }
  if (json) {
    std::cout << apps::EvaluationToJson(evaluation).Dump() << "\n";
    return 0;
  }

  std::cout << "ground truth: " << gt_path << " (" << gt_raw.size() << " poses)\n"
            << "estimate:     " << est_path << " (" << est_raw.size() << " poses)\n"
            << "poses:        " << gt.size() << " (" << io::TrajectoryFormatName(format) << ", "
            << pairing << ")\n"
            << "alignment:    " << align_name << " (Umeyama), scale "
            << dfo::FormatScale(alignment.transform.scale) << "\n"
            << "ATE [m]       rmse " << Fixed(ate.stats.rmse) << "  mean " << Fixed(ate.stats.mean)
            << "  median " << Fixed(ate.stats.median) << "  std " << Fixed(ate.stats.std)
            << "  min " << Fixed(ate.stats.min) << "  max " << Fixed(ate.stats.max) << "\n";
  std::cout << "RPE           delta "
            << Fixed(rpe_options.delta, rpe_options.delta_unit == DeltaUnit::kFrames ? 0 : 3) << " "
            << delta_unit << (rpe_options.all_pairs ? ", all pairs" : ", consecutive pairs") << ", "
            << rpe.pairs.size() << " pairs\n";
  if (rpe.pairs.empty()) {
    std::cout << "              not computed: no pose pair at this delta\n";
  } else {
    std::cout << "  trans [m]   rmse " << Fixed(rpe.translation.rmse) << "  mean "
              << Fixed(rpe.translation.mean) << "  median " << Fixed(rpe.translation.median)
              << "  max " << Fixed(rpe.translation.max) << "\n"
              << "  rot [deg]   rmse " << Fixed(rpe.rotation_deg.rmse) << "  mean "
              << Fixed(rpe.rotation_deg.mean) << "  median " << Fixed(rpe.rotation_deg.median)
              << "  max " << Fixed(rpe.rotation_deg.max) << "\n";
  }
  if (kitti.num_segments > 0) {
    std::cout << "KITTI         t_rel " << Fixed(kitti.t_rel_pct, 4) << " %  r_rel "
              << Fixed(kitti.r_rel_deg_per_100m, 4) << " deg/100m  (" << kitti.num_segments
              << " segments of 100..800 m)\n";
  } else {
    std::cout << "KITTI         not computed: ground-truth path " << Fixed(gt.PathLength(), 1)
              << " m has no 100 m segment\n";
  }
  if (!snippet.errors.empty()) {
    std::cout << "snippet ATE   mean " << Fixed(snippet.mean) << "  std " << Fixed(snippet.std)
              << "  (" << snippet.errors.size() << " 5-frame snippets, SfMLearner)\n";
  } else {
    std::cout << "snippet ATE   not computed: fewer than 5 poses\n";
  }
  const ScaleDriftResult& drift = evaluation.scale_drift;
  if (drift.ratios.size() >= 2) {
    std::cout << "scale drift   log std " << Fixed(drift.log_std, 4) << "  min "
              << Fixed(drift.min, 3) << "  max " << Fixed(drift.max, 3) << "  ("
              << drift.ratios.size() << " stretches of " << Fixed(drift.segment_length_m, 0)
              << " m: estimated / true path length after the alignment)\n";
  } else {
    std::cout << "scale drift   not computed: fewer than two " << Fixed(drift.segment_length_m, 0)
              << " m stretches of ground-truth path\n";
  }
  const ScaleDriftResult& steps = evaluation.step_scale;
  if (steps.ratios.size() >= 2) {
    std::cout << "step scale    log std " << Fixed(steps.log_std, 4) << "  min "
              << Fixed(steps.min, 3) << "  max " << Fixed(steps.max, 3) << "  ("
              << steps.ratios.size() << " stretches of " << steps.segment_frames
              << " frames: estimated / true path length after the alignment)\n";
  }
  std::cout << "ATE split     rmse " << Fixed(evaluation.ate_split.directions_rmse)
            << " m with the true step lengths, " << Fixed(evaluation.ate_split.lengths_rmse)
            << " m with the true step directions (what the estimate's directions / step lengths "
               "alone cost)\n";
  if (opt.Has("--plot")) std::cout << "plot:         " << opt.Get("--plot", "") << "\n";
  return 0;
}

int RunDepth(int argc, char** argv) {
  if (WantsHelp(argc, argv)) {
    std::cout << kDepthHelp;
    return 0;
  }
  const Options opt(
      "depth", argc, argv,
      {"--gt", "--pred", "--gt-scale", "--pred-scale", "--min-depth", "--max-depth", "--per-image"},
      {"--json", "--median-scaling"});
  const std::string gt_dir = opt.Required("--gt");
  const std::string pred_dir = opt.Required("--pred");
  const double gt_scale = opt.Number("--gt-scale", io::kDepthFolderScale);
  const double pred_scale = opt.Number("--pred-scale", io::kDepthFolderScale);
  if (!(gt_scale > 0.0)) throw UsageError("--gt-scale must be > 0");
  if (!(pred_scale > 0.0)) throw UsageError("--pred-scale must be > 0");
  DepthMetricsOptions metrics;
  metrics.min_depth = opt.Number("--min-depth", metrics.min_depth);
  metrics.max_depth = opt.Number("--max-depth", metrics.max_depth);
  metrics.median_scaling = opt.Has("--median-scaling");
  try {
    metrics.Check();
  } catch (const ConfigError& e) {
    throw UsageError(e.what());
  }

  namespace fs = std::filesystem;
  std::error_code ec;
  for (const auto& [dir, what] :
       {std::make_pair(gt_dir, "ground-truth"), std::make_pair(pred_dir, "prediction")}) {
    if (!fs::is_directory(dir, ec))
      throw InputError(std::string(what) + " folder not found: " + dir);
  }
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(gt_dir)) {
    if (entry.is_regular_file() && entry.path().extension() == ".png") {
      names.push_back(entry.path().filename().string());
    }
  }
  std::sort(names.begin(), names.end());
  if (names.empty()) throw InputError("no .png depth map in ground-truth folder " + gt_dir);
  const std::string per_image_path = opt.Get("--per-image", "");
  if (!per_image_path.empty()) io::CheckFileWritable(per_image_path, "per-image CSV");

  std::vector<DepthErrors> per_image;
  for (const std::string& name : names) {
    const std::string gt_path = (fs::path(gt_dir) / name).string();
    const std::string pred_path = (fs::path(pred_dir) / name).string();
    if (!fs::exists(pred_path, ec)) {
      throw InputError("no prediction for ground truth " + gt_path + ": expected " + pred_path);
    }
    const ImageF gt = io::ReadDepthPng(gt_path, gt_scale);
    const ImageF pred = io::ReadDepthPng(pred_path, pred_scale);
    if (gt.width() != pred.width() || gt.height() != pred.height()) {
      throw InputError("size mismatch: ground truth " + gt_path + " is " +
                       std::to_string(gt.width()) + "x" + std::to_string(gt.height()) +
                       ", prediction " + pred_path + " is " + std::to_string(pred.width()) + "x" +
                       std::to_string(pred.height()) + "; expected equal sizes");
    }
    per_image.push_back(ComputeDepthErrors(gt, pred, metrics));
  }
  const DepthErrors mean = AverageDepthErrors(per_image);
  const size_t skipped = names.size() - mean.num_images;
  if (!per_image_path.empty()) {
    std::string csv =
        "image,pixels,median_gt_m,median_pred_m,median_gt_over_pred,abs_rel,rmse_log,a1\n";
    char buf[256];
    for (size_t i = 0; i < names.size(); ++i) {
      const DepthErrors& e = per_image[i];
      if (e.num_images == 0) {
        csv += names[i] + ",0,,,,,,\n";
        continue;
      }
      std::snprintf(buf, sizeof(buf), ",%zu,%.4f,%.4f,", e.num_pixels, e.median_ground_truth,
                    e.median_prediction);
      csv += names[i] + buf;
      if (e.median_prediction > 0.0) {  // empty ratio for a prediction with no positive median
        std::snprintf(buf, sizeof(buf), "%.5f", e.median_ground_truth / e.median_prediction);
        csv += buf;
      }
      std::snprintf(buf, sizeof(buf), ",%.5f,%.5f,%.5f\n", e.abs_rel, e.rmse_log, e.a1);
      csv += buf;
    }
    io::WriteFileAtomically(per_image_path, csv, "per-image CSV");
  }

  if (opt.Has("--json")) {
    io::JsonValue out = io::JsonValue::Object();
    out.Set("num_images", static_cast<int64_t>(mean.num_images));
    out.Set("num_skipped", static_cast<int64_t>(skipped));
    out.Set("num_pixels", static_cast<int64_t>(mean.num_pixels));
    out.Set("median_scaling", metrics.median_scaling);
    out.Set("median_scale_mean", metrics.median_scaling ? mean.median_scale : 1.0);
    if (metrics.median_scaling) out.Set("median_scale_cv", mean.median_scale_cv);
    out.Set("abs_rel", mean.abs_rel);
    out.Set("sq_rel", mean.sq_rel);
    out.Set("rmse", mean.rmse);
    out.Set("rmse_log", mean.rmse_log);
    out.Set("a1", mean.a1);
    out.Set("a2", mean.a2);
    out.Set("a3", mean.a3);
    std::cout << out.Dump() << "\n";
    return 0;
  }
  std::cout << "images: " << mean.num_images << " evaluated";
  if (skipped > 0) std::cout << ", " << skipped << " without valid ground truth skipped";
  std::cout << " (" << mean.num_pixels << " pixels, depth in (" << metrics.min_depth << ", "
            << metrics.max_depth << ") m)\n";
  if (metrics.median_scaling) {
    std::cout << "median scaling: mean ratio " << Fixed(mean.median_scale, 4)
              << ", coefficient of variation over the images " << Fixed(mean.median_scale_cv, 4)
              << "\n";
  }
  std::cout << "   abs_rel    sq_rel      rmse  rmse_log        a1        a2        a3\n";
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%10.4f%10.4f%10.4f%10.4f%10.4f%10.4f%10.4f\n", mean.abs_rel,
                mean.sq_rel, mean.rmse, mean.rmse_log, mean.a1, mean.a2, mean.a3);
  std::cout << buf;
  return 0;
}

// "A-B" -> {A, B}; UsageError otherwise.
std::pair<int, int> ParseRange(const std::string& key, const std::string& text) {
  const size_t dash = text.find('-');
  char* end = nullptr;
  if (dash != std::string::npos && dash > 0) {
    const long a = std::strtol(text.c_str(), &end, 10);
    if (end == text.c_str() + dash) {
      const long b = std::strtol(text.c_str() + dash + 1, &end, 10);
      if (*end == '\0' && end != text.c_str() + dash + 1 && a >= 0 && b >= a) {
        return {static_cast<int>(a), static_cast<int>(b)};
      }
    }
  }
  throw UsageError("option " + key + " = '" + text + "' is not a range A-B with 0 <= A <= B");
}

int RunKeyframeDepth(int argc, char** argv) {
  if (WantsHelp(argc, argv)) {
    std::cout << kKeyframeDepthHelp;
    return 0;
  }
  const Options opt("keyframe-depth", argc, argv,
                    {"--folder", "--gt", "--gt-scale", "--min-depth", "--max-depth"}, {"--json"});
  const std::string folder_dir = opt.Required("--folder");
  const std::string gt_dir = opt.Required("--gt");
  const double gt_scale = opt.Number("--gt-scale", io::kDepthFolderScale);
  const double min_depth = opt.Number("--min-depth", 1e-3);
  const double max_depth = opt.Number("--max-depth", 80.0);
  if (!(gt_scale > 0.0)) throw UsageError("--gt-scale must be > 0");
  if (!(min_depth > 0.0) || !(max_depth > min_depth)) {
    throw UsageError("--min-depth must be > 0 and below --max-depth");
  }
  std::error_code ec;
  if (!std::filesystem::is_directory(gt_dir, ec)) {
    throw InputError("reference depth folder not found: " + gt_dir);
  }
  const io::KeyframeDepthFolder folder = io::ReadKeyframeDepthFolder(folder_dir);
  const apps::KeyframeDepthCheck c =
      apps::CheckKeyframeDepth(folder, gt_dir, gt_scale, min_depth, max_depth);
  if (opt.Has("--json")) {
    io::JsonValue out = io::JsonValue::Object();
    out.Set("keyframes", static_cast<int64_t>(c.keyframes));
    out.Set("keyframes_without_reference", static_cast<int64_t>(c.keyframes_without_reference));
    out.Set("points", static_cast<int64_t>(c.points));
    out.Set("run_scale", c.run_scale);
    out.Set("abs_rel_run_scale", c.abs_rel_run_scale);
    out.Set("abs_rel_keyframe_scale", c.abs_rel_keyframe_scale);
    out.Set("a1_run_scale", c.a1_run_scale);
    out.Set("keyframe_scale_cv", c.keyframe_scale_cv);
    out.Set("start_abs_rel_run_scale", c.start_abs_rel_run_scale);
    out.Set("start_abs_rel_keyframe_scale", c.start_abs_rel_keyframe_scale);
    io::JsonValue bins = io::JsonValue::Array();
    const char* names[3] = {"1", "2-3", "4+"};
    for (int b = 0; b < 3; ++b) {
      io::JsonValue bin = io::JsonValue::Object();
      bin.Set("observations", names[b]);
      bin.Set("points", static_cast<int64_t>(c.points_by_observations[b]));
      bin.Set("abs_rel_run_scale", c.abs_rel_by_observations[b]);
      bin.Set("start_abs_rel_run_scale", c.start_abs_rel_by_observations[b]);
      bin.Set("median_log_ratio", c.median_log_ratio_by_observations[b]);
      bins.Push(std::move(bin));
    }
    out.Set("by_observations", std::move(bins));
    std::cout << out.Dump() << "\n";
    return 0;
  }
  std::cout << "keyframes: " << c.keyframes << " with a reference map ("
            << c.keyframes_without_reference << " without), " << c.points << " points\n"
            << "abs_rel, one scale for the run (x" << Fixed(c.run_scale, 4)
            << "): " << Fixed(c.abs_rel_run_scale, 4) << " (start depth "
            << Fixed(c.start_abs_rel_run_scale, 4) << "), a1 " << Fixed(c.a1_run_scale, 4) << "\n"
            << "abs_rel, each keyframe's own scale: " << Fixed(c.abs_rel_keyframe_scale, 4)
            << " (start depth " << Fixed(c.start_abs_rel_keyframe_scale, 4)
            << "); keyframe scale cv " << Fixed(c.keyframe_scale_cv, 4) << "\n"
            << "abs_rel (run scale) by observations, estimate / start depth:";
  const char* bin_names[3] = {"1", "2-3", "4+"};
  for (int b = 0; b < 3; ++b) {
    std::cout << " " << bin_names[b] << ": " << Fixed(c.abs_rel_by_observations[b], 4) << " / "
              << Fixed(c.start_abs_rel_by_observations[b], 4) << " ("
              << c.points_by_observations[b] << " points, median log(estimate / reference) "
              << Fixed(c.median_log_ratio_by_observations[b], 4) << ")" << (b < 2 ? "," : "\n");
  }
  return 0;
}

int RunStereoDepth(int argc, char** argv) {
  if (WantsHelp(argc, argv)) {
    std::cout << kStereoDepthHelp;
    return 0;
  }
  const Options opt(
      "stereo-depth", argc, argv,
      {"--path", "--type", "--sequence", "--camera", "--output", "--frames", "--every",
       "--neighbours", "--min-depth", "--max-depth", "--depths", "--window-radius", "--max-cost",
       "--uniqueness", "--min-texture", "--min-epipolar", "--threads", "--size"},
      {});
  const auto integer = [&](const std::string& key, int fallback, int min) {
    const double v = opt.Number(key, fallback);
    if (v != std::floor(v) || v < min || v > 1e6) {
      throw UsageError("option " + key + " = " + opt.Get(key, "") +
                       " must be an integer >= " + std::to_string(min));
    }
    return static_cast<int>(v);
  };
  io::DatasetOptions dataset;
  dataset.type = opt.Get("--type", "kitti");
  dataset.path = opt.Required("--path");
  dataset.sequence = opt.Get("--sequence", dataset.sequence);
  dataset.camera = opt.Get("--camera", "");
  dataset.keep_native = !opt.Has("--size");
  if (opt.Has("--size")) {
    const std::string size = opt.Get("--size", "");
    int width = 0, height = 0;
    char tail = 0;
    if (std::sscanf(size.c_str(), "%dx%d%c", &width, &height, &tail) != 2 || width < 16 ||
        height < 16) {
      throw UsageError("option --size = '" + size + "' is not WxH with both sides >= 16");
    }
    dataset.image_width = width;
    dataset.image_height = height;
  }
  const std::string output = opt.Required("--output");
  const int every = integer("--every", 10, 1);
  const int neighbours = integer("--neighbours", 3, 1);
  PlaneSweepOptions sweep;
  sweep.min_depth_m = opt.Number("--min-depth", sweep.min_depth_m);
  sweep.max_depth_m = opt.Number("--max-depth", sweep.max_depth_m);
  sweep.num_depths = integer("--depths", sweep.num_depths, 1);
  sweep.window_radius = integer("--window-radius", sweep.window_radius, 0);
  sweep.max_cost = opt.Number("--max-cost", sweep.max_cost);
  sweep.uniqueness = opt.Number("--uniqueness", sweep.uniqueness);
  sweep.min_texture = opt.Number("--min-texture", sweep.min_texture);
  sweep.min_epipolar_px = opt.Number("--min-epipolar", sweep.min_epipolar_px);
  sweep.num_threads = integer("--threads", 2, 1);
  sweep.min_views = 1;
  try {
    sweep.Check();
  } catch (const ConfigError& e) {
    throw UsageError(e.what());
  }

  const io::Sequence sequence = io::OpenSequence(dataset);
  for (const std::string& w : sequence.warnings()) std::cerr << "dfo_eval: warning: " << w << "\n";
  // The plane sweep's cost volume holds a float per pixel and depth sample.
  const double volume_mib = 4.0 * sweep.num_depths * sequence.output_width() *
                            static_cast<double>(sequence.output_height()) / (1024.0 * 1024.0);
  constexpr double kMaxVolumeMib = 2048.0;
  if (volume_mib > kMaxVolumeMib) {
    throw UsageError("the plane sweep's cost volume would take " +
                     std::to_string(static_cast<long long>(std::ceil(volume_mib))) + " MiB (" +
                     std::to_string(sweep.num_depths) + " depths (--depths) x " +
                     std::to_string(sequence.output_width()) + " x " +
                     std::to_string(sequence.output_height()) + " pixels (--size)), more than " +
                     std::to_string(static_cast<int>(kMaxVolumeMib)) +
                     " MiB: fewer depths or a smaller --size");
  }
  const int count = static_cast<int>(sequence.size());
  std::pair<int, int> range = {0, count - 1};
  if (opt.Has("--frames")) range = ParseRange("--frames", opt.Get("--frames", ""));
  if (range.first >= count) {
    throw InputError(sequence.name() + " has " + std::to_string(count) + " frames; --frames " +
                     opt.Get("--frames", "") + " starts after the last");
  }
  range.second = std::min(range.second, count - 1);
  const PinholeCamera camera = sequence.camera();
  const auto pose_of = [&](int i) {
    const std::optional<SE3d>& pose = sequence.frame(i).world_from_cam;
    if (!pose) {
      throw InputError(sequence.name() + " frame " + std::to_string(i) + " (" +
                       sequence.frame(i).image_path +
                       ") has no ground-truth pose; stereo depth needs the poses");
    }
    return *pose;
  };

  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(fs::path(output) / "pictures", ec);
  if (ec) throw InputError("cannot create " + output + "/pictures: " + ec.message());
  std::vector<int> references;
  for (int i = range.first; i <= range.second; i += every) references.push_back(i);
  apps::ProgressReporter progress(stdout, apps::ProgressMode::kAuto, references.size(), 5.0,
                                  "dfo_eval stereo-depth");
  double confident_sum = 0.0;
  std::map<int, ImageF> images;  // loaded frames still needed
  const auto image_of = [&](int i) -> const ImageF& {
    auto it = images.find(i);
    if (it == images.end()) it = images.emplace(i, sequence.LoadImage(i).Cast<float>()).first;
    return it->second;
  };
  for (size_t k = 0; k < references.size(); ++k) {
    const int i = references[k];
    const SE3d world_from_ref = pose_of(i);
    std::vector<StereoView> views;
    for (int j = std::max(0, i - neighbours); j <= std::min(count - 1, i + neighbours); ++j) {
      if (j != i) views.push_back({&image_of(j), pose_of(j).Inverse() * world_from_ref});
    }
    const PlaneSweepResult result = PlaneSweepDepth(image_of(i), camera, views, sweep);
    const std::string name = fs::path(sequence.frame(i).image_path).stem().string() + ".png";
    io::WriteDepthPng((fs::path(output) / name).string(), result.depth, io::kDepthFolderScale);
    // The picture: the frame (grey) above its depth.
    const ImageF& grey = image_of(i);
    const ImageU8 colour = io::ColourDepth(result.depth, 2.0, 150.0);
    ImageU8 picture(camera.width, 2 * camera.height, 3, 0);
    for (int y = 0; y < camera.height; ++y) {
      for (int x = 0; x < camera.width; ++x) {
        for (int c = 0; c < 3; ++c) {
          picture(x, y, c) = static_cast<uint8_t>(grey(x, y, grey.channels() == 3 ? c : 0));
          picture(x, y + camera.height, c) = colour(x, y, c);
        }
      }
    }
    io::WriteImage((fs::path(output) / "pictures" / name).string(), picture);
    confident_sum += result.confident_fraction;
    for (auto it = images.begin(); it != images.end();) {
      it = it->first < i + every - neighbours ? images.erase(it) : std::next(it);
    }
    progress.Update(k + 1, "frame " + std::to_string(i) + ": " +
                               Fixed(100.0 * result.confident_fraction, 1) + " % confident");
  }
  progress.Finish(references.size());
  std::cout << "wrote " << references.size() << " depth maps of " << sequence.name() << " ("
            << camera.width << "x" << camera.height << ", "
            << Fixed(100.0 * confident_sum / std::max<size_t>(references.size(), 1), 1)
            << " % of the pixels confident on average) to " << output << "\n";
  return 0;
}

}  // namespace
}  // namespace dfo

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "dfo_eval: error: no command given, expected traj, depth, stereo-depth or "
                 "keyframe-depth (see "
                 "dfo_eval --help)\n";
    return 2;
  }
  const std::string command = argv[1];
  if (command == "--help" || command == "-h" || command == "help") {
    std::cout << dfo::kMainHelp;
    return 0;
  }
  try {
    if (command == "traj") return dfo::RunTraj(argc - 2, argv + 2);
    if (command == "depth") return dfo::RunDepth(argc - 2, argv + 2);
    if (command == "stereo-depth") return dfo::RunStereoDepth(argc - 2, argv + 2);
    if (command == "keyframe-depth") return dfo::RunKeyframeDepth(argc - 2, argv + 2);
    std::cerr << "dfo_eval: error: unknown command '" << command
              << "', expected traj, depth, stereo-depth or keyframe-depth (see dfo_eval --help)\n";
    return 2;
  } catch (const dfo::UsageError& e) {
    std::cerr << "dfo_eval " << command << ": error: " << e.what() << " (see dfo_eval " << command
              << " --help)\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << "dfo_eval " << command << ": error: " << e.what() << "\n";
    return 1;
  }
}
