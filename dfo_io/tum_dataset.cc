#include "dfo_io/tum_dataset.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <tuple>

#include "dfo_core/error.h"
#include "dfo_io/camera_yaml.h"
#include "dfo_io/image_io.h"
#include "dfo_io/lens.h"
#include "dfo_io/trajectory_io.h"

namespace dfo::io {
namespace fs = std::filesystem;
namespace {

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

std::vector<TumListEntry> ReadTumFileList(const std::string& path) {
  std::ifstream file(path);
  if (!IsFile(path) || !file) throw InputError("TUM file list not found: " + path);
  std::vector<TumListEntry> entries;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    const std::string where = path + ":" + std::to_string(line_number);
    std::istringstream tokens(line);
    std::string stamp, name, extra;
    if (!(tokens >> stamp >> name) || (tokens >> extra)) {
      throw InputError(where + ": expected 'timestamp filename', found '" + line + "'");
    }
    // Exact decimal parsing: epoch stamps like 1341841278.8427 must match groundtruth.txt's to
    // the nanosecond (a double only resolves ~0.2 us there).
    int64_t ns = 0;
    if (!ParseSecondsToNs(stamp, &ns)) {
      throw InputError(where + ": timestamp '" + stamp + "' " + WhyNotSeconds(stamp));
    }
    TumListEntry entry{ns, name, line_number};
    if (!entries.empty() && entry.timestamp_ns <= entries.back().timestamp_ns) {
      throw InputError(where + ": timestamps going backwards: " + stamp + " is not after line " +
                       std::to_string(entries.back().line) + "'s " +
                       FormatNsAsSeconds(entries.back().timestamp_ns));
    }
    entries.push_back(std::move(entry));
  }
  return entries;
}

std::vector<std::pair<size_t, size_t>> AssociateTumStamps(const std::vector<int64_t>& a,
                                                          const std::vector<int64_t>& b,
                                                          int64_t max_diff_ns) {
  // Candidate pairs closer than max_diff (associate.py: abs(a - b) < max_difference). Both lists
  // are sorted, so each a's candidates are a window of b found by binary search.
  std::vector<std::tuple<int64_t, size_t, size_t>> candidates;
  for (size_t i = 0; i < a.size(); ++i) {
    auto it = std::upper_bound(b.begin(), b.end(), a[i] - max_diff_ns);
    for (; it != b.end() && *it < a[i] + max_diff_ns; ++it) {
      const int64_t diff = std::llabs(a[i] - *it);
      if (diff < max_diff_ns) {
        candidates.emplace_back(diff, i, static_cast<size_t>(it - b.begin()));
      }
    }
  }
  // Greedy by increasing difference (ties by a then b, as Python's tuple sort).
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> used_a(a.size(), false), used_b(b.size(), false);
  std::vector<std::pair<size_t, size_t>> matches;
  for (const auto& [diff, i, j] : candidates) {
    if (used_a[i] || used_b[j]) continue;
    used_a[i] = used_b[j] = true;
    matches.emplace_back(i, j);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
}

SE3d InterpolatePose(const SE3d& a, const SE3d& b, double alpha) {
  const Eigen::Vector3d t = (1.0 - alpha) * a.translation() + alpha * b.translation();
  // Eigen's slerp takes the shorter arc.
  const Eigen::Quaterniond q = a.quaternion().slerp(alpha, b.quaternion());
  return SE3d(q, t);
}

std::optional<SE3d> GroundTruthAt(const Trajectory& gt, int64_t t_ns, const std::string& mode,
                                  int64_t max_diff_ns, int64_t max_gap_ns) {
  if (gt.empty()) return std::nullopt;
  const auto& poses = gt.poses();
  // First pose with timestamp >= t.
  const auto it =
      std::lower_bound(poses.begin(), poses.end(), t_ns,
                       [](const StampedPose& p, int64_t t) { return p.timestamp_ns < t; });
  const size_t k = static_cast<size_t>(it - poses.begin());
  if (k < poses.size() && poses[k].timestamp_ns == t_ns) return poses[k].world_from_cam;
  if (mode == "interpolate" && k > 0 && k < poses.size()) {
    const StampedPose& before = poses[k - 1];
    const StampedPose& after = poses[k];
    const int64_t gap = after.timestamp_ns - before.timestamp_ns;
    if (gap <= max_gap_ns) {
      const double alpha = static_cast<double>(t_ns - before.timestamp_ns) / gap;
      return InterpolatePose(before.world_from_cam, after.world_from_cam, alpha);
    }
  }
  // Nearest (the mode itself, or interpolation's fallback at the ends and across large gaps).
  size_t best = poses.size();
  int64_t best_diff = 0;
  for (size_t c : {k == 0 ? poses.size() : k - 1, k}) {
    if (c >= poses.size()) continue;
    const int64_t diff = std::llabs(poses[c].timestamp_ns - t_ns);
    if (best == poses.size() || diff < best_diff) {
      best = c;
      best_diff = diff;
    }
  }
  if (best < poses.size() && best_diff <= max_diff_ns) return poses[best].world_from_cam;
  return std::nullopt;
}

bool TumDefaultCamera(const std::string& folder, PinholeCamera* camera, std::string* sensor) {
  std::string name = fs::path(folder).lexically_normal().filename().string();
  if (name.empty()) name = fs::path(folder).lexically_normal().parent_path().filename().string();
  name = Lower(name);
  // Earliest occurrence of "freiburgN" or "frN" with N in 1..3.
  size_t best_pos = std::string::npos;
  int which = 0;
  for (int n = 1; n <= 3; ++n) {
    for (const std::string& token :
         {std::string("freiburg") + char('0' + n), std::string("fr") + char('0' + n)}) {
      const size_t pos = name.find(token);
      if (pos != std::string::npos && pos < best_pos) {
        best_pos = pos;
        which = n;
      }
    }
  }
  if (which == 0) return false;
  // Calibrated colour intrinsics from the TUM RGB-D benchmark's "file formats" page.
  static const double kIntrinsics[3][4] = {
      {517.3, 516.5, 318.6, 255.3}, {520.9, 521.0, 325.1, 249.7}, {535.4, 539.2, 320.1, 247.6}};
  const double* k = kIntrinsics[which - 1];
  *camera = PinholeCamera(k[0], k[1], k[2], k[3], 640, 480);
  if (sensor != nullptr) *sensor = "fr" + std::to_string(which);
  return true;
}

Sequence OpenTumSequence(const DatasetOptions& options) {
  const fs::path root(options.path);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    throw InputError("TUM RGB-D sequence folder not found: " + options.path);
  }
  const std::string what = "TUM sequence " + options.path;

  // Intrinsics: camera.yaml, else the folder-name rule (see the header).
  PinholeCamera camera;
  LensDistortion lens;
  double depth_scale = 5000.0;
  const fs::path camera_yaml = CameraYamlPath(options, (root / "camera.yaml").string());
  bool camera_from_file = false;
  if (!options.camera.empty() && !IsFile(camera_yaml)) {
    throw InputError(what + ": camera file not found: " + camera_yaml.string() +
                     " (dataset.camera)");
  }
  if (IsFile(camera_yaml)) {
    const CameraYaml c = ReadCameraYaml(camera_yaml.string());
    camera = c.camera;
    lens = c.lens;
    if (c.depth_scale) depth_scale = *c.depth_scale;
    camera_from_file = true;
  } else if (!TumDefaultCamera(options.path, &camera, nullptr)) {
    throw InputError(what +
                     ": no camera.yaml and the folder name names no freiburg sensor "
                     "(fr1/fr2/fr3): add " +
                     camera_yaml.string() + " with fx, fy, cx, cy, width, height");
  }

  const std::string rgb_list = (root / "rgb.txt").string();
  const std::vector<TumListEntry> rgb = ReadTumFileList(rgb_list);
  if (rgb.empty()) throw InputError(rgb_list + ": no images listed");
  std::vector<FrameInfo> frames(rgb.size());
  std::vector<int64_t> rgb_stamps;
  for (size_t i = 0; i < rgb.size(); ++i) {
    frames[i].timestamp_ns = rgb[i].timestamp_ns;
    frames[i].image_path = (root / rgb[i].file).string();
    rgb_stamps.push_back(rgb[i].timestamp_ns);
  }

  const fs::path depth_list = root / "depth.txt";
  if (IsFile(depth_list)) {
    const std::vector<TumListEntry> depth = ReadTumFileList(depth_list.string());
    std::vector<int64_t> depth_stamps;
    for (const auto& d : depth) depth_stamps.push_back(d.timestamp_ns);
    for (const auto& [i, j] :
         AssociateTumStamps(rgb_stamps, depth_stamps, SecondsToNs(options.tum_max_depth_diff))) {
      frames[i].depth_path = (root / depth[j].file).string();
    }
  }

  const fs::path gt_path = root / "groundtruth.txt";
  if (IsFile(gt_path)) {
    const Trajectory gt = ReadTumTrajectory(gt_path.string());
    for (auto& f : frames) {
      f.world_from_cam =
          GroundTruthAt(gt, f.timestamp_ns, options.tum_gt_mode,
                        SecondsToNs(options.tum_max_gt_diff), SecondsToNs(options.tum_max_gt_gap));
    }
  }

  frames = SelectFrameRange(std::move(frames), options, what);

  int width = 0, height = 0;
  try {
    ReadImageSize(frames.front().image_path, &width, &height);
  } catch (const InputError& e) {
    throw InputError(what + ", frame 0: " + e.what());
  }
  if (width != camera.width || height != camera.height) {
    throw InputError(what + ": the camera (" +
                     (camera_from_file ? camera_yaml.string() : std::string("freiburg default")) +
                     ") is for " + std::to_string(camera.width) + "x" +
                     std::to_string(camera.height) + " images, but " + frames.front().image_path +
                     " is " + std::to_string(width) + "x" + std::to_string(height));
  }
  CheckCalibration(camera, camera_from_file ? camera_yaml.string() : what);
  return Sequence("TUM " + root.lexically_normal().filename().string(), std::move(frames), camera,
                  depth_scale, options, MakeUndistorter(camera, lens, camera_yaml.string()));
}

}  // namespace dfo::io
