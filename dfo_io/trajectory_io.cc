#include "dfo_io/trajectory_io.h"

#include <Eigen/SVD>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_io/file_writer.h"
#include "dfo_io/json.h"
#include "dfo_io/text_lines.h"

namespace dfo::io {
namespace {

// Projects a nearly orthonormal matrix onto the nearest rotation (polar decomposition via SVD)
// after checking it is within tolerance of one.
Eigen::Matrix3d CheckedRotation(const Eigen::Matrix3d& R, const std::string& path, int line) {
  const double orth_error = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = R.determinant();
  // Written so that NaN fails too.
  if (!(orth_error <= kRotationTolerance) || !(std::abs(det - 1.0) <= kRotationTolerance)) {
    std::ostringstream msg;
    msg << Where(path, line) << "rotation is not orthonormal (max |R^T R - I| = " << orth_error
        << ", det = " << det << "), expected a rotation within " << kRotationTolerance;
    throw InputError(msg.str());
  }
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * svd.matrixV().transpose();
}

}  // namespace

TrajectoryFormat ParseTrajectoryFormat(const std::string& name) {
  if (name == "kitti") return TrajectoryFormat::kKitti;
  if (name == "tum") return TrajectoryFormat::kTum;
  throw InputError("unknown trajectory format '" + name + "', expected kitti or tum");
}

std::string TrajectoryFormatName(TrajectoryFormat format) {
  return format == TrajectoryFormat::kKitti ? "kitti" : "tum";
}

std::string WhyNotSeconds(const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || std::isnan(v)) return "is not a number";
  return "is beyond the range of nanosecond time stamps (|t| < 9.2e9 s)";
}

bool ParseSecondsToNs(const std::string& text, int64_t* ns) {
  size_t i = 0;
  bool negative = false;
  if (i < text.size() && (text[i] == '-' || text[i] == '+')) negative = text[i++] == '-';
  const size_t int_begin = i;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
  const size_t int_end = i;
  size_t frac_begin = i, frac_end = i;
  if (i < text.size() && text[i] == '.') {
    frac_begin = ++i;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) ++i;
    frac_end = i;
  }
  const bool plain = i == text.size() && (int_end > int_begin || frac_end > frac_begin) &&
                     int_end - int_begin <= 10;
  int64_t seconds = 0;
  for (size_t k = int_begin; k < int_end && plain; ++k) seconds = seconds * 10 + (text[k] - '0');
  if (plain && seconds < 9200000000LL) {
    int64_t frac = 0;
    int digits = 0;
    for (size_t k = frac_begin; k < frac_end && digits < 9; ++k, ++digits) {
      frac = frac * 10 + (text[k] - '0');
    }
    for (; digits < 9; ++digits) frac *= 10;
    // Round half up on the tenth decimal.
    if (frac_end - frac_begin > 9 && text[frac_begin + 9] >= '5') ++frac;
    const int64_t value = seconds * 1000000000LL + frac;
    *ns = negative ? -value : value;
    return true;
  }
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end == text.c_str() || *end != '\0' || !std::isfinite(v) || std::abs(v) > 9.2e9) {
    return false;
  }
  *ns = SecondsToNs(v);
  return true;
}

std::string FormatNsAsSeconds(int64_t ns) {
  const bool negative = ns < 0;
  // Magnitude as unsigned so INT64_MIN is safe.
  const uint64_t mag = negative ? static_cast<uint64_t>(-(ns + 1)) + 1 : static_cast<uint64_t>(ns);
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%s%llu.%09llu", negative ? "-" : "",
                static_cast<unsigned long long>(mag / 1000000000ULL),
                static_cast<unsigned long long>(mag % 1000000000ULL));
  std::string s = buf;
  // Trim trailing zeros down to 6 decimals (microseconds, the usual TUM precision).
  const size_t dot = s.find('.');
  while (s.size() > dot + 7 && s.back() == '0') s.pop_back();
  return s;
}

Trajectory ReadKittiTrajectory(const std::string& path, const std::vector<int64_t>* timestamps_ns) {
  std::ifstream in = OpenForReading(path, "KITTI trajectory");
  Trajectory trajectory;
  std::string line;
  std::vector<std::string> tokens;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!Tokenize(line, &tokens)) continue;
    if (tokens.size() != 12) {
      throw InputError(Where(path, line_number) + "pose line with " +
                       std::to_string(tokens.size()) +
                       " numbers, expected 12 (row-major 3x4 world_from_cam)");
    }
    Matrix3x4d m;
    for (int k = 0; k < 12; ++k) m(k / 4, k % 4) = ParseNumber(tokens[k], path, line_number, k + 1);
    const Eigen::Matrix3d R = CheckedRotation(m.leftCols<3>(), path, line_number);
    const int64_t stamp = static_cast<int64_t>(trajectory.size()) * 1000000000LL;
    trajectory.Add(stamp, SE3d(SO3d::FromMatrix(R), m.col(3)));
  }
  if (timestamps_ns != nullptr) {
    if (timestamps_ns->size() != trajectory.size()) {
      throw InputError("KITTI trajectory " + path + " has " + std::to_string(trajectory.size()) +
                       " poses but " + std::to_string(timestamps_ns->size()) +
                       " timestamps were given, expected one per pose");
    }
    for (size_t i = 0; i < trajectory.size(); ++i) trajectory[i].timestamp_ns = (*timestamps_ns)[i];
  }
  return trajectory;
}

Trajectory ReadTumTrajectory(const std::string& path) {
  std::ifstream in = OpenForReading(path, "TUM trajectory");
  Trajectory trajectory;
  std::string line;
  std::vector<std::string> tokens;
  int line_number = 0;
  int previous_line = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!Tokenize(line, &tokens)) continue;
    if (tokens.size() != 8) {
      throw InputError(Where(path, line_number) + "pose line with " +
                       std::to_string(tokens.size()) +
                       " numbers, expected 8 (timestamp tx ty tz qx qy qz qw)");
    }
    int64_t stamp = 0;
    ParseNumber(tokens[0], path, line_number, 1);  // uniform message for non-numbers
    if (!ParseSecondsToNs(tokens[0], &stamp)) {
      throw InputError(Where(path, line_number) + "timestamp '" + tokens[0] + "' " +
                       WhyNotSeconds(tokens[0]));
    }
    double v[7];
    for (int k = 0; k < 7; ++k) v[k] = ParseNumber(tokens[k + 1], path, line_number, k + 2);
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);  // w, x, y, z
    const double norm = q.norm();
    if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
      std::ostringstream msg;
      msg << Where(path, line_number) << "quaternion (qx qy qz qw) has norm " << norm
          << ", expected 1 within " << kQuaternionNormTolerance;
      throw InputError(msg.str());
    }
    if (!trajectory.empty() && stamp <= trajectory.poses().back().timestamp_ns) {
      throw InputError(Where(path, line_number) + "timestamp " + tokens[0] +
                       " does not increase (previous pose, line " + std::to_string(previous_line) +
                       ", has " + FormatNsAsSeconds(trajectory.poses().back().timestamp_ns) +
                       "), expected strictly increasing timestamps");
    }
    previous_line = line_number;
    trajectory.Add(stamp, SE3d(q.normalized(), Eigen::Vector3d(v[0], v[1], v[2])));
  }
  return trajectory;
}

TrajectoryFormat DetectTrajectoryFormat(const std::string& path, const char* what) {
  std::ifstream in = OpenForReading(path, what);
  std::string line;
  std::vector<std::string> tokens;
  for (int number = 1; std::getline(in, line); ++number) {
    for (char& c : line) c = c == ',' ? ' ' : c;
    if (!Tokenize(line, &tokens)) continue;
    if (tokens.size() == 12) return TrajectoryFormat::kKitti;
    if (tokens.size() == 8) return TrajectoryFormat::kTum;
    throw InputError(Where(path, number) + "cannot tell the format from a line with " +
                     std::to_string(tokens.size()) +
                     " values, expected 12 (kitti) or 8 (tum); give --format");
  }
  throw InputError(std::string(what) + " file " + path + " has no pose line");
}

Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format) {
  return format == TrajectoryFormat::kKitti ? ReadKittiTrajectory(path) : ReadTumTrajectory(path);
}

std::vector<int64_t> ReadTimestamps(const std::string& path) {
  std::ifstream in = OpenForReading(path, "timestamps");
  std::vector<int64_t> stamps;
  std::string line;
  std::vector<std::string> tokens;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (!Tokenize(line, &tokens)) continue;
    if (tokens.size() != 1) {
      throw InputError(Where(path, line_number) + "line with " + std::to_string(tokens.size()) +
                       " values, expected 1 (seconds)");
    }
    ParseNumber(tokens[0], path, line_number, 1);
    int64_t ns = 0;
    if (!ParseSecondsToNs(tokens[0], &ns)) {
      throw InputError(Where(path, line_number) + "time '" + tokens[0] + "' " +
                       WhyNotSeconds(tokens[0]));
    }
    stamps.push_back(ns);
  }
  return stamps;
}

std::string KittiTrajectoryLine(const SE3d& world_from_cam) {
  const Matrix3x4d m = world_from_cam.Matrix3x4Form();
  std::string line;
  for (int k = 0; k < 12; ++k) {
    if (k > 0) line.push_back(' ');
    line += FormatDouble(m(k / 4, k % 4));
  }
  line.push_back('\n');
  return line;
}

std::string TumTrajectoryLine(int64_t timestamp_ns, const SE3d& world_from_cam) {
  const Eigen::Vector3d& t = world_from_cam.translation();
  const Eigen::Quaterniond& q = world_from_cam.quaternion();
  std::string line = FormatNsAsSeconds(timestamp_ns);
  for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) {
    line.push_back(' ');
    line += FormatDouble(v);
  }
  line.push_back('\n');
  return line;
}

void WriteKittiTrajectory(const std::string& path, const Trajectory& trajectory) {
  std::string text;
  for (const auto& pose : trajectory) text += KittiTrajectoryLine(pose.world_from_cam);
  WriteFileAtomically(path, text, "KITTI trajectory");
}

void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory) {
  std::string text = kTumTrajectoryHeader;
  for (const auto& pose : trajectory) {
    text += TumTrajectoryLine(pose.timestamp_ns, pose.world_from_cam);
  }
  WriteFileAtomically(path, text, "TUM trajectory");
}

void WriteTrajectory(const std::string& path, const Trajectory& trajectory,
                     TrajectoryFormat format) {
  if (format == TrajectoryFormat::kKitti) {
    WriteKittiTrajectory(path, trajectory);
  } else {
    WriteTumTrajectory(path, trajectory);
  }
}

}  // namespace dfo::io
