#include "dfo_io/synth_writer.h"

#include <atomic>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <thread>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_io/dataset.h"
#include "dfo_io/image_io.h"
#include "dfo_io/trajectory_io.h"

namespace dfo::io {

namespace fs = std::filesystem;

namespace {

void MakeDirs(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir)) {
    throw InputError("cannot create folder " + dir.string() + ": " +
                     (ec ? ec.message() : std::string("a file of that name exists")));
  }
}

std::ofstream OpenForWriting(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw InputError("cannot write " + path + " (folder missing or not writable?)");
  return out;
}

// One calibration row: "P0: " and the 12 numbers of the row-major 3x4 matrix, KITTI's %e style.
void WriteRow(std::ofstream& out, const char* label, const Eigen::Matrix<double, 3, 4>& P) {
  out << label << ":";
  char buf[32];
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      std::snprintf(buf, sizeof(buf), " %.12e", P(r, c));
      out << buf;
    }
  }
  out << "\n";
}

}  // namespace

void SynthWriteOptions::Check() const {
  if (output_dir.empty())
    throw ConfigError("SynthWriteOptions.output_dir is empty; a folder is needed");
  bool ok = !sequence.empty() && sequence.size() <= 16;
  for (char c : sequence) {
    ok = ok && (std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-');
  }
  if (!ok) {
    throw ConfigError("SynthWriteOptions.sequence = '" + sequence +
                      "' violates 1 to 16 characters of [0-9A-Za-z_-]");
  }
  if (num_threads < 1) {
    throw ConfigError("SynthWriteOptions.num_threads = " + std::to_string(num_threads) +
                      " violates >= 1");
  }
}

std::string KittiFrameName(int i) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%06d.png", i);
  return buf;
}

void WriteKittiCalibration(const std::string& path, const PinholeCamera& camera,
                           double stereo_baseline_m) {
  Eigen::Matrix<double, 3, 4> P0 = Eigen::Matrix<double, 3, 4>::Zero();
  P0.leftCols<3>() = camera.K();
  // KITTI: P_i = K [I | t_i] maps points of camera 0 to pixels of camera i; the right camera sits
  // b metres along +x, so t = (-b, 0, 0) and the 4th column is K t = (-fx b, 0, 0).
  Eigen::Matrix<double, 3, 4> P1 = P0;
  P1.col(3) = camera.K() * Eigen::Vector3d(-stereo_baseline_m, 0.0, 0.0);
  std::ofstream out = OpenForWriting(path);
  WriteRow(out, "P0", P0);
  WriteRow(out, "P1", P1);
  WriteRow(out, "P2", P0);
  WriteRow(out, "P3", P1);
  if (!out) throw InputError("error while writing " + path);
}

void WriteKittiTimes(const std::string& path, const Trajectory& trajectory) {
  std::ofstream out = OpenForWriting(path);
  char buf[64];
  for (const auto& pose : trajectory) {
    std::snprintf(buf, sizeof(buf), "%.6e\n", NsToSeconds(pose.timestamp_ns));
    out << buf;
  }
  if (!out) throw InputError("error while writing " + path);
}

SynthWriteSummary WriteSyntheticSequence(
    const SyntheticSequence& sequence, const SynthWriteOptions& options,
    const std::function<void(const SynthWriteProgress&)>& progress, double progress_interval_s) {
  options.Check();
  const auto start = std::chrono::steady_clock::now();
  const fs::path root(options.output_dir);
  const fs::path seq_dir = root / "sequences" / options.sequence;
  MakeDirs(seq_dir / "image_0");
  if (options.write_rgb) MakeDirs(seq_dir / "image_2");
  if (options.write_depth) MakeDirs(seq_dir / "depth_0");
  MakeDirs(root / "poses");

  const Trajectory truth = sequence.GroundTruth();
  WriteKittiCalibration((seq_dir / "calib.txt").string(), sequence.camera(),
                        sequence.options().stereo_baseline_m);
  WriteKittiTimes((seq_dir / "times.txt").string(), truth);
  const std::string poses_path = (root / "poses" / (options.sequence + ".txt")).string();
  WriteKittiTrajectory(poses_path, truth);

  // Frames are handed out one at a time; each worker renders and encodes whole frames (PNG
  // encoding is a large share of the time, so frame-level parallelism beats row-level).
  const int n = sequence.num_frames();
  std::atomic<int> next{0}, done{0};
  std::atomic<bool> failed{false};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&]() {
    while (!failed.load()) {
      const int i = next.fetch_add(1);
      if (i >= n) break;
      try {
        const SyntheticFrame frame = sequence.RenderFrame(i, 1);
        const std::string name = KittiFrameName(i);
        WriteImage((seq_dir / "image_0" / name).string(), frame.gray);
        if (options.write_rgb) WriteImage((seq_dir / "image_2" / name).string(), frame.rgb);
        if (options.write_depth) {
          WriteDepthPng((seq_dir / "depth_0" / name).string(), frame.depth, kDepthFolderScale);
        }
        done.fetch_add(1);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        failed.store(true);
      }
    }
  };
  const int threads = std::min(options.num_threads, n);
  std::vector<std::thread> pool;
  for (int k = 0; k < threads; ++k) pool.emplace_back(worker);

  auto elapsed = [&start]() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  auto report = [&]() {
    if (!progress) return;
    SynthWriteProgress p;
    p.frames_done = done.load();
    p.num_frames = n;
    p.elapsed_s = elapsed();
    p.frames_per_s = p.elapsed_s > 0 ? p.frames_done / p.elapsed_s : 0.0;
    p.eta_s = p.frames_per_s > 0 ? (n - p.frames_done) / p.frames_per_s : 0.0;
    progress(p);
  };
  double last_report = 0.0;
  while (done.load() < n && !failed.load()) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (elapsed() - last_report >= progress_interval_s) {
      last_report = elapsed();
      report();
    }
  }
  for (auto& th : pool) th.join();
  if (error) std::rethrow_exception(error);
  report();

  SynthWriteSummary summary;
  summary.num_frames = n;
  summary.seconds = elapsed();
  summary.sequence_dir = seq_dir.string();
  summary.poses_path = poses_path;
  return summary;
}

}  // namespace dfo::io
