#include "dfo_io/kitti_dataset.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_io/image_io.h"
#include "dfo_io/trajectory_io.h"

namespace dfo::io {
namespace fs = std::filesystem;
namespace {

bool ParseNumber(const std::string& token, double* out) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(token.c_str(), &end);
  if (token.empty() || errno == ERANGE || end != token.c_str() + token.size() ||
      !std::isfinite(v)) {
    return false;
  }
  *out = v;
  return true;
}

bool IsDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}
bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// KITTI numbers its images 000000, 000001, ...: names the numbers missing between the first
// and the last (at most five), or "" when the names are not all numbers or none is missing.
std::string MissingImageNumbers(const std::vector<std::string>& images) {
  std::vector<long long> numbers;
  size_t digits = 0;
  for (const std::string& image : images) {
    const std::string stem = fs::path(image).stem().string();
    if (stem.empty() || stem.size() > 12 ||
        !std::all_of(stem.begin(), stem.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      return "";
    }
    digits = stem.size();
    numbers.push_back(std::stoll(stem));
  }
  std::sort(numbers.begin(), numbers.end());
  std::string missing;
  int count = 0;
  for (size_t i = 1; i < numbers.size(); ++i) {
    for (long long n = numbers[i - 1] + 1; n < numbers[i]; ++n) {
      if (++count <= 5) {
        std::string name = std::to_string(n);
        if (name.size() < digits) name.insert(0, digits - name.size(), '0');
        missing += (missing.empty() ? "" : ", ") + name;
      }
    }
  }
  if (count == 0) return "";
  return "; missing between " + fs::path(images.front()).stem().string() + " and " +
         fs::path(images.back()).stem().string() + ": " + missing +
         (count > 5 ? " and " + std::to_string(count - 5) + " more" : "");
}

}  // namespace

KittiCalibration ReadKittiCalibration(const std::string& path) {
  std::ifstream file(path);
  if (!IsFile(path) || !file) throw InputError("KITTI calibration file not found: " + path);
  KittiCalibration calib;
  std::map<std::string, int> first_line;  // label -> line of its row
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    const std::string where = path + ":" + std::to_string(line_number);
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const size_t colon = line.find(':');
    if (colon == std::string::npos) {
      throw InputError(where + ": expected a labelled row like 'P0: <12 numbers>', found '" + line +
                       "'");
    }
    std::istringstream label_stream(line.substr(0, colon));
    std::string label;
    label_stream >> label;
    std::istringstream values(line.substr(colon + 1));
    std::vector<double> numbers;
    std::string token;
    while (values >> token) {
      double v;
      if (!ParseNumber(token, &v)) {
        throw InputError(where + ": non-numeric value '" + token + "' in calibration row '" +
                         label + "'");
      }
      numbers.push_back(v);
    }
    const bool projection = label.size() == 2 && label[0] == 'P';
    if (numbers.size() != 12) {
      if (projection) {
        throw InputError(where + ": calibration row '" + label + "' has " +
                         std::to_string(numbers.size()) + " numbers, expected 12 (3x4 matrix)");
      }
      continue;  // other rows (e.g. from raw KITTI) are not needed
    }
    Matrix3x4d m;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) m(r, c) = numbers[r * 4 + c];
    }
    const auto seen = first_line.find(label);
    if (seen != first_line.end()) {
      throw InputError(where + ": a second '" + label + ":' row (the first is on line " +
                       std::to_string(seen->second) + "); which one is meant is unclear");
    }
    first_line[label] = line_number;
    calib.rows[label] = m;
  }
  return calib;
}

PinholeCamera CameraFromProjection(const Matrix3x4d& projection, int width, int height) {
  return PinholeCamera(projection(0, 0), projection(1, 1), projection(0, 2), projection(1, 2),
                       width, height);
}

Eigen::Vector3d ProjectionOffset(const Matrix3x4d& projection) {
  const Eigen::Matrix3d K = projection.leftCols<3>();
  return K.inverse() * projection.col(3);
}

std::vector<int64_t> ReadKittiTimes(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError("times file " + path +
                     " is a folder; expected a text file of times in seconds");
  }
  if (!std::filesystem::exists(path, ec)) throw InputError("times file not found: " + path);
  errno = 0;
  std::ifstream file(path);
  if (!IsFile(path) || !file) {
    throw InputError("times file " + path + " cannot be read: " + std::strerror(errno));
  }
  std::vector<int64_t> stamps;
  std::string line;
  int line_number = 0;
  while (std::getline(file, line)) {
    ++line_number;
    std::istringstream tokens(line);
    std::string token, extra;
    if (!(tokens >> token)) continue;
    const std::string where = path + ":" + std::to_string(line_number);
    int64_t ns = 0;
    if (tokens >> extra) {
      throw InputError(where + ": expected one time in seconds, found '" + line + "'");
    }
    if (!ParseSecondsToNs(token, &ns)) {
      throw InputError(where + ": time '" + token + "' " + WhyNotSeconds(token));
    }
    if (!stamps.empty() && ns <= stamps.back()) {
      throw InputError(where + ": timestamps going backwards: " + token +
                       " s is not after the previous line's " + FormatNsAsSeconds(stamps.back()) +
                       " s");
    }
    stamps.push_back(ns);
  }
  return stamps;
}

Sequence OpenKittiSequence(const DatasetOptions& options) {
  // Where the sequence folder and the ground truth are.
  fs::path seq_dir = fs::path(options.path) / "sequences" / options.sequence;
  fs::path poses_path = fs::path(options.path) / "poses" / (options.sequence + ".txt");
  std::string seq_name = options.sequence;
  if (!IsDir(seq_dir)) {
    if (IsFile(fs::path(options.path) / "calib.txt")) {
      seq_dir = fs::path(options.path);
      seq_name = fs::absolute(seq_dir).lexically_normal().filename().string();
      if (seq_name.empty()) {
        seq_name = fs::absolute(seq_dir).lexically_normal().parent_path().filename().string();
      }
      poses_path = seq_dir / ".." / ".." / "poses" / (seq_name + ".txt");
    } else {
      throw InputError("KITTI sequence folder not found: " + seq_dir.string() + " (expected " +
                       "<dataset.path>/sequences/<dataset.sequence>/ with calib.txt, times.txt "
                       "and image_0/)");
    }
  }
  const std::string what = "KITTI sequence " + seq_dir.string();

  // Camera: image_2/P2 for colour when present, else image_0/P0 (see the header).
  const bool has0 = IsDir(seq_dir / "image_0");
  const bool has2 = IsDir(seq_dir / "image_2");
  if (!has0 && !has2) {
    throw InputError(what + ": no image folder: expected " + (seq_dir / "image_0").string() +
                     " (gray) or image_2 (colour)");
  }
  const int cam = (options.color && has2) || !has0 ? 2 : 0;
  const std::string cam_label = "P" + std::to_string(cam);
  const std::string calib_path = (seq_dir / "calib.txt").string();
  const KittiCalibration calib = ReadKittiCalibration(calib_path);
  const auto row = calib.rows.find(cam_label);
  if (row == calib.rows.end()) {
    throw InputError(calib_path + ": no '" + cam_label + ":' row: it is needed for the images in " +
                     (seq_dir / ("image_" + std::to_string(cam))).string());
  }
  const Eigen::Vector3d offset = ProjectionOffset(row->second);

  // Frames: images sorted by name, one time per image.
  const std::string image_dir = (seq_dir / ("image_" + std::to_string(cam))).string();
  const std::vector<std::string> images = ListImageFiles(image_dir);
  if (images.empty()) throw InputError(what + ": no images in " + image_dir);
  const std::string times_path = (seq_dir / "times.txt").string();
  const std::vector<int64_t> stamps = ReadKittiTimes(times_path);
  if (stamps.size() != images.size()) {
    throw InputError(times_path + ": " + std::to_string(stamps.size()) +
                     " timestamps, expected one per image: " + std::to_string(images.size()) +
                     " images in " + image_dir + MissingImageNumbers(images));
  }

  // Depth folder of this camera (see the header for camera 2 without depth_2).
  fs::path depth_dir = seq_dir / ("depth_" + std::to_string(cam));
  if (!IsDir(depth_dir) && cam == 2 && IsDir(seq_dir / "depth_0")) {
    const auto p0 = calib.rows.find("P0");
    if (p0 != calib.rows.end() && (ProjectionOffset(p0->second) - offset).norm() < 1e-9) {
      depth_dir = seq_dir / "depth_0";
    }
  }
  const bool has_depth = IsDir(depth_dir);

  std::vector<FrameInfo> frames(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    frames[i].timestamp_ns = stamps[i];
    frames[i].image_path = images[i];
    if (has_depth) {
      frames[i].depth_path =
          (depth_dir / fs::path(images[i]).filename().replace_extension(".png")).string();
    }
  }

  // Ground truth of camera 0, moved to the loaded camera: world_from_cam = world_from_cam0 *
  // cam0_from_cam, cam0_from_cam = [I | -t].
  if (IsFile(poses_path)) {
    const Trajectory gt = ReadKittiTrajectory(poses_path.string(), &stamps);
    if (gt.size() != frames.size()) {
      throw InputError(poses_path.string() + ": " + std::to_string(gt.size()) +
                       " poses, expected one per image: " + std::to_string(frames.size()));
    }
    const SE3d cam0_from_cam(SO3d(), -offset);
    for (size_t i = 0; i < frames.size(); ++i) {
      frames[i].world_from_cam = gt[i].world_from_cam * cam0_from_cam;
    }
  }

  frames = SelectFrameRange(std::move(frames), options, what);

  // Native size from the first used image; the others are checked when loaded (or Validate).
  int width = 0, height = 0;
  try {
    ReadImageSize(frames.front().image_path, &width, &height);
  } catch (const InputError& e) {
    throw InputError(what + ", frame 0: " + e.what());
  }
  const PinholeCamera camera = CameraFromProjection(row->second, width, height);
  CheckCalibration(camera, calib_path + " row " + cam_label);
  return Sequence("KITTI " + seq_name + (cam == 2 ? " (image_2)" : " (image_0)"), std::move(frames),
                  camera, kDepthFolderScale, options);
}

}  // namespace dfo::io
