// Trajectory files in the KITTI odometry and TUM RGB-D formats (camera-to-world poses).
//
// KITTI: one pose per line, 12 numbers: the row-major 3x4 matrix [R | t] of world_from_cam.
//        The file has no timestamps: they come from a separate times file or the line index.
// TUM:   one pose per line, "timestamp tx ty tz qx qy qz qw" (seconds; Hamilton quaternion,
//        x y z w order); lines starting with '#' and blank lines are skipped.
//
// Every reading error throws dfo::InputError with "path:line: what was found, what was
// expected" (1-based line numbers): missing file, wrong count of numbers, a token that is not a
// number, non-finite values, a rotation that is not orthonormal (KITTI), a quaternion that is
// not of unit norm (TUM), timestamps that do not strictly increase. Rotations within tolerance
// are re-orthonormalised (files printed with 6-9 significant digits are not exactly
// orthonormal).
#ifndef DFO_IO_TRAJECTORY_IO_H_
#define DFO_IO_TRAJECTORY_IO_H_

#include <cstdint>
#include <string>
#include <vector>

#include "dfo_core/trajectory.h"

namespace dfo::io {

// Trajectory file formats.
enum class TrajectoryFormat { kKitti, kTum };

// "kitti" | "tum". Throws InputError naming the value otherwise.
TrajectoryFormat ParseTrajectoryFormat(const std::string& name);
// The inverse of ParseTrajectoryFormat.
std::string TrajectoryFormatName(TrajectoryFormat format);

// Tolerances of the readers' sanity checks.
// |R^T R - I| (largest element) and |det R - 1| above this are errors in KITTI files.
constexpr double kRotationTolerance = 1e-3;
// |norm(q) - 1| above this is an error in TUM files.
constexpr double kQuaternionNormTolerance = 1e-3;

// Reads a KITTI pose file. With `timestamps_ns` it must hold one entry per pose line (else
// InputError naming both counts); without it pose i gets timestamp i * 1e9 ns (1 s per frame).
// Blank lines and '#' comment lines are skipped.
Trajectory ReadKittiTrajectory(const std::string& path,
                               const std::vector<int64_t>* timestamps_ns = nullptr);

// Reads a TUM trajectory file; timestamps must strictly increase (the error names the file and
// the line of the first stamp that does not).
Trajectory ReadTumTrajectory(const std::string& path);

// Reads either format.
Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format);

// The format of a trajectory file from its first pose line: 12 values KITTI, 8 TUM. Throws
// InputError naming `what` (e.g. "ground-truth trajectory") and the file when it is missing or a
// folder, or naming the line when it tells neither, or when the file has no pose line.
TrajectoryFormat DetectTrajectoryFormat(const std::string& path, const char* what);

// Reads a times file (KITTI `times.txt`): one time in seconds per line (blank and '#' lines
// skipped), returned in nanoseconds. Errors name file and line.
std::vector<int64_t> ReadTimestamps(const std::string& path);

// Writes a KITTI pose file (timestamps are not stored). Numbers are written with the fewest
// digits that read back to the same double. Creates missing parent folders. The file is written
// as "<path>.tmp" and renamed onto `path` when complete, so `path` never holds a partial write;
// throws InputError naming the file and the system's reason (errno) when it cannot be written.
void WriteKittiTrajectory(const std::string& path, const Trajectory& trajectory);

// Writes a TUM trajectory file: timestamps in seconds with exact nanoseconds, positions and
// quaternions with round-trip precision, a '#' header line. Creates missing parent folders;
// written and renamed as WriteKittiTrajectory.
void WriteTumTrajectory(const std::string& path, const Trajectory& trajectory);

// One line of each file format (with its '\n'), for files written a frame at a time, and the TUM
// header line.
std::string KittiTrajectoryLine(const SE3d& world_from_cam);
std::string TumTrajectoryLine(int64_t timestamp_ns, const SE3d& world_from_cam);
inline constexpr char kTumTrajectoryHeader[] = "# timestamp tx ty tz qx qy qz qw\n";

// Writes either format.
void WriteTrajectory(const std::string& path, const Trajectory& trajectory,
                     TrajectoryFormat format);

// Parses a decimal time in seconds ("1305031102.160407", "-0.5", "1e3") to nanoseconds without
// going through a double when the text is plain decimal (so 10-digit epoch stamps stay exact to
// the nanosecond); exponent forms go through strtod. Returns false when `text` is not a finite
// number.
bool ParseSecondsToNs(const std::string& text, int64_t* ns);
// Why ParseSecondsToNs(text) failed, for messages: "is not a number" or "is beyond the range of
// nanosecond time stamps (|t| < 9.2e9 s)".
std::string WhyNotSeconds(const std::string& text);

// Formats nanoseconds as decimal seconds, exactly, with at least 6 decimals
// (1305031102160407000 -> "1305031102.160407").
std::string FormatNsAsSeconds(int64_t ns);

}  // namespace dfo::io

#endif  // DFO_IO_TRAJECTORY_IO_H_
