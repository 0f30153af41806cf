#include "dfo_io/folder_dataset.h"

#include <filesystem>

#include "dfo_core/error.h"
#include "dfo_io/camera_yaml.h"
#include "dfo_io/image_io.h"
#include "dfo_io/kitti_dataset.h"
#include "dfo_io/lens.h"

namespace dfo::io {
namespace fs = std::filesystem;

Sequence OpenFolderSequence(const DatasetOptions& options) {
  const fs::path root(options.path);
  std::error_code ec;
  if (!fs::is_directory(root, ec)) throw InputError("image folder not found: " + options.path);
  const std::string what = "image folder " + options.path;
  const fs::path camera_path = CameraYamlPath(options, (root / "camera.yaml").string());
  if (!fs::exists(camera_path, ec)) {  // a file, or a pipe (ReadCameraYaml reads both)
    throw InputError(what + ": camera file not found: " + camera_path.string() +
                     " (needs fx, fy, cx, cy, width, height)");
  }
  const CameraYaml camera = ReadCameraYaml(camera_path.string());
  const std::vector<std::string> images = ListImageFiles(options.path);
  if (images.empty()) throw InputError(what + ": no image files (png, jpg, ...) found");

  // Timestamps (see the header): times file, else fps.
  std::string times_path = camera.timestamps_path;
  if (times_path.empty() && fs::is_regular_file(root / "times.txt", ec)) {
    times_path = (root / "times.txt").string();
  }
  std::vector<int64_t> stamps;
  if (!times_path.empty()) {
    stamps = ReadKittiTimes(times_path);
    if (stamps.size() != images.size()) {
      throw InputError(times_path + ": " + std::to_string(stamps.size()) +
                       " timestamps, expected one per image: " + std::to_string(images.size()) +
                       " images in " + options.path);
    }
  } else {
    const double fps = camera.fps.value_or(1.0);
    for (size_t i = 0; i < images.size(); ++i) {
      stamps.push_back(SecondsToNs(static_cast<double>(i) / fps));
    }
  }

  std::vector<FrameInfo> frames(images.size());
  for (size_t i = 0; i < images.size(); ++i) {
    frames[i].timestamp_ns = stamps[i];
    frames[i].image_path = images[i];
  }
  frames = SelectFrameRange(std::move(frames), options, what);

  int width = 0, height = 0;
  try {
    ReadImageSize(frames.front().image_path, &width, &height);
  } catch (const InputError& e) {
    throw InputError(what + ", frame 0: " + e.what());
  }
  if (width != camera.camera.width || height != camera.camera.height) {
    throw InputError(
        camera_path.string() + ": camera is for " + std::to_string(camera.camera.width) + "x" +
        std::to_string(camera.camera.height) + " images, but " + frames.front().image_path +
        " is " + std::to_string(width) + "x" + std::to_string(height));
  }
  return Sequence(options.path, std::move(frames), camera.camera,
                  camera.depth_scale.value_or(1000.0), options,
                  MakeUndistorter(camera.camera, camera.lens, camera_path.string()));
}

}  // namespace dfo::io
