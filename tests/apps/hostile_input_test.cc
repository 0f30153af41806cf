// Hostile inputs against the real executables, one class per test: broken image files, image and
// configuration sizes meant to exhaust memory, broken sequence files, sweeps of absurd size,
// depth maps without depth. Each case must end with one clear line naming what and where, a
// non-zero exit status when the result is not valid, every frame before the fault kept, and less
// than 1 GB of memory in any process it started (RUSAGE_CHILDREN; ctest runs each test in its own
// process). Signals, unwritable outputs and a reused folder: tests/apps/dfo_run_test.cc.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "dfo_io/image_io.h"
#include "dfo_io/json.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;
using test::CommandResult;
using test::ReadFile;
using test::RunCommand;

constexpr int kFrames = 12;
constexpr long kMaxChildRssKb = 1024 * 1024;  // 1 GB, the bound for any hostile input

void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream file(path, std::ios::binary | std::ios::trunc);
  file << bytes;
  if (!file) throw std::runtime_error("cannot write " + path);
}

// Peak resident memory of the largest process this test started so far, in kB.
long PeakChildRssKb() {
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  return usage.ru_maxrss;
}

std::string MakeSequence(const std::string& tag) {
  return test::CopyOfSyntheticSequence(DFO_SYNTH_EXE, kFrames, tag);
}

std::string Frame(const std::string& root, const std::string& folder, int index,
                  const std::string& ext = ".png") {
  char name[32];
  std::snprintf(name, sizeof(name), "%06d", index);
  return root + "/sequences/00/" + folder + "/" + name + ext;
}

std::string RunArgs(const std::string& root, const std::string& out) {
  return "--config " + test::SourceDir() + "/configs/demo.yaml --set dataset.path=" + root +
         " --output " + out + " --set run.progress=none";
}

// The run failed with one clear stderr line holding every fragment.
void ExpectClearError(const CommandResult& r, const std::vector<std::string>& fragments) {
  EXPECT_NE(r.status, 0) << r.out;
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "not one line: " << r.err;
  for (const std::string& f : fragments) {
    EXPECT_NE(r.err.find(f), std::string::npos) << r.err << "\n  missing: " << f;
  }
  // Nothing from the libraries (libpng, libjpeg, glog) beside dfo's own line.
  EXPECT_EQ(r.err.find("libpng"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("InitGoogleLogging"), std::string::npos) << r.err;
}

// The run stopped at frame `at`, with frames 0..at-1 in frames.csv and the trajectories.
void ExpectFramesKept(const std::string& out, int at) {
  const io::JsonValue s = io::ParseJson(ReadFile(out + "/summary.json"), out + "/summary.json");
  EXPECT_EQ(s["frames"].AsInt(), at);
  EXPECT_FALSE(s["error"].AsString().empty());
  const std::string csv = ReadFile(out + "/frames.csv");
  EXPECT_EQ(static_cast<int>(std::count(csv.begin(), csv.end(), '\n')), at + 1);
  const std::string kitti = ReadFile(out + "/frontend_kitti.txt");
  EXPECT_EQ(static_cast<int>(std::count(kitti.begin(), kitti.end(), '\n')), at);
}

// --- Image files -----------------------------------------------------------------------------

TEST(HostileImages, TruncatedOrCorruptPngMidSequenceIsNamedAndKeepsTheFramesBefore) {
  struct Case {
    std::string name;
    std::string (*mutate)(const std::string&);
    std::string says;
  };
  const std::vector<Case> cases = {
      {"truncated", [](const std::string& b) { return b.substr(0, b.size() / 2); },
       "truncated PNG"},
      {"crc", [](const std::string& b) {
         std::string c = b;
         c[c.size() / 2] = static_cast<char>(c[c.size() / 2] ^ 0x5A);  // inside IDAT
         return c;
       },
       "CRC mismatch in chunk IDAT"},
      {"empty", [](const std::string&) { return std::string(); }, "the file is empty"},
      {"text", [](const std::string&) { return std::string("not an image at all\n"); },
       "corrupt or not an image"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string root = MakeSequence("hostile_png_" + c.name);
    const std::string bad = Frame(root, "image_0", 5);
    WriteFile(bad, c.mutate(ReadFile(bad)));
    const std::string out = test::MakeTempDir("hostile_png_out_" + c.name);
    const CommandResult r = RunCommand(DFO_RUN_EXE, RunArgs(root, out));
    ExpectClearError(r, {bad, c.says, "frame 5", "stopped after 5 of 12 frames"});
    ExpectFramesKept(out, 5);
  }
}

TEST(HostileImages, TruncatedJpegIsAnErrorNotAGreyFrame) {
  // An image folder of JPEGs with a camera.yaml; frame 7 loses its last third (libjpeg alone
  // would fill it with grey and warn without naming the file).
  const std::string root = MakeSequence("hostile_jpeg_src");
  const std::string folder = test::MakeTempDir("hostile_jpeg");
  for (int i = 0; i < kFrames; ++i) {
    const cv::Mat image = cv::imread(Frame(root, "image_0", i), cv::IMREAD_GRAYSCALE);
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.jpg", i);
    ASSERT_TRUE(cv::imwrite(folder + name, image));
  }
  WriteFile(folder + "/camera.yaml",
            "fx: 247.88\nfy: 247.88\ncx: 207.5\ncy: 63.5\nwidth: 416\nheight: 128\nfps: 10\n");
  const std::string bad = folder + "/000007.jpg";
  const std::string bytes = ReadFile(bad);
  WriteFile(bad, bytes.substr(0, bytes.size() * 2 / 3));
  const std::string out = test::MakeTempDir("hostile_jpeg_out");
  const CommandResult r = RunCommand(
      DFO_RUN_EXE, "--config " + test::SourceDir() +
                       "/configs/demo.yaml --set dataset.type=folder --set dataset.path=" +
                       folder + " --set frontend.depth=learned --set learned.model=" + test::SourceDir() +
                       "/models/default.dfo --set run.progress=none --output " +
                       out);
  ExpectClearError(r, {bad, "truncated JPEG (no end-of-image marker"});
  ExpectFramesKept(out, 7);
}

TEST(HostileImages, ADeclaredHugeImageIsRefusedBeforeItIsDecoded) {
  // A PNG whose header declares 30000 x 30000 16-bit pixels (1.8 GB decoded) with valid CRCs,
  // as a depth map and as an image; and the same size as a JPEG frame header.
  const std::string root = MakeSequence("hostile_huge");
  io::WriteU16(Frame(root, "depth_0", 3), ImageU16(30000, 2, 1));
  std::string png = ReadFile(Frame(root, "depth_0", 3));
  // IHDR's height at bytes 20-23, then the chunk's CRC at 29-32: rewrite both.
  png[20] = 0;
  png[21] = 0;
  png[22] = static_cast<char>(30000 >> 8);
  png[23] = static_cast<char>(30000 & 0xFF);
  uint32_t crc = 0xFFFFFFFFu;
  for (int i = 12; i < 29; ++i) {
    crc ^= static_cast<unsigned char>(png[i]);
    for (int k = 0; k < 8; ++k) crc = (crc & 1) ? 0xEDB88320u ^ (crc >> 1) : crc >> 1;
  }
  crc ^= 0xFFFFFFFFu;
  for (int k = 0; k < 4; ++k) png[29 + k] = static_cast<char>(crc >> (24 - 8 * k));
  WriteFile(Frame(root, "depth_0", 3), png);
  const std::string out = test::MakeTempDir("hostile_huge_out");
  const CommandResult r = RunCommand(DFO_RUN_EXE, RunArgs(root, out));
  ExpectClearError(r, {Frame(root, "depth_0", 3), "declares 30000 x 30000 pixels"});
  ExpectFramesKept(out, 3);
  EXPECT_LT(PeakChildRssKb(), kMaxChildRssKb);
}

// --- Sizes in the configuration --------------------------------------------------------------

TEST(HostileSizes, HugeListsFilesAndSizesAreRefusedByName) {
  const std::string root = MakeSequence("hostile_sizes");
  const std::string dir = test::MakeTempDir("hostile_sizes_cfg");
  const std::string out = dir + "/out";

  // A list of 100000 elements in a 200 kB YAML file: refused by element count, naming the key.
  std::string list = "tracker:\n  max_iterations: [";
  for (int i = 0; i < 100000; ++i) list += i ? ",1" : "1";
  WriteFile(dir + "/list.yaml", list + "]\n");
  CommandResult r = RunCommand(DFO_RUN_EXE, "--config " + dir + "/list.yaml --set dataset.path=" +
                                                root + " --output " + out);
  ExpectClearError(r, {dir + "/list.yaml:2", "tracker.max_iterations", "100000 elements",
                       "at most 64"});

  // A 3 MB configuration file: refused by size before it is parsed.
  WriteFile(dir + "/big.yaml", "# " + std::string(3 << 20, 'x') + "\n");
  r = RunCommand(DFO_RUN_EXE, "--config " + dir + "/big.yaml --output " + out);
  ExpectClearError(r, {dir + "/big.yaml", "bytes; at most 1048576"});

  // An endless device: read up to the cap.
  r = RunCommand(DFO_RUN_EXE, "--config /dev/zero --output " + out);
  ExpectClearError(r, {"/dev/zero", "holds more than 1048576 bytes"});

  // Image sizes that would need gigabytes.
  r = RunCommand(DFO_RUN_EXE, RunArgs(root, out) + " --set dataset.image_width=100000");
  ExpectClearError(r, {"dataset.image_width = 100000 violates", "<= 8192"});
  r = RunCommand(DFO_RUN_EXE, RunArgs(root, out) + " --set window.max_keyframes=1000000");
  ExpectClearError(r, {"window.max_keyframes", "<= 64"});
  EXPECT_LT(PeakChildRssKb(), kMaxChildRssKb);
}

TEST(HostileSizes, ASweepOfAMillionRunsIsRefusedBeforeItIsListed) {
  const std::string dir = test::MakeTempDir("hostile_sweep");
  std::string grid = "grid:\n";
  const char* keys[] = {"tracker.max_points",   "tracker.min_cell_px",  "tracker.min_gradient",
                        "tracker.patch_size",   "keyframe.min_interval", "keyframe.max_interval",
                        "tracker.min_inliers_lost", "window.points_per_keyframe",
                        "reference.max_interval", "tracker.min_inliers_ok"};
  for (const char* key : keys) grid += std::string("  ") + key + ": [1, 3, 5, 7]\n";
  WriteFile(dir + "/sweep.yaml", "output: out\nsequences:\n  - name: a\n    set: {}\n" + grid);
  const CommandResult r = RunCommand(DFO_SWEEP_EXE, dir + "/sweep.yaml --list");
  ExpectClearError(r, {dir + "/sweep.yaml", "1048576 combinations", "at most 100000"});
  EXPECT_LT(PeakChildRssKb(), kMaxChildRssKb);
}

// --- Sequence files ---------------------------------------------------------------------------

TEST(HostileSequence, MissingImagesAndImpossibleTimesAreNamed) {
  std::string root = MakeSequence("hostile_missing");
  fs::remove(Frame(root, "image_0", 4));
  fs::remove(Frame(root, "image_0", 9));
  const std::string out = test::MakeTempDir("hostile_sequence_out");
  CommandResult r = RunCommand(DFO_RUN_EXE, RunArgs(root, out));
  ExpectClearError(r, {"12 timestamps", "10 images", "missing between 000000 and 000011: 000004, "
                                                     "000009"});

  root = MakeSequence("hostile_times");
  std::string times = ReadFile(root + "/sequences/00/times.txt");
  times.replace(0, times.find('\n'), "1e30");
  WriteFile(root + "/sequences/00/times.txt", times);
  r = RunCommand(DFO_RUN_EXE, RunArgs(root, out));
  ExpectClearError(r, {"times.txt:1", "'1e30'", "beyond the range of nanosecond time stamps"});
}

// Entries that are named like a frame or a sequence file but are none: each is named for what it
// is, not counted as a missing frame blamed on times.txt.
TEST(HostileSequence, FoldersAndLinkLoopsNamedLikeFilesAreNamedForWhatTheyAre) {
  const std::string out = test::MakeTempDir("hostile_odd_entries_out");
  std::string root = MakeSequence("hostile_folder_frame");
  fs::remove(Frame(root, "image_0", 3));
  fs::create_directories(Frame(root, "image_0", 3));
  ExpectClearError(RunCommand(DFO_RUN_EXE, RunArgs(root, out)),
                   {Frame(root, "image_0", 3), "is a folder, not an image file"});

  root = MakeSequence("hostile_loop_frame");
  fs::remove(Frame(root, "image_0", 5));
  fs::create_symlink("000005.png", Frame(root, "image_0", 5));  // points at itself
  ExpectClearError(RunCommand(DFO_RUN_EXE, RunArgs(root, out)),
                   {Frame(root, "image_0", 5), "symbolic link that leads to no file"});

  root = MakeSequence("hostile_folder_times");
  fs::remove(root + "/sequences/00/times.txt");
  fs::create_directories(root + "/sequences/00/times.txt");
  ExpectClearError(RunCommand(DFO_RUN_EXE, RunArgs(root, out)),
                   {"times file " + root + "/sequences/00/times.txt is a folder"});
}

// Configuration mistakes are named as the user wrote them: the key as the configuration spells it
// with where the value came from, an integer beyond 64 bits as such, a folder given as a file.
TEST(HostileConfiguration, MessagesNameTheKeyAsWrittenAndTheCause) {
  const std::string root = MakeSequence("hostile_config_messages");
  const std::string out = test::MakeTempDir("hostile_config_messages_out");
  CommandResult r = RunCommand(DFO_RUN_EXE, RunArgs(root, out) + " --set tracker.max_rmse_ok=inf");
  ExpectClearError(r, {"tracker.max_rmse_ok = inf violates", "(--set)"});
  EXPECT_EQ(r.err.find("frontend.tracker"), std::string::npos) << r.err;
  r = RunCommand(DFO_RUN_EXE, RunArgs(root, out) + " --set dataset.last=99999999999999999999");
  ExpectClearError(r, {"dataset.last", "beyond the 64-bit integer range"});
  const std::string folder = test::MakeTempDir("hostile_lcm_folder");
  r = RunCommand(DFO_RUN_EXE, RunArgs(root, out) + " --set lcm.log_path=" + folder);
  ExpectClearError(r, {folder + " (lcm.log_path) is a folder"});
  r = RunCommand(DFO_RUN_EXE, RunArgs(root, out) + " --set lcm.log_path=" + folder + "/no/x.log");
  ExpectClearError(r, {"lcm.log_path", "No such file or directory"});
}

TEST(HostileSequence, DepthMapsWithoutDepthLoseFramesAndSayWhy) {
  const std::string root = MakeSequence("hostile_zero_depth");
  for (int i = 4; i < 8; ++i) io::WriteU16(Frame(root, "depth_0", i), ImageU16(416, 128, 1));
  const std::string out = test::MakeTempDir("hostile_zero_depth_out");
  const CommandResult r = RunCommand(DFO_RUN_EXE, RunArgs(root, out));
  EXPECT_EQ(r.status, 0) << r.err;  // a valid run: the lost frames are reported as lost
  const io::JsonValue s = io::ParseJson(ReadFile(out + "/summary.json"), "summary.json");
  EXPECT_EQ(s["frames"].AsInt(), kFrames);
  const int lost = static_cast<int>(s["frames_lost"].AsInt());
  const io::JsonValue& causes = s["frames_lost_by_cause"];
  EXPECT_EQ(causes["tracking"].AsInt() + causes["no_depth"].AsInt() +
                causes["few_points"].AsInt(),
            lost);
  // Every frame that had to start a reference from an empty depth map is lost for that reason.
  const std::string csv = ReadFile(out + "/frames.csv");
  std::istringstream lines(csv);
  std::string line;
  std::getline(lines, line);
  while (std::getline(lines, line)) {
    const bool no_depth = line.size() >= 9 && line.compare(line.size() - 9, 9, ",no_depth") == 0;
    const bool lost_line = line.find(",lost,") != std::string::npos;
    if (no_depth) {
      EXPECT_TRUE(lost_line) << line;
    }
    if (lost_line) {
      EXPECT_TRUE(no_depth || line.compare(line.size() - 9, 9, ",tracking") == 0) << line;
    }
  }
  if (causes["no_depth"].AsInt() > 0) {
    EXPECT_NE(r.err.find("cannot start a tracking reference"), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace dfo
