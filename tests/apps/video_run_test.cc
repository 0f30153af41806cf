// dfo_run on video files (dataset.type: video), against the same frames as an image folder:
// a lossless FFV1 video gives byte-identical trajectories, and a lossy MPEG-4 video of a real
// sequence (the KITTI 06 extract of ../shared/data) tracks within 1.5x (+ 0.1 m) of the PNG
// frames' Sim3 ATE; a damaged video runs the frames that decoded and names the others. The videos
// are written here with OpenCV's FFmpeg backend; FFmpeg is a dependency, so a codec it cannot write
// fails the test.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "dfo_io/json.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::ReadFile;
using test::RunCommand;

// The grey PNGs of `image_dir` (sorted) as a video; false when FFmpeg cannot write the codec.
bool WriteVideo(const std::vector<std::string>& pngs, const std::string& path, const char* fourcc) {
  const cv::Mat first = cv::imread(pngs.front(), cv::IMREAD_GRAYSCALE);
  cv::VideoWriter writer(path, cv::CAP_FFMPEG,
                         cv::VideoWriter::fourcc(fourcc[0], fourcc[1], fourcc[2], fourcc[3]), 10.0,
                         first.size(), /*isColor=*/false);
  if (!writer.isOpened()) return false;
  for (const std::string& png : pngs) writer.write(cv::imread(png, cv::IMREAD_GRAYSCALE));
  writer.release();
  return true;
}

// The frames as an image folder, an FFV1 .mkv and an MPEG-4 .mp4, each with the camera.yaml.
struct Inputs {
  std::string folder, mkv, mp4;
};

Inputs MakeInputs(const std::string& tag, const std::string& image_dir, int frames,
                  const std::string& camera_yaml) {
  Inputs in;
  const std::string root = test::MakeTempDir(tag);
  in.folder = root + "/frames";
  fs::create_directories(in.folder);
  fs::create_directories(root + "/video");
  std::vector<std::string> pngs;
  for (int i = 0; i < frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.png", i);
    fs::copy_file(image_dir + name, in.folder + name);
    pngs.push_back(in.folder + name);
  }
  std::ofstream(in.folder + "/camera.yaml") << camera_yaml;
  std::ofstream(root + "/video/camera.yaml") << camera_yaml;
  in.mkv = root + "/video/frames.mkv";
  in.mp4 = root + "/video/frames.mp4";
  EXPECT_TRUE(WriteVideo(pngs, in.mkv, "FFV1")) << "FFmpeg cannot write FFV1";
  EXPECT_TRUE(WriteVideo(pngs, in.mp4, "mp4v")) << "FFmpeg cannot write MPEG-4";
  return in;
}

CommandResult RunDfoRun(const std::string& type, const std::string& path, const std::string& out) {
  return RunCommand("cd " + test::SourceDir() + " && " + std::string(DFO_RUN_EXE),
                    "--config configs/kitti.yaml --set dataset.type=" + type +
                        " --set dataset.path=" + path + " --set run.progress=none --output " + out);
}

double Ate(const std::string& gt, const std::string& estimate) {
  const CommandResult r = RunCommand(DFO_EVAL_EXE, "traj --gt " + gt + " --est " + estimate +
                                                       " --format kitti --align sim3 --json");
  EXPECT_EQ(r.status, 0) << r.err;
  return io::ParseJson(r.out)["ate_rmse"].AsNumber();
}

TEST(VideoRun, LosslessVideoEqualsTheFolderAndLossyVideoTracksAsThePngs) {
  const std::string shared = test::SharedDataDir();
  if (shared.empty()) GTEST_SKIP() << "../shared/data is absent (the KITTI 06 extract)";
  const std::string kitti = shared + "/kitti";
  const std::string camera =
      "width: 1226\nheight: 370\nfx: 707.0912\nfy: 707.0912\ncx: 601.8873\ncy: 183.1104\n"
      "fps: 10\n";
  const Inputs in = MakeInputs("video_run", kitti + "/sequences/06/image_0", 51, camera);
  const std::string out = test::MakeTempDir("video_run_out");
  for (const auto& [type, path, name] :
       {std::make_tuple("folder", in.folder, "folder"), std::make_tuple("video", in.mkv, "mkv"),
        std::make_tuple("video", in.mp4, "mp4")}) {
    const CommandResult r = RunDfoRun(type, path, out + "/" + name);
    ASSERT_EQ(r.status, 0) << name << ": " << r.err;
  }
  for (const char* file : {"frontend_kitti.txt", "windowed_kitti.txt", "keyframes_tum.txt"}) {
    EXPECT_EQ(ReadFile(out + "/folder/" + file), ReadFile(out + "/mkv/" + file)) << file;
  }
  // The lossy frames track as the PNGs: the frontend-only trajectory within 1.5x; the windowed
  // one within the 2-4x that any change of the input, down to float rounding, moves a single
  // windowed run on these 51 frames (docs/window.md, "Single runs scatter").
  const std::string gt = kitti + "/poses/06.txt";
  for (const auto& [file, factor] :
       {std::make_pair("frontend_kitti.txt", 1.5), std::make_pair("windowed_kitti.txt", 4.0)}) {
    const double png = Ate(gt, out + "/folder/" + file);
    const double mp4 = Ate(gt, out + "/mp4/" + file);
    EXPECT_LE(mp4, factor * png + 0.1) << file << ": PNG frames " << png << " m";
  }
}

// A damaged MPEG-4 video of the synthetic street (5,000 bytes overwritten in the middle): the run
// processes every frame that decoded, says on stderr in dfo's format which frames were damaged
// or missing (FFmpeg's own lines never appear) and lists each in summary.json input_warnings;
// decoded and missing frames add up to the 40 the container announces.
TEST(VideoRun, ADamagedVideoSaysWhichFramesAreDamagedOrMissing) {
  constexpr int kFrames = 40;
  const std::string synthetic =
      test::CopyOfSyntheticSequence(DFO_SYNTH_EXE, kFrames, "video_damage_run");
  const std::string frames = synthetic + "/sequences/00/image_0";
  std::vector<std::string> pngs;
  for (int i = 0; i < kFrames; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.png", i);
    pngs.push_back(frames + name);
  }
  // The camera from the KITTI calibration dfo_synth wrote (P0: fx 0 cx 0 0 fy cy ...).
  std::istringstream calib(ReadFile(synthetic + "/sequences/00/calib.txt"));
  std::string tag;
  double p[12];
  calib >> tag;
  for (double& v : p) calib >> v;
  const cv::Mat first = cv::imread(pngs.front(), cv::IMREAD_GRAYSCALE);
  const std::string root = test::MakeTempDir("video_damage_run_input");
  std::ofstream(root + "/camera.yaml")
      << "width: " << first.cols << "\nheight: " << first.rows << "\nfx: " << p[0]
      << "\nfy: " << p[5] << "\ncx: " << p[2] << "\ncy: " << p[6] << "\nfps: 10\n";
  const std::string video = root + "/street.mp4";
  ASSERT_TRUE(WriteVideo(pngs, video, "mp4v")) << "FFmpeg cannot write MPEG-4";
  std::string bytes = ReadFile(video);
  for (size_t i = 0; i < 5000; ++i) {
    bytes[bytes.size() / 2 + i] = static_cast<char>((i * 7919) & 0xff);
  }
  std::ofstream(video, std::ios::binary | std::ios::trunc) << bytes;

  const std::string out = test::MakeTempDir("video_damage_run_out");
  const CommandResult r = RunDfoRun("video", video, out);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find(" @ 0x"), std::string::npos) << "FFmpeg's own line: " << r.err;
  EXPECT_NE(r.err.find("dfo_run: warning: video " + video), std::string::npos) << r.err;
  const io::JsonValue summary = io::ParseJson(ReadFile(out + "/summary.json"));
  const io::JsonValue& warnings = summary["input_warnings"];
  ASSERT_GE(warnings.size(), 1u);
  int missing = 0;
  for (size_t i = 0; i < warnings.size(); ++i) {
    const std::string w = warnings[i].AsString();
    EXPECT_NE(w.find(video), std::string::npos) << w;
    missing += w.find("no frame came of it") != std::string::npos ? 1 : 0;
  }
  const int processed = static_cast<int>(summary["frames"].AsNumber());
  EXPECT_EQ(processed, static_cast<int>(summary["frames_in_sequence"].AsNumber()));
  EXPECT_EQ(processed + missing, kFrames) << ::testing::PrintToString(r.err);
}

}  // namespace
}  // namespace dfo
