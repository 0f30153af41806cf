// Runs the real dfo_synth executable (DFO_SYNTH_EXE) and checks the KITTI layout it writes, the
// calibration rows, the counts, that the files hold what the library renders in memory, and its
// command-line errors.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_io/image_io.h"
#include "dfo_io/kitti_dataset.h"
#include "dfo_io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;

using test::CommandResult;

CommandResult RunSynth(const std::string& args) { return test::RunCommand(DFO_SYNTH_EXE, args); }

std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

int CountFiles(const fs::path& dir) {
  if (!fs::is_directory(dir)) return -1;
  int n = 0;
  for (const auto& entry : fs::directory_iterator(dir)) n += entry.is_regular_file();
  return n;
}

TEST(DfoSynthAppTest, WritesKittiLayoutMatchingTheLibrary) {
  const std::string out = test::MakeTempDir("dfo_synth_app");
  const std::string preview = out + "/preview.png";
  const CommandResult r = RunSynth("--output " + out + " --sequence 07 --seed 5 --frames 10 " +
                                   "--threads 2 --preview " + preview);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.out.find("10/10 frames"), std::string::npos) << r.out;  // progress line

  const fs::path seq = fs::path(out) / "sequences" / "07";
  EXPECT_EQ(CountFiles(seq / "image_0"), 10);
  EXPECT_EQ(CountFiles(seq / "image_2"), 10);
  EXPECT_EQ(CountFiles(seq / "depth_0"), 10);
  ASSERT_TRUE(fs::is_regular_file(seq / "image_0" / "000009.png"));

  // calib.txt: P0..P3, 12 numbers each; P0 = K [I | 0], P1 carries -fx * 0.54.
  const SyntheticOptions defaults;
  const PinholeCamera cam = defaults.Camera();
  const std::vector<std::string> calib = ReadLines((seq / "calib.txt").string());
  ASSERT_EQ(calib.size(), 4u);
  for (int row = 0; row < 4; ++row) {
    std::istringstream in(calib[row]);
    std::string label;
    in >> label;
    EXPECT_EQ(label, "P" + std::to_string(row) + ":");
    std::vector<double> v;
    double x;
    while (in >> x) v.push_back(x);
    ASSERT_EQ(v.size(), 12u) << calib[row];
    EXPECT_NEAR(v[0], cam.fx, 1e-9);
    EXPECT_NEAR(v[2], cam.cx, 1e-9);
    EXPECT_NEAR(v[5], cam.fy, 1e-9);
    EXPECT_NEAR(v[6], cam.cy, 1e-9);
    EXPECT_DOUBLE_EQ(v[10], 1.0);
    EXPECT_NEAR(v[3], (row % 2 == 1) ? -cam.fx * 0.54 : 0.0, 1e-9);
  }

  // times.txt: 10 lines, 0.1 s apart.
  const std::vector<std::string> times = ReadLines((seq / "times.txt").string());
  ASSERT_EQ(times.size(), 10u);
  EXPECT_NEAR(std::stod(times[0]), 0.0, 1e-12);
  EXPECT_NEAR(std::stod(times[9]), 0.9, 1e-9);

  // Poses: 10 lines of 12 numbers, the first the identity, equal to the library's ground truth.
  const std::string poses_path = out + "/poses/07.txt";
  const std::vector<std::string> pose_lines = ReadLines(poses_path);
  ASSERT_EQ(pose_lines.size(), 10u);
  for (const auto& line : pose_lines) {
    std::istringstream in(line);
    std::vector<double> v;
    double x;
    while (in >> x) v.push_back(x);
    EXPECT_EQ(v.size(), 12u) << line;
  }
  const Trajectory written = io::ReadKittiTrajectory(poses_path);
  ASSERT_EQ(written.size(), 10u);
  EXPECT_TRUE(written[0].world_from_cam.Matrix().isIdentity(1e-12));

  SyntheticOptions options;
  options.seed = 5;
  options.num_frames = 10;
  const SyntheticSequence sequence(options);
  for (int i = 0; i < 10; ++i) {
    EXPECT_TRUE(
        written[i].world_from_cam.Matrix().isApprox(sequence.WorldFromCam(i).Matrix(), 1e-9))
        << "pose " << i;
  }
  // The files hold exactly what the library renders (PNG is lossless; depth in 1/256 m).
  const SyntheticFrame frame = sequence.RenderFrame(4, 2);
  const ImageU8 gray = io::ReadGray((seq / "image_0" / "000004.png").string());
  const ImageU8 rgb = io::ReadRgb((seq / "image_2" / "000004.png").string());
  const ImageU16 depth = io::ReadU16((seq / "depth_0" / "000004.png").string());
  ASSERT_EQ(gray.width(), 416);
  ASSERT_EQ(gray.height(), 128);
  EXPECT_EQ(gray.vector(), frame.gray.vector());
  EXPECT_EQ(rgb.vector(), frame.rgb.vector());
  ASSERT_EQ(depth.size(), frame.depth.size());
  int zeros = 0;
  for (size_t k = 0; k < depth.size(); ++k) {
    const double expected = std::round(frame.depth.vector()[k] * 256.0);
    ASSERT_EQ(depth.vector()[k], static_cast<uint16_t>(expected)) << "pixel " << k;
    zeros += depth.vector()[k] == 0;
  }
  EXPECT_LT(zeros, static_cast<int>(depth.size()) / 2);  // sky is a minority of the picture

  // The preview exists and is a picture of sensible size.
  int w = 0, h = 0;
  io::ReadImageSize(preview, &w, &h);
  EXPECT_GT(w, 2 * 416);
  EXPECT_GT(h, 5 * 128);
}

// dfo's own KITTI reader opens the written sequence: same camera, poses and depth.
TEST(DfoSynthAppTest, KittiReaderOpensTheOutput) {
  const std::string out = test::MakeTempDir("dfo_synth_reader");
  const CommandResult r = RunSynth("--output " + out + " --seed 2 --frames 6 --threads 2");
  ASSERT_EQ(r.status, 0) << r.err;
  SyntheticOptions options;
  options.seed = 2;
  options.num_frames = 6;
  const SyntheticSequence sequence(options);

  io::DatasetOptions dataset;
  dataset.path = out;
  dataset.sequence = "00";
  dataset.color = true;
  dataset.depth = true;
  const io::Sequence opened = io::OpenKittiSequence(dataset);
  ASSERT_EQ(opened.size(), 6u);
  const PinholeCamera& cam = opened.native_camera();
  EXPECT_EQ(cam.width, 416);
  EXPECT_EQ(cam.height, 128);
  EXPECT_NEAR(cam.fx, sequence.camera().fx, 1e-9);
  EXPECT_NEAR(cam.cy, sequence.camera().cy, 1e-9);
  ASSERT_TRUE(opened.has_ground_truth());
  ASSERT_TRUE(opened.has_depth());
  const io::LoadedFrame loaded = opened.Load(5);
  ASSERT_TRUE(loaded.world_from_cam.has_value());
  EXPECT_TRUE(loaded.world_from_cam->Matrix().isApprox(sequence.WorldFromCam(5).Matrix(), 1e-9));
  EXPECT_EQ(loaded.timestamp_ns, sequence.TimestampNs(5));
  const SyntheticFrame frame = sequence.RenderFrame(5, 2);
  EXPECT_EQ(loaded.image.vector(), frame.rgb.vector());
  ASSERT_EQ(loaded.depth_m.size(), frame.depth.size());
  for (size_t k = 0; k < frame.depth.size(); ++k) {
    ASSERT_NEAR(loaded.depth_m.vector()[k], frame.depth.vector()[k], 0.5 / 256.0 + 1e-6);
  }
}

TEST(DfoSynthAppTest, HelpPrintsUsage) {
  const CommandResult r = RunSynth("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("usage: dfo_synth --output DIR"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--fov-deg"), std::string::npos);
  EXPECT_TRUE(r.err.empty()) << r.err;
}

// Exactly one line on stderr containing `fragment`, non-zero exit.
void ExpectCleanFailure(const CommandResult& r, const std::string& fragment) {
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "more than one line: " << r.err;
}

TEST(DfoSynthAppTest, BadArgumentsFailWithOneLine) {
  const std::string out = test::MakeTempDir("dfo_synth_bad");
  ExpectCleanFailure(RunSynth("--output " + out + " --bogus 3"), "unknown argument '--bogus'");
  ExpectCleanFailure(RunSynth("--frames 10"), "--output DIR is required");
  ExpectCleanFailure(RunSynth("--output " + out + " --frames 0"), "--frames: 0 is out of range");
  ExpectCleanFailure(RunSynth("--output " + out + " --frames ten"),
                     "--frames: 'ten' is not an integer");
  ExpectCleanFailure(RunSynth("--output " + out + " --seed -1"), "--seed: -1 is out of range");
  ExpectCleanFailure(RunSynth("--output " + out + " --fov-deg 170 --frames 1"),
                     "horizontal_fov_deg = 170");
  ExpectCleanFailure(RunSynth("--output " + out + " --sequence a/b --frames 1"),
                     "SynthWriteOptions.sequence = 'a/b'");
  ExpectCleanFailure(RunSynth("--output " + out + " --threads"), "--threads needs a value");
  // Nothing was rendered by the failed runs.
  EXPECT_FALSE(fs::exists(fs::path(out) / "sequences"));
}

TEST(DfoSynthAppTest, UnwritableOutputIsReported) {
  const std::string dir = test::MakeTempDir("dfo_synth_file");
  const std::string file = dir + "/not_a_folder";
  std::ofstream(file) << "x";
  ExpectCleanFailure(RunSynth("--output " + file + " --frames 2"), "cannot create folder");
}

}  // namespace
}  // namespace dfo
