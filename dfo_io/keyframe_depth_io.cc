#include "dfo_io/keyframe_depth_io.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <set>

#include "dfo_core/error.h"
#include "dfo_io/file_writer.h"
#include "dfo_io/json.h"
#include "dfo_io/text_lines.h"
#include "dfo_io/trajectory_io.h"

namespace dfo::io {
namespace {

namespace fs = std::filesystem;

constexpr const char* kFormat = "dfo_keyframe_depth";
constexpr int kVersion = 1;

std::string PointsFileName(int frame) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d.txt", frame);
  return name;
}

std::string Join(const std::vector<double>& values) {
  std::string out;
  for (double v : values) {
    if (!out.empty()) out.push_back(' ');
    out += FormatDouble(v);
  }
  return out;
}

// The text after the first `n` tokens of `line` (leading blanks removed).
std::string RestAfterTokens(const std::string& line, size_t n) {
  size_t i = 0;
  for (size_t k = 0; k < n; ++k) {
    i = line.find_first_not_of(" \t", i);
    i = line.find_first_of(" \t", i);
    if (i == std::string::npos) return "";
  }
  const size_t begin = line.find_first_not_of(" \t", i);
  if (begin == std::string::npos) return "";
  const size_t end = line.find_last_not_of(" \t\r\n");
  return line.substr(begin, end - begin + 1);
}

int ParseCount(const std::string& token, const std::string& path, int line, int column) {
  const double v = ParseNumber(token, path, line, column);
  if (v != std::floor(v) || v < 0 || v > 1e9) {
    throw InputError(Where(path, line) + "number " + std::to_string(column) + " is '" + token +
                     "', expected a count (a whole number >= 0)");
  }
  return static_cast<int>(v);
}

void ReadHeader(const std::string& path, KeyframeDepthFolder* out) {
  std::set<std::string> seen;
  ForEachDataLine(
      path, "keyframe depth description",
      [&](int n, const std::string& line, const std::vector<std::string>& tokens) {
        const std::string& key = tokens[0];
        seen.insert(key);
        const auto expect = [&](size_t count, const char* what) {
          if (tokens.size() != count + 1) {
            throw InputError(Where(path, n) + "'" + key + "' with " +
                             std::to_string(tokens.size() - 1) + " values, expected " + what);
          }
        };
        if (key == "format") {
          expect(2, "2 (dfo_keyframe_depth 1)");
          if (tokens[1] != kFormat || tokens[2] != std::to_string(kVersion)) {
            throw InputError(Where(path, n) + "format '" + tokens[1] + " " + tokens[2] +
                             "', expected '" + kFormat + " " + std::to_string(kVersion) + "'");
          }
        } else if (key == "sequence") {
          out->sequence = RestAfterTokens(line, 1);
        } else if (key == "image_size") {
          expect(2, "2 (width height)");
          out->image_width = ParseCount(tokens[1], path, n, 2);
          out->image_height = ParseCount(tokens[2], path, n, 3);
          if (out->image_width <= 0 || out->image_height <= 0) {
            throw InputError(Where(path, n) + "image size " + tokens[1] + " x " + tokens[2] +
                             ", expected positive sides");
          }
        } else if (key == "camera") {
          expect(4, "4 (fx fy cx cy)");
          out->fx = ParseNumber(tokens[1], path, n, 2);
          out->fy = ParseNumber(tokens[2], path, n, 3);
          out->cx = ParseNumber(tokens[3], path, n, 4);
          out->cy = ParseNumber(tokens[4], path, n, 5);
          if (!(out->fx > 0.0) || !(out->fy > 0.0)) {
            throw InputError(Where(path, n) + "focal lengths " + tokens[1] + ", " + tokens[2] +
                             ", expected positive values");
          }
        } else {
          throw InputError(Where(path, n) + "unknown key '" + key +
                           "', expected format, sequence, image_size or camera");
        }
      });
  for (const char* key : {"format", "image_size", "camera"}) {
    if (!seen.count(key)) throw InputError(path + ": no '" + key + "' line");
  }
}

std::vector<KeyframeDepthPoint> ReadPoints(const std::string& path, int expected,
                                           const KeyframeDepthFolder& folder) {
  std::vector<KeyframeDepthPoint> points;
  ForEachDataLine(
      path, "keyframe points",
      [&](int n, const std::string& /*line*/, const std::vector<std::string>& tokens) {
        if (tokens.size() != 6) {
          throw InputError(Where(path, n) + "point line with " + std::to_string(tokens.size()) +
                           " numbers, expected 6 (u v depth_m start_depth_m observations "
                           "rms_residual)");
        }
        KeyframeDepthPoint p;
        p.u = ParseNumber(tokens[0], path, n, 1);
        p.v = ParseNumber(tokens[1], path, n, 2);
        p.depth_m = ParseNumber(tokens[2], path, n, 3);
        p.start_depth_m = ParseNumber(tokens[3], path, n, 4);
        p.observations = ParseCount(tokens[4], path, n, 5);
        p.rms_residual = ParseNumber(tokens[5], path, n, 6);
        if (p.u < -0.5 || p.v < -0.5 || p.u > folder.image_width - 0.5 ||
            p.v > folder.image_height - 0.5) {
          throw InputError(Where(path, n) + "pixel (" + tokens[0] + ", " + tokens[1] +
                           ") outside the " + std::to_string(folder.image_width) + " x " +
                           std::to_string(folder.image_height) + " image");
        }
        if (!(p.depth_m > 0.0) || !(p.start_depth_m > 0.0)) {
          throw InputError(Where(path, n) + "depth " + tokens[2] + " / start depth " + tokens[3] +
                           ", expected positive depths");
        }
        if (p.rms_residual < 0.0) {
          throw InputError(Where(path, n) + "rms_residual " + tokens[5] + ", expected >= 0");
        }
        points.push_back(p);
      });
  if (static_cast<int>(points.size()) != expected) {
    throw InputError(path + ": " + std::to_string(points.size()) +
                     " points, keyframes.txt announces " + std::to_string(expected));
  }
  return points;
}

}  // namespace

void WriteKeyframeDepthFolder(const std::string& folder, const KeyframeDepthFolder& data) {
  CreateFolder(folder, "keyframe depth folder");
  const fs::path root(folder);
  std::string header = std::string("# dfo keyframe depth (dfo_run run.write_keyframe_depth)\n") +
                       "format " + kFormat + " " + std::to_string(kVersion) + "\n";
  header += "sequence " + data.sequence + "\n";
  header += "image_size " + std::to_string(data.image_width) + " " +
            std::to_string(data.image_height) + "\n";
  header += "camera " + Join({data.fx, data.fy, data.cx, data.cy}) + "\n";

  std::string keyframes =
      "# frame timestamp_s tx ty tz qx qy qz qw points image (world_from_cam, windowed)\n";
  std::set<std::string> written;
  const fs::path points_dir = root / "points";
  CreateFolder(points_dir.string(), "keyframe depth folder");
  for (const KeyframeDepthEntry& kf : data.keyframes) {
    std::string pose = TumTrajectoryLine(kf.timestamp_ns, kf.world_from_cam);
    pose.pop_back();  // its '\n'
    keyframes += std::to_string(kf.frame) + " " + pose + " " + std::to_string(kf.points.size()) +
                 " " + (kf.image.empty() ? "-" : kf.image) + "\n";
    std::string points = "# u v depth_m start_depth_m observations rms_residual\n";
    for (const KeyframeDepthPoint& p : kf.points) {
      points += Join({p.u, p.v, p.depth_m, p.start_depth_m}) + " " +
                std::to_string(p.observations) + " " + FormatDouble(p.rms_residual) + "\n";
    }
    const std::string name = PointsFileName(kf.frame);
    WriteFileAtomically((points_dir / name).string(), points, "keyframe points");
    written.insert(name);
  }
  // Point files of an earlier folder's keyframes that this run does not have.
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(points_dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file(ec) && entry.path().extension() == ".txt" && !written.count(name)) {
      fs::remove(entry.path(), ec);
    }
  }
  WriteFileAtomically((root / "keyframes.txt").string(), keyframes, "keyframe list");
  WriteFileAtomically((root / "keyframe_depth.txt").string(), header, "keyframe depth description");
}

KeyframeDepthFolder ReadKeyframeDepthFolder(const std::string& folder) {
  const fs::path root(folder);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) {
    throw InputError("keyframe depth folder not found: " + folder);
  }
  KeyframeDepthFolder out;
  ReadHeader((root / "keyframe_depth.txt").string(), &out);
  const std::string path = (root / "keyframes.txt").string();
  ForEachDataLine(
      path, "keyframe list",
      [&](int n, const std::string& line, const std::vector<std::string>& tokens) {
        if (tokens.size() < 11) {
          throw InputError(Where(path, n) + "keyframe line with " + std::to_string(tokens.size()) +
                           " fields, expected 11 (frame timestamp_s tx ty tz qx qy qz qw points "
                           "image)");
        }
        KeyframeDepthEntry kf;
        kf.frame = ParseCount(tokens[0], path, n, 1);
        ParseNumber(tokens[1], path, n, 2);
        if (!ParseSecondsToNs(tokens[1], &kf.timestamp_ns)) {
          throw InputError(Where(path, n) + "timestamp '" + tokens[1] + "' " +
                           WhyNotSeconds(tokens[1]));
        }
        double v[7];
        for (int k = 0; k < 7; ++k) v[k] = ParseNumber(tokens[k + 2], path, n, k + 3);
        const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
        if (std::abs(q.norm() - 1.0) > kQuaternionNormTolerance) {
          throw InputError(Where(path, n) + "quaternion (qx qy qz qw) has norm " +
                           FormatDouble(q.norm()) + ", expected 1");
        }
        kf.world_from_cam = SE3d(q.normalized(), Eigen::Vector3d(v[0], v[1], v[2]));
        const int count = ParseCount(tokens[9], path, n, 10);
        kf.image = RestAfterTokens(line, 10);
        if (!out.keyframes.empty() && kf.frame <= out.keyframes.back().frame) {
          throw InputError(Where(path, n) + "frame " + tokens[0] + " after frame " +
                           std::to_string(out.keyframes.back().frame) +
                           ", expected increasing frame numbers");
        }
        kf.points = ReadPoints((root / "points" / PointsFileName(kf.frame)).string(), count, out);
        out.keyframes.push_back(std::move(kf));
      });
  return out;
}

}  // namespace dfo::io
