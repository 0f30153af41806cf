#include "dfo_io/dataset.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_io/folder_dataset.h"
#include "dfo_io/image_io.h"
#include "dfo_io/kitti_dataset.h"
#include "dfo_io/lens.h"
#include "dfo_io/tum_dataset.h"
#include "dfo_io/video_dataset.h"
#include "dfo_io/video_reader.h"

namespace dfo::io {
namespace fs = std::filesystem;

void DatasetOptions::Check() const {
  const auto fail = [](const std::string& what) { throw ConfigError(what); };
  if (type != "kitti" && type != "tum" && type != "folder" && type != "video") {
    fail("dataset.type = '" + type + "' violates one of kitti|tum|folder|video");
  }
  if (path.empty()) fail("dataset.path is empty: set it to the dataset's folder or video file");
  if (type == "kitti" && sequence.empty()) fail("dataset.sequence is empty (KITTI needs it)");
  if (type == "kitti" && !camera.empty()) {
    fail("dataset.camera = '" + camera +
         "' violates empty for dataset.type kitti (KITTI's camera is its calib.txt)");
  }
  if (first < 0) fail("dataset.first = " + std::to_string(first) + " violates >= 0");
  if (step < 1) fail("dataset.step = " + std::to_string(step) + " violates >= 1");
  if (last < -1) fail("dataset.last = " + std::to_string(last) + " violates >= -1");
  if (last >= 0 && last < first) {
    fail("dataset.last = " + std::to_string(last) + " violates >= dataset.first (" +
         std::to_string(first) + ") or -1");
  }
  if (!keep_native && image_width <= 0) {
    fail("dataset.image_width = " + std::to_string(image_width) + " violates > 0");
  }
  if (!keep_native && image_height <= 0) {
    fail("dataset.image_height = " + std::to_string(image_height) + " violates > 0");
  }
  if (!depth_dir.empty() && type == "video") {
    fail("dataset.depth_dir = '" + depth_dir +
         "' violates empty for dataset.type video (its frames have no image files to name depth "
         "maps after)");
  }
  if (processing_width < 0) {
    fail("dataset.processing_width = " + std::to_string(processing_width) + " violates >= 0");
  }
  if (processing_width > 0 && keep_native) {
    fail("dataset.processing_width = " + std::to_string(processing_width) +
         " and dataset.keep_native = true ask for two frame sizes: set one of them");
  }
  const auto positive = [&](const char* name, double v) {
    if (!(v > 0) || !std::isfinite(v)) {
      std::ostringstream msg;
      msg << "dataset." << name << " = " << v << " violates > 0";
      fail(msg.str());
    }
  };
  positive("tum_max_depth_diff", tum_max_depth_diff);
  positive("tum_max_gt_diff", tum_max_gt_diff);
  positive("tum_max_gt_gap", tum_max_gt_gap);
  if (tum_gt_mode != "interpolate" && tum_gt_mode != "nearest") {
    fail("dataset.tum_gt_mode = '" + tum_gt_mode + "' violates one of interpolate|nearest");
  }
}

std::pair<int, int> ProcessingSize(const PinholeCamera& native, int width, int multiple) {
  DFO_CHECK(multiple >= 1 && width > 0 && native.width > 0 && native.height > 0)
      << "multiple " << multiple << ", width " << width << ", native " << native.width << " x "
      << native.height;
  const int w = std::max(multiple, width / multiple * multiple);
  const double exact_height = static_cast<double>(native.height) * w / native.width;
  const int h =
      std::max(multiple, static_cast<int>(std::lround(exact_height / multiple)) * multiple);
  if (w > 8192 || h > 8192) {
    throw ConfigError("dataset.processing_width = " + std::to_string(width) + " gives " +
                      std::to_string(w) + " x " + std::to_string(h) + " for " +
                      std::to_string(native.width) + " x " + std::to_string(native.height) +
                      " frames, above 8192 pixels a side");
  }
  return {w, h};
}

Sequence Sequence::WithOutputSize(int width, int height) const {
  Sequence out = *this;
  out.options_.image_width = width;
  out.options_.image_height = height;
  out.options_.Check();
  return out;
}

Sequence Sequence::WithDepthFolder(const std::string& folder) const {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw InputError("dataset.depth_dir = '" + folder + "': no such folder");
  }
  Sequence out = *this;
  for (size_t i = 0; i < out.frames_.size(); ++i) {
    FrameInfo& f = out.frames_[i];
    if (f.video_frame >= 0) {
      throw ConfigError("dataset.depth_dir = '" + folder +
                        "': frames decoded from a video have no image files to name depth maps "
                        "after");
    }
    const fs::path map = fs::path(folder) / (fs::path(f.image_path).stem().string() + ".png");
    if (!fs::is_regular_file(map, ec)) {
      throw InputError(FramePrefix(i) + "dataset.depth_dir = '" + folder + "' has no depth map " +
                       map.string() + " for image " + f.image_path);
    }
    f.depth_path = map.string();
  }
  out.depth_scale_ = kDepthFolderScale;
  return out;
}

Sequence::Sequence(std::string name, std::vector<FrameInfo> frames, PinholeCamera native_camera,
                   double depth_scale, DatasetOptions options,
                   std::shared_ptr<const Undistorter> undistorter,
                   std::shared_ptr<VideoReader> video)
    : name_(std::move(name)),
      frames_(std::move(frames)),
      native_camera_(native_camera),
      depth_scale_(depth_scale),
      options_(std::move(options)),
      undistorter_(std::move(undistorter)),
      video_(std::move(video)) {
  DFO_CHECK(!frames_.empty()) << name_;
  DFO_CHECK(depth_scale_ > 0) << depth_scale_;
  native_camera_.Check();
  if (undistorter_) {
    DFO_CHECK(undistorter_->camera().width == native_camera_.width &&
              undistorter_->camera().height == native_camera_.height)
        << "undistortion maps for another image size than the native camera's";
  }
  for (const FrameInfo& f : frames_) {
    DFO_CHECK(f.video_frame < 0 || video_) << "video frame " << f.video_frame << " without video";
  }
}

const FrameInfo& Sequence::frame(size_t i) const {
  DFO_CHECK(i < frames_.size()) << "frame " << i << " of " << frames_.size();
  return frames_[i];
}

int Sequence::output_width() const {
  return options_.keep_native ? native_camera_.width : options_.image_width;
}
int Sequence::output_height() const {
  return options_.keep_native ? native_camera_.height : options_.image_height;
}

PinholeCamera Sequence::camera() const {
  if (output_width() == native_camera_.width && output_height() == native_camera_.height) {
    return native_camera_;
  }
  return native_camera_.Resized(output_width(), output_height());
}

bool Sequence::has_depth() const {
  return std::any_of(frames_.begin(), frames_.end(),
                     [](const FrameInfo& f) { return !f.depth_path.empty(); });
}

bool Sequence::has_ground_truth() const {
  return std::any_of(frames_.begin(), frames_.end(),
                     [](const FrameInfo& f) { return f.world_from_cam.has_value(); });
}

Trajectory Sequence::GroundTruth() const {
  Trajectory gt;
  for (const auto& f : frames_) {
    if (f.world_from_cam) gt.Add(f.timestamp_ns, *f.world_from_cam);
  }
  return gt;
}

std::vector<int64_t> Sequence::Timestamps() const {
  std::vector<int64_t> stamps;
  stamps.reserve(frames_.size());
  for (const auto& f : frames_) stamps.push_back(f.timestamp_ns);
  return stamps;
}

std::string Sequence::FramePrefix(size_t i) const {
  return name_ + ", frame " + std::to_string(i) + " (recording index " +
         std::to_string(frames_[i].source_index) + "): ";
}

ImageU8 Sequence::LoadNativeImage(size_t i) const {
  const FrameInfo& f = frame(i);
  ImageU8 image;
  try {
    if (f.video_frame >= 0) {
      image = video_->ReadFrame(f.video_frame, options_.color);
    } else {
      image = options_.color ? ReadRgb(f.image_path) : ReadGray(f.image_path);
    }
  } catch (const InputError& e) {
    throw InputError(FramePrefix(i) + e.what());
  }
  if (image.width() != native_camera_.width || image.height() != native_camera_.height) {
    const std::string file = f.video_frame >= 0
                                 ? f.image_path + " frame " + std::to_string(f.video_frame)
                                 : f.image_path;
    throw InputError(FramePrefix(i) + "images of different sizes in one sequence: " + file +
                     " is " + std::to_string(image.width()) + "x" + std::to_string(image.height()) +
                     ", expected " + std::to_string(native_camera_.width) + "x" +
                     std::to_string(native_camera_.height) + " (the size of " +
                     frames_.front().image_path + ")");
  }
  return undistorter_ ? undistorter_->Apply(image) : image;
}

ImageU8 Sequence::LoadImage(size_t i) const {
  ImageU8 native = LoadNativeImage(i);
  return Resize(native, output_width(), output_height());
}

ImageF Sequence::LoadDepth(size_t i) const {
  const FrameInfo& f = frame(i);
  if (f.depth_path.empty()) return ImageF();
  ImageF depth;
  try {
    depth = ReadDepthPng(f.depth_path, depth_scale_);
  } catch (const InputError& e) {
    throw InputError(FramePrefix(i) + e.what());
  }
  if (depth.width() != native_camera_.width || depth.height() != native_camera_.height) {
    throw InputError(FramePrefix(i) + "depth map " + f.depth_path + " is " +
                     std::to_string(depth.width()) + "x" + std::to_string(depth.height()) +
                     ", expected the image size " + std::to_string(native_camera_.width) + "x" +
                     std::to_string(native_camera_.height));
  }
  if (undistorter_) depth = undistorter_->ApplyDepth(depth);
  return ResizeDepth(depth, output_width(), output_height());
}

LoadedFrame Sequence::Load(size_t i) const {
  LoadedFrame out;
  out.index = static_cast<int>(i);
  out.timestamp_ns = frame(i).timestamp_ns;
  out.image = LoadImage(i);
  if (options_.depth) out.depth_m = LoadDepth(i);
  out.camera = camera();
  out.world_from_cam = frame(i).world_from_cam;
  return out;
}

void Sequence::Validate() const {
  for (size_t i = 0; i < frames_.size(); ++i) {
    const FrameInfo& f = frames_[i];
    if (f.video_frame >= 0) {
      LoadNativeImage(i);  // decodes the frame and checks its size
      continue;
    }
    int w = 0, h = 0;
    try {
      ReadImageSize(f.image_path, &w, &h);
    } catch (const InputError& e) {
      throw InputError(FramePrefix(i) + e.what());
    }
    if (w != native_camera_.width || h != native_camera_.height) {
      throw InputError(
          FramePrefix(i) + "images of different sizes in one sequence: " + f.image_path + " is " +
          std::to_string(w) + "x" + std::to_string(h) + ", expected " +
          std::to_string(native_camera_.width) + "x" + std::to_string(native_camera_.height) +
          " (the size of " + frames_.front().image_path + ")");
    }
    if (!f.depth_path.empty()) {
      ImageU16 raw;
      try {
        raw = ReadU16(f.depth_path);
      } catch (const InputError& e) {
        throw InputError(FramePrefix(i) + e.what());
      }
      if (raw.width() != w || raw.height() != h) {
        throw InputError(FramePrefix(i) + "depth map " + f.depth_path + " is " +
                         std::to_string(raw.width()) + "x" + std::to_string(raw.height()) +
                         ", expected the image size " + std::to_string(w) + "x" +
                         std::to_string(h));
      }
    }
  }
}

namespace {

Sequence OpenByType(const DatasetOptions& options) {
  if (options.type == "kitti") return OpenKittiSequence(options);
  if (options.type == "tum") return OpenTumSequence(options);
  if (options.type == "video") return OpenVideoSequence(options);
  return OpenFolderSequence(options);
}

}  // namespace

Sequence OpenSequence(const DatasetOptions& options) {
  options.Check();
  Sequence sequence = OpenByType(options);
  if (options.depth_dir.empty()) return sequence;
  return sequence.WithDepthFolder(options.depth_dir);
}

ImageF ResizeDepth(const ImageF& depth, int width, int height) {
  DFO_CHECK(width > 0 && height > 0) << width << "x" << height;
  DFO_CHECK(depth.channels() == 1) << depth.channels();
  if (depth.width() == width && depth.height() == height) return depth;
  const double sx = static_cast<double>(depth.width()) / width;
  const double sy = static_cast<double>(depth.height()) / height;
  const auto valid = [](float d) { return d > 0.0f && std::isfinite(d); };
  ImageF out(width, height, 1, 0.0f);
  for (int v = 0; v < height; ++v) {
    // Output pixel v covers source rows [v * sy, (v + 1) * sy) (pixel-corner coordinates); its
    // centre is at (v + 0.5) * sy - 0.5 in pixel-centre coordinates, as PinholeCamera::Resized.
    const double cy = (v + 0.5) * sy - 0.5;
    const int y0 = std::max(0, static_cast<int>(std::floor(v * sy)));
    const int y1 = std::min(depth.height() - 1, static_cast<int>(std::ceil((v + 1) * sy)) - 1);
    const int yc = std::clamp(static_cast<int>(std::lround(cy)), 0, depth.height() - 1);
    for (int u = 0; u < width; ++u) {
      const double cx = (u + 0.5) * sx - 0.5;
      const int xc = std::clamp(static_cast<int>(std::lround(cx)), 0, depth.width() - 1);
      const float centre = depth(xc, yc);
      if (valid(centre)) {
        out(u, v) = centre;
        continue;
      }
      const int x0 = std::max(0, static_cast<int>(std::floor(u * sx)));
      const int x1 = std::min(depth.width() - 1, static_cast<int>(std::ceil((u + 1) * sx)) - 1);
      double best = std::numeric_limits<double>::max();
      float best_depth = 0.0f;
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
          const float d = depth(x, y);
          if (!valid(d)) continue;
          const double dist = (x - cx) * (x - cx) + (y - cy) * (y - cy);
          // Ties resolved by scan order, so the result is deterministic.
          if (dist < best) {
            best = dist;
            best_depth = d;
          }
        }
      }
      out(u, v) = best_depth;
    }
  }
  return out;
}

std::vector<FrameInfo> SelectFrameRange(std::vector<FrameInfo> frames,
                                        const DatasetOptions& options, const std::string& what) {
  const int n = static_cast<int>(frames.size());
  if (n == 0) throw InputError(what + ": no frames found");
  const int last = options.last < 0 ? n - 1 : options.last;
  if (options.first >= n || last >= n || last < options.first) {
    throw InputError(what + ": frame range dataset.first = " + std::to_string(options.first) +
                     ", dataset.last = " + std::to_string(options.last) +
                     " is outside the recording's " + std::to_string(n) + " frames (0.." +
                     std::to_string(n - 1) + ")");
  }
  DFO_CHECK(options.step >= 1) << options.step;
  std::vector<FrameInfo> kept;
  kept.reserve(static_cast<size_t>((last - options.first) / options.step + 1));
  for (int i = options.first; i <= last; i += options.step) {
    kept.push_back(std::move(frames[i]));
    kept.back().source_index = i;
  }
  return kept;
}

void CheckCalibration(const PinholeCamera& camera, const std::string& what) {
  std::string why;
  if (!camera.IsValid(&why)) throw InputError(what + ": wrong calibration: " + why);
  // Pixel centres at integers: the image spans [-0.5, width - 0.5] x [-0.5, height - 0.5].
  if (camera.cx < -0.5 || camera.cx > camera.width - 0.5 || camera.cy < -0.5 ||
      camera.cy > camera.height - 0.5) {
    std::ostringstream msg;
    msg << what << ": wrong calibration: principal point (" << camera.cx << ", " << camera.cy
        << ") lies outside the " << camera.width << "x" << camera.height << " image";
    throw InputError(msg.str());
  }
}

std::string CameraYamlPath(const DatasetOptions& options, const std::string& default_path) {
  return options.camera.empty() ? default_path : options.camera;
}

std::vector<std::string> ListImageFiles(const std::string& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw InputError("image folder not found: " + folder);
  std::vector<std::string> files;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    std::string ext = entry.path().extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (!(ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".ppm" || ext == ".pgm" ||
          ext == ".bmp" || ext == ".tif" || ext == ".tiff")) {
      continue;
    }
    // A name like an image's that holds none is named, not counted as a missing frame.
    std::error_code status_error;
    const fs::file_status status = fs::status(entry.path(), status_error);
    if (fs::is_directory(status)) {
      throw InputError("image " + entry.path().string() + " is a folder, not an image file");
    }
    if (status_error || !fs::exists(status)) {
      const bool link = fs::is_symlink(fs::symlink_status(entry.path(), status_error));
      throw InputError("image " + entry.path().string() +
                       (link ? " is a symbolic link that leads to no file (a loop or a missing "
                               "target)"
                             : " cannot be read: " + status_error.message()));
    }
    if (!fs::is_regular_file(status)) {
      throw InputError("image " + entry.path().string() + " is not a regular file");
    }
    files.push_back(entry.path().string());
  }
  if (ec) throw InputError("cannot list image folder " + folder + ": " + ec.message());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace dfo::io
