// Using dfo from your own program: read images with OpenCV, feed them to dfo::Odometry one at a
// time, print each frame's pose. Built by CMake as dfo_example in dfo's own build, and against the
// installed package by its own CMakeLists.txt (find_package(dfo)); tests/apps/example_test.cc runs
// both, so it keeps working as the library changes. It uses the library alone.
//
//   dfo_example IMAGE_DIR FX FY CX CY [MODEL]
//
// IMAGE_DIR holds the frames as .png/.jpg files (sorted by name); FX FY CX CY are the pinhole
// intrinsics of those images in pixels; MODEL is a dfo model file (default: the model installed
// with dfo, dfo::DefaultModelPath()), whose depth network gives each frame's depth. Frames are
// resized to the model's input size. Prints one line per frame: index status tx ty tz qx qy qz qw
// (camera-to-world, windowed).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "dfo_backend/odometry.h"
#include "dfo_frontend/learned/learned_sources.h"

namespace {

struct Args {
  std::string image_dir;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::string model = dfo::DefaultModelPath();  // the model installed with dfo
  bool help = false;
};

// A mistake on the command line (exit status 2).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// `text` as a number, in full ("247.9x" and "abc" are refused, naming the argument).
double ParseNumber(const std::string& name, const std::string& text) {
  size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || !std::isfinite(value)) {
    throw UsageError(name + ": '" + text + "' is not a (finite) number");
  }
  return value;
}

// IMAGE_DIR FX FY CX CY [MODEL]; focal lengths > 0.
Args ParseArgs(int argc, char** argv) {
  Args args;
  const char* names[] = {"IMAGE_DIR", "FX", "FY", "CX", "CY", "MODEL"};
  std::vector<std::string> words;
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word == "--help" || word == "-h") {
      args.help = true;
      return args;
    }
    if (words.size() == 6) throw UsageError("unexpected argument '" + word + "' after MODEL");
    words.push_back(word);
  }
  if (words.size() < 5) throw UsageError(std::string(names[words.size()]) + " is missing");
  args.image_dir = words[0];
  args.fx = ParseNumber("FX", words[1]);
  args.fy = ParseNumber("FY", words[2]);
  args.cx = ParseNumber("CX", words[3]);
  args.cy = ParseNumber("CY", words[4]);
  if (words.size() == 6) args.model = words[5];
  if (!(args.fx > 0.0)) throw UsageError("FX: " + words[1] + " is not a focal length (> 0)");
  if (!(args.fy > 0.0)) throw UsageError("FY: " + words[2] + " is not a focal length (> 0)");
  return args;
}

int Run(const Args& args) {
  // The images, sorted by name.
  std::error_code ec;
  if (!std::filesystem::is_directory(args.image_dir, ec)) {
    throw dfo::InputError("IMAGE_DIR " + args.image_dir + " is not a folder");
  }
  std::vector<std::string> paths;
  for (const auto& entry : std::filesystem::directory_iterator(args.image_dir)) {
    const std::string ext = entry.path().extension().string();
    if (ext == ".png" || ext == ".jpg" || ext == ".jpeg") paths.push_back(entry.path().string());
  }
  std::sort(paths.begin(), paths.end());
  if (paths.empty()) throw dfo::InputError("no .png/.jpg images in " + args.image_dir);

  // The depth network; dfo's hand-made features and default keyframe and window settings.
  dfo::LearnedModelOptions model_options;
  model_options.model_path = args.model;
  const std::shared_ptr<dfo::LearnedModel> model = dfo::LoadLearnedModel(model_options);
  const int width = model->info().input_width, height = model->info().input_height;
  dfo::FrontendOptions frontend_options;
  frontend_options.depth = "learned";
  frontend_options.reference.policy = "external";  // the keyframe manager picks keyframes
  dfo::OdometryOptions options;                    // windowed, tracking against the window
  dfo::Odometry odometry(frontend_options, options, nullptr, dfo::MakeLearnedDepthSource(model));

  for (size_t i = 0; i < paths.size(); ++i) {
    const cv::Mat gray = cv::imread(paths[i], cv::IMREAD_GRAYSCALE);
    if (gray.empty()) throw dfo::InputError("cannot read image " + paths[i]);
    const double sx = double(width) / gray.cols, sy = double(height) / gray.rows;
    cv::Mat resized;
    cv::resize(gray, resized, cv::Size(width, height), 0, 0, cv::INTER_AREA);
    dfo::Frame frame;
    frame.index = static_cast<int>(i);
    frame.timestamp_ns = static_cast<int64_t>(i) * 100000000;  // 10 Hz
    // Pixel centres at integers: the intrinsics scale about the image corner.
    frame.camera = dfo::PinholeCamera(args.fx * sx, args.fy * sy, (args.cx + 0.5) * sx - 0.5,
                                      (args.cy + 0.5) * sy - 0.5, width, height);
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
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Args args = ParseArgs(argc, argv);
    if (args.help) {
      std::printf("usage: dfo_example IMAGE_DIR FX FY CX CY [MODEL]\n");
      return 0;
    }
    return Run(args);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "dfo_example: error: %s (see dfo_example --help)\n", e.what());
    return 2;
  } catch (const std::exception& e) {  // dfo::InputError and the rest: the message names the file
    std::fprintf(stderr, "dfo_example: error: %s\n", e.what());
    return 1;
  }
}
