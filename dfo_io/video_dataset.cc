#include "dfo_io/video_dataset.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>

#include "dfo_core/error.h"
#include "dfo_io/camera_yaml.h"
#include "dfo_io/kitti_dataset.h"
#include "dfo_io/lens.h"
#include "dfo_io/video_reader.h"

namespace dfo::io {
namespace fs = std::filesystem;
namespace {

// Scans of the videos opened by this process (see the header), keyed by absolute path, size and
// modification time, so that a changed file is scanned again.
VideoIndex CachedScan(VideoReader* reader, int max_frames) {
  static std::mutex mutex;
  static std::map<std::string, VideoIndex> cache;
  std::error_code ec_path, ec_size, ec_time;
  const fs::path absolute = fs::absolute(reader->path(), ec_path).lexically_normal();
  const auto size = fs::file_size(reader->path(), ec_size);
  const auto mtime = fs::last_write_time(reader->path(), ec_time);
  const bool no_key = ec_path || ec_size || ec_time;  // no reliable key: no caching
  const std::string key =
      absolute.string() + "|" + std::to_string(size) + "|" +
      std::to_string(
          std::chrono::duration_cast<std::chrono::nanoseconds>(mtime.time_since_epoch()).count());
  const auto covers = [max_frames](const VideoIndex& index) {
    return index.complete ||
           (max_frames >= 0 && static_cast<int>(index.stamps_ms.size()) >= max_frames);
  };
  {
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = cache.find(key);
    if (!no_key && it != cache.end() && covers(it->second)) return it->second;
  }
  VideoIndex index = reader->Scan(max_frames);
  if (!no_key) {
    std::lock_guard<std::mutex> lock(mutex);
    VideoIndex& stored = cache[key];
    if (index.complete || index.stamps_ms.size() > stored.stamps_ms.size()) stored = index;
  }
  return index;
}

std::string Seconds(double ms) {
  if (ms < 0) return "unknown time";
  char text[32];
  std::snprintf(text, sizeof(text), "t = %.3f s", ms / 1000.0);
  return text;
}

// One line per damage that touches the frames [first, last] of the video, and one for frames the
// container announces that the scan did not find (complete scans only).
std::vector<std::string> DamageWarnings(const VideoIndex& index, const std::string& path, int first,
                                        int last) {
  std::vector<std::string> out;
  for (const VideoDamage& d : index.damage) {
    if (d.frame >= 0) {
      if (d.frame < first || d.frame > last) continue;
      out.push_back("video " + path + ", frame " + std::to_string(d.frame) + " (" +
                    Seconds(d.time_ms) +
                    "): decoded with concealed damage, processed as decoded (" + d.cause + ")");
    } else {
      if (d.next_frame < first || d.next_frame > last + 1) continue;
      const std::string where =
          d.next_frame == 0 ? "before frame 0"
          : d.next_frame >= static_cast<int>(index.stamps_ms.size())
              ? "after frame " + std::to_string(d.next_frame - 1) + ", the last"
              : "between frames " + std::to_string(d.next_frame - 1) + " and " +
                    std::to_string(d.next_frame);
      out.push_back("video " + path + ": " +
                    (d.packet >= 0 ? "packet " + std::to_string(d.packet) + " (" +
                                         Seconds(d.time_ms) + ") could not be decoded"
                                   : "reading stopped (" + Seconds(d.time_ms) + ")") +
                    ", no frame came of it " + where + " (" + d.cause + ")");
    }
  }
  if (index.complete && index.declared_frames >= 0) {
    const int64_t found = static_cast<int64_t>(index.stamps_ms.size()) + index.undecodable_packets;
    const int64_t missing = index.declared_frames - found;
    // A count from a duration is rounded and may be one frame off.
    const int64_t tolerance =
        index.declared_estimated ? std::max<int64_t>(1, index.declared_frames / 50) : 0;
    if (missing > tolerance) {
      out.push_back(
          "video " + path + ": the container announces " +
          (index.declared_estimated ? "about " : "") + std::to_string(index.declared_frames) +
          " frames" + (index.declared_estimated ? " (its duration times its frame rate)" : "") +
          ", " + std::to_string(index.stamps_ms.size()) + " were decoded and " +
          std::to_string(index.undecodable_packets) + " could not be: " + std::to_string(missing) +
          " are missing from the file (truncated or damaged)");
    }
  }
  return out;
}

}  // namespace

std::vector<int64_t> VideoTimestampsNs(const std::vector<double>& container_ms,
                                       std::optional<double> fps, double container_fps,
                                       const std::string& what) {
  const size_t n = container_ms.size();
  std::vector<int64_t> stamps(n);
  if (n == 0) return stamps;
  const auto ms_to_ns = [](double ms) { return static_cast<int64_t>(std::llround(ms * 1e6)); };
  // The run of strictly increasing container times from frame 0.
  size_t good = 1;
  while (good < n && std::isfinite(container_ms[good]) &&
         container_ms[good] > container_ms[good - 1]) {
    ++good;
  }
  const double first_ms = std::isfinite(container_ms[0]) ? container_ms[0] : 0.0;
  stamps[0] = ms_to_ns(first_ms);
  for (size_t i = 1; i < good; ++i) stamps[i] = ms_to_ns(container_ms[i]);
  if (good == n) return stamps;
  double rate = 0.0;
  if (fps) {
    rate = *fps;
  } else if (container_fps > 0) {
    rate = container_fps;
  } else {
    throw InputError(what + ": the container gives no time for frame " + std::to_string(good) +
                     " on and no frame rate: set 'fps' in the camera.yaml (or a 'timestamps' "
                     "file)");
  }
  for (size_t i = good; i < n; ++i) {
    stamps[i] = stamps[good - 1] + SecondsToNs(static_cast<double>(i - good + 1) / rate);
  }
  return stamps;
}

Sequence OpenVideoSequence(const DatasetOptions& options) {
  const std::string what = "video " + options.path;
  auto reader = std::make_shared<VideoReader>(options.path);
  const fs::path beside = fs::path(options.path).parent_path() / "camera.yaml";
  const std::string camera_path = CameraYamlPath(options, beside.string());
  std::error_code ec;
  if (!fs::exists(camera_path, ec)) {  // a file, or a pipe (ReadCameraYaml reads both)
    throw InputError(what + ": camera file not found: " + camera_path +
                     " (needs fx, fy, cx, cy, width, height; by default camera.yaml beside the "
                     "video, or name it with dataset.camera)");
  }
  const CameraYaml camera = ReadCameraYaml(camera_path);

  // Frames to scan: all when the times come from a file (one line per frame) or the range is
  // open-ended, else up to dataset.last.
  const bool all = !camera.timestamps_path.empty() || options.last < 0;
  const VideoIndex index = CachedScan(reader.get(), all ? -1 : options.last + 1);
  if (index.width != camera.camera.width || index.height != camera.camera.height) {
    throw InputError(camera_path + ": camera is for " + std::to_string(camera.camera.width) + "x" +
                     std::to_string(camera.camera.height) + " images, but the frames of " +
                     options.path + " are " + std::to_string(index.width) + "x" +
                     std::to_string(index.height));
  }
  const size_t n = index.stamps_ms.size();
  std::vector<int64_t> stamps;
  if (!camera.timestamps_path.empty()) {
    stamps = ReadKittiTimes(camera.timestamps_path);
    if (stamps.size() != n) {
      throw InputError(camera.timestamps_path + ": " + std::to_string(stamps.size()) +
                       " timestamps, expected one per frame: " + std::to_string(n) + " frames in " +
                       options.path);
    }
  } else {
    stamps = VideoTimestampsNs(index.stamps_ms, camera.fps, index.container_fps, what);
  }

  std::vector<FrameInfo> frames(n);
  for (size_t i = 0; i < n; ++i) {
    frames[i].timestamp_ns = stamps[i];
    frames[i].image_path = options.path;
    frames[i].video_frame = static_cast<int>(i);
  }
  frames = SelectFrameRange(std::move(frames), options, what);
  std::vector<std::string> warnings =
      DamageWarnings(index, options.path, frames.front().video_frame, frames.back().video_frame);
  Sequence sequence(options.path, std::move(frames), camera.camera,
                    camera.depth_scale.value_or(1000.0), options,
                    MakeUndistorter(camera.camera, camera.lens, camera_path), std::move(reader));
  sequence.set_warnings(std::move(warnings));
  return sequence;
}

}  // namespace dfo::io
