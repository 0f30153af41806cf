// Using dfo from your own program: read images with OpenCV, feed them to dfo::Odometry one at a
// time, print each frame's pose. Built by CMake as dfo_example and run by a test
// (tests/apps/example_test.cc), so it keeps working as the library changes.
//
//   dfo_example IMAGE_DIR FX FY CX CY [MODEL]
//
// IMAGE_DIR holds the frames as .png/.jpg files (sorted by name); FX FY CX CY are the pinhole
// intrinsics of those images in pixels; MODEL is a dfo model file (default models/default.dfo),
// whose depth network gives each frame's depth. Frames are resized to the model's input size.
// Prints one line per frame: index status tx ty tz qx qy qz qw (camera-to-world, windowed).
#include <algorithm>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "dfo_backend/odometry.h"
#include "dfo_frontend/learned/learned_sources.h"

int main(int argc, char** argv) {
  if (argc < 6) {
    std::fprintf(stderr, "usage: %s IMAGE_DIR FX FY CX CY [MODEL]\n", argv[0]);
    return 2;
  }
  try {
    // The images, sorted by name.
    std::vector<std::string> paths;
    for (const auto& entry : std::filesystem::directory_iterator(argv[1])) {
      const std::string ext = entry.path().extension().string();
      if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") paths.push_back(entry.path().string());
    }
    std::sort(paths.begin(), paths.end());
    if (paths.empty()) {
      std::fprintf(stderr, "no .png/.jpg images in %s\n", argv[1]);
      return 1;
    }

    // The depth network; dfo's hand-made features and default keyframe and window settings.
    dfo::LearnedModelOptions model_options;
    model_options.model_path = argc > 6 ? argv[6] : "models/default.dfo";
    const std::shared_ptr<dfo::LearnedModel> model = dfo::LoadLearnedModel(model_options);
    const int width = model->info().input_width, height = model->info().input_height;
    dfo::FrontendOptions frontend_options;
    frontend_options.depth = "learned";
    frontend_options.reference.policy = "external";  // the keyframe manager picks keyframes
    dfo::OdometryOptions options;                    // windowed, tracking against the window
    dfo::Odometry odometry(frontend_options, options, nullptr, dfo::MakeLearnedDepthSource(model));

    for (size_t i = 0; i < paths.size(); ++i) {
      const cv::Mat gray = cv::imread(paths[i], cv::IMREAD_GRAYSCALE);
      if (gray.empty()) {
        std::fprintf(stderr, "cannot read %s\n", paths[i].c_str());
        return 1;
      }
      const double sx = double(width) / gray.cols, sy = double(height) / gray.rows;
      cv::Mat resized;
      cv::resize(gray, resized, cv::Size(width, height), 0, 0, cv::INTER_AREA);
      dfo::Frame frame;
      frame.index = static_cast<int>(i);
      frame.timestamp_ns = static_cast<int64_t>(i) * 100000000;  // 10 Hz
      // Pixel centres at integers: the intrinsics scale about the image corner.
      frame.camera = dfo::PinholeCamera(std::stod(argv[2]) * sx, std::stod(argv[3]) * sy,
                                        (std::stod(argv[4]) + 0.5) * sx - 0.5,
                                        (std::stod(argv[5]) + 0.5) * sy - 0.5, width, height);
      frame.image = dfo::ImageU8(width, height, 1);
      for (int y = 0; y < height; ++y) {
        std::copy_n(resized.ptr<uint8_t>(y), width, frame.image.Row(y));
      }

      const dfo::OdometryFrame out = odometry.Process(frame);
      const dfo::SE3d& pose = out.windowed_world_from_cam;
      const Eigen::Quaterniond q = pose.quaternion();
      std::printf("%d %s %.6f %.6f %.6f %.6f %.6f %.6f %.6f\n", frame.index,
                  dfo::TrackingStatusName(out.tracked.status), pose.translation().x(),
                  pose.translation().y(), pose.translation().z(), q.x(), q.y(), q.z(), q.w());
    }
    std::fprintf(stderr, "%zu frames, %zu keyframes\n", paths.size(), odometry.keyframes().size());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
}
