#include "apps/common/keyframe_depth_export.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_io/image_io.h"

namespace dfo::apps {

io::KeyframeDepthFolder KeyframeDepthOfRun(const SequenceRunResult& result,
                                           const io::Sequence& sequence) {
  if (!result.has_windowed()) {
    throw InputError("keyframe depth needs the window's points: run.mode frontend has none");
  }
  io::KeyframeDepthFolder out;
  out.sequence = sequence.name();
  const PinholeCamera camera = sequence.camera();
  out.image_width = camera.width;
  out.image_height = camera.height;
  out.fx = camera.fx;
  out.fy = camera.fy;
  out.cx = camera.cx;
  out.cy = camera.cy;
  for (const KeyframeRecord& kf : result.keyframes) {
    if (!kf.ba_ran || kf.frame_index < 0 ||
        static_cast<size_t>(kf.frame_index) >= sequence.size() ||
        !result.poses.Contains(kf.frame_index)) {
      continue;
    }
    const io::FrameInfo& info = sequence.frame(static_cast<size_t>(kf.frame_index));
    io::KeyframeDepthEntry entry;
    entry.frame = info.source_index;
    entry.timestamp_ns = info.timestamp_ns;
    entry.world_from_cam = result.poses.WindowedPose(kf.frame_index);
    entry.image = info.video_frame >= 0 ? info.image_path + "#" + std::to_string(info.video_frame)
                                        : info.image_path;
    for (const SettledPoint& p : kf.settled_points) {
      // A block that could not be evaluated leaves a non-finite residual: not a target.
      if (!std::isfinite(p.rms_residual) || !std::isfinite(p.depth_m) ||
          !std::isfinite(p.start_depth_m)) {
        continue;
      }
      entry.points.push_back(
          {p.u, p.v, p.depth_m, p.start_depth_m, p.observations, p.rms_residual});
    }
    out.keyframes.push_back(std::move(entry));
  }
  return out;
}

namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t k = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

double Mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

}  // namespace

KeyframeDepthCheck CheckKeyframeDepth(const io::KeyframeDepthFolder& folder,
                                      const std::string& reference_dir, double reference_scale,
                                      double min_depth, double max_depth) {
  namespace fs = std::filesystem;
  struct Sample {
    size_t keyframe;
    double reference, estimate, start;
    int observations;
  };
  std::vector<Sample> samples;
  std::vector<double> keyframe_scales;        // per keyframe: median reference / estimate
  std::vector<double> keyframe_start_scales;  // the same for the start depths
  KeyframeDepthCheck out;
  std::error_code ec;
  for (const io::KeyframeDepthEntry& kf : folder.keyframes) {
    std::string image = kf.image;
    const size_t hash = image.rfind('#');
    if (hash != std::string::npos) image = image.substr(0, hash);
    const fs::path map_path = fs::path(reference_dir) / (fs::path(image).stem().string() + ".png");
    if (image == "-" || !fs::is_regular_file(map_path, ec)) {
      ++out.keyframes_without_reference;
      continue;
    }
    const ImageF reference = io::ReadDepthPng(map_path.string(), reference_scale);
    const double sx = static_cast<double>(reference.width()) / folder.image_width;
    const double sy = static_cast<double>(reference.height()) / folder.image_height;
    const size_t first = samples.size();
    for (const io::KeyframeDepthPoint& p : kf.points) {
      const int x = static_cast<int>(std::lround((p.u + 0.5) * sx - 0.5));
      const int y = static_cast<int>(std::lround((p.v + 0.5) * sy - 0.5));
      if (x < 0 || y < 0 || x >= reference.width() || y >= reference.height()) continue;
      const double d = reference(x, y);
      if (!(d > min_depth && d < max_depth)) continue;
      samples.push_back(
          {static_cast<size_t>(out.keyframes), d, p.depth_m, p.start_depth_m, p.observations});
    }
    ++out.keyframes;
    std::vector<double> ratios, start_ratios;
    for (size_t i = first; i < samples.size(); ++i) {
      ratios.push_back(samples[i].reference / samples[i].estimate);
      start_ratios.push_back(samples[i].reference / samples[i].start);
    }
    keyframe_scales.push_back(Median(ratios));
    keyframe_start_scales.push_back(Median(start_ratios));
  }
  if (samples.empty()) {
    throw InputError("no keyframe point of the folder has a reference depth in " + reference_dir +
                     " (expected <image name>.png depth maps of the keyframes' images)");
  }
  out.points = samples.size();
  std::vector<double> all, all_start;
  for (const Sample& s : samples) {
    all.push_back(s.reference / s.estimate);
    all_start.push_back(s.reference / s.start);
  }
  out.run_scale = Median(all);
  const double start_scale = Median(all_start);
  std::vector<double> rel_run, rel_kf, rel_start_run, rel_start_kf, rel_obs[3], rel_start_obs[3],
      log_obs[3];
  size_t within = 0;
  for (const Sample& s : samples) {
    const double e = out.run_scale * s.estimate;
    rel_run.push_back(std::abs(e - s.reference) / s.reference);
    rel_kf.push_back(std::abs(keyframe_scales[s.keyframe] * s.estimate - s.reference) /
                     s.reference);
    rel_start_run.push_back(std::abs(start_scale * s.start - s.reference) / s.reference);
    rel_start_kf.push_back(std::abs(keyframe_start_scales[s.keyframe] * s.start - s.reference) /
                           s.reference);
    within += std::max(e / s.reference, s.reference / e) < 1.25 ? 1 : 0;
    const int bin = s.observations <= 1 ? 0 : (s.observations <= 3 ? 1 : 2);
    rel_obs[bin].push_back(rel_run.back());
    rel_start_obs[bin].push_back(rel_start_run.back());
    log_obs[bin].push_back(std::log(e / s.reference));
  }
  out.abs_rel_run_scale = Mean(rel_run);
  out.abs_rel_keyframe_scale = Mean(rel_kf);
  out.a1_run_scale = static_cast<double>(within) / static_cast<double>(samples.size());
  out.start_abs_rel_run_scale = Mean(rel_start_run);
  out.start_abs_rel_keyframe_scale = Mean(rel_start_kf);
  for (int b = 0; b < 3; ++b) {
    out.abs_rel_by_observations[b] = Mean(rel_obs[b]);
    out.start_abs_rel_by_observations[b] = Mean(rel_start_obs[b]);
    out.median_log_ratio_by_observations[b] = Median(log_obs[b]);
    out.points_by_observations[b] = rel_obs[b].size();
  }
  std::vector<double> scales;
  for (double s : keyframe_scales) {
    if (s > 0.0) scales.push_back(s);
  }
  const double mean_scale = Mean(scales);
  double var = 0.0;
  for (double s : scales) var += (s - mean_scale) * (s - mean_scale);
  out.keyframe_scale_cv = scales.size() > 1 && mean_scale > 0.0
                              ? std::sqrt(var / (scales.size() - 1)) / mean_scale
                              : 0.0;
  return out;
}

}  // namespace dfo::apps
