#include "dfo_io/keyframe_depth_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tests/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

namespace fs = std::filesystem;
using test_util::ExpectInputError;
using test_util::WriteText;

KeyframeDepthFolder Example() {
  KeyframeDepthFolder f;
  f.sequence = "KITTI 03";
  f.image_width = 208;
  f.image_height = 64;
  f.fx = 180.5;
  f.fy = 182.25;
  f.cx = 103.5;
  f.cy = 31.75;
  for (int k = 0; k < 3; ++k) {
    KeyframeDepthEntry kf;
    kf.frame = 10 + 3 * k;
    kf.timestamp_ns = 1000000000LL * kf.frame + 123456;
    kf.world_from_cam =
        SE3d::Exp((Vector6d() << 0.1 * k, -0.2, 1.5 * k, 0.01, 0.02 * k, -0.03).finished());
    kf.image = k == 1 ? "/data/my images/" + std::to_string(kf.frame) + ".png"
                      : "/data/video.mp4#" + std::to_string(kf.frame);
    for (int i = 0; i < 4 * k; ++i) {
      kf.points.push_back({1.5 + i, 2.0 * i, 5.0 + 0.25 * i, 6.0, i, 0.125 * i});
    }
    f.keyframes.push_back(kf);
  }
  return f;
}

TEST(KeyframeDepthIo, WritesAndReadsBackEveryField) {
  const std::string dir = test::MakeTempDir("keyframe_depth_roundtrip") + "/teacher";
  const KeyframeDepthFolder written = Example();
  WriteKeyframeDepthFolder(dir, written);
  EXPECT_TRUE(fs::is_regular_file(dir + "/keyframe_depth.txt"));
  EXPECT_TRUE(fs::is_regular_file(dir + "/points/000013.txt"));
  const KeyframeDepthFolder read = ReadKeyframeDepthFolder(dir);
  EXPECT_EQ(read.sequence, written.sequence);
  EXPECT_EQ(read.image_width, 208);
  EXPECT_EQ(read.image_height, 64);
  EXPECT_EQ(read.fx, written.fx);
  EXPECT_EQ(read.cy, written.cy);
  ASSERT_EQ(read.keyframes.size(), 3u);
  for (size_t k = 0; k < 3; ++k) {
    const KeyframeDepthEntry& a = written.keyframes[k];
    const KeyframeDepthEntry& b = read.keyframes[k];
    EXPECT_EQ(b.frame, a.frame);
    EXPECT_EQ(b.timestamp_ns, a.timestamp_ns);
    EXPECT_EQ(b.image, a.image);  // spaces and '#' survive
    EXPECT_LT((b.world_from_cam.Inverse() * a.world_from_cam).Log().norm(), 1e-12);
    ASSERT_EQ(b.points.size(), a.points.size());
    for (size_t i = 0; i < a.points.size(); ++i) {
      EXPECT_EQ(b.points[i].u, a.points[i].u);
      EXPECT_EQ(b.points[i].v, a.points[i].v);
      EXPECT_EQ(b.points[i].depth_m, a.points[i].depth_m);
      EXPECT_EQ(b.points[i].start_depth_m, a.points[i].start_depth_m);
      EXPECT_EQ(b.points[i].observations, a.points[i].observations);
      EXPECT_EQ(b.points[i].rms_residual, a.points[i].rms_residual);
    }
  }
  // Written again with fewer keyframes: the stale points file goes.
  KeyframeDepthFolder fewer = written;
  fewer.keyframes.pop_back();
  WriteKeyframeDepthFolder(dir, fewer);
  EXPECT_FALSE(fs::exists(dir + "/points/000016.txt"));
  EXPECT_EQ(ReadKeyframeDepthFolder(dir).keyframes.size(), 2u);
}

TEST(KeyframeDepthIo, DamagedFoldersAreRefusedNamingTheFile) {
  const std::string base = test::MakeTempDir("keyframe_depth_bad");
  const auto fresh = [&](const std::string& name) {
    const std::string dir = base + "/" + name;
    WriteKeyframeDepthFolder(dir, Example());
    return dir;
  };
  ExpectInputError([&] { ReadKeyframeDepthFolder(base + "/none"); },
                   {"keyframe depth folder not found", base + "/none"});
  {
    const std::string dir = fresh("missing_points");
    fs::remove(dir + "/points/000016.txt");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"keyframe points file not found", "000016.txt"});
  }
  {
    const std::string dir = fresh("nan_depth");
    WriteText(dir + "/points/000013.txt",
              "1 2 nan 3 1 0.5\n2 2 4 3 1 0.5\n3 2 4 3 1 0.5\n"
              "4 2 4 3 1 0.5\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"000013.txt:1:", "expected a finite value"});
  }
  {
    const std::string dir = fresh("zero_depth");
    WriteText(dir + "/points/000013.txt",
              "1 2 0 3 1 0.5\n2 2 4 3 1 0.5\n3 2 4 3 1 0.5\n"
              "4 2 4 3 1 0.5\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"000013.txt:1:", "expected positive depths"});
  }
  {
    const std::string dir = fresh("outside");
    WriteText(dir + "/points/000013.txt",
              "1 2 4 3 1 0.5\n2 64 4 3 1 0.5\n3 2 4 3 1 0.5\n"
              "4 2 4 3 1 0.5\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"000013.txt:2:", "outside the 208 x 64 image"});
  }
  {
    const std::string dir = fresh("count");
    WriteText(dir + "/points/000013.txt", "1 2 4 3 1 0.5\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"000013.txt", "1 points, keyframes.txt announces 4"});
  }
  {
    const std::string dir = fresh("size");
    WriteText(dir + "/keyframe_depth.txt",
              "format dfo_keyframe_depth 1\nimage_size 0 64\ncamera 1 1 0 0\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"keyframe_depth.txt:2:", "expected positive sides"});
  }
  {
    const std::string dir = fresh("format");
    WriteText(dir + "/keyframe_depth.txt",
              "format dfo_keyframe_depth 2\nimage_size 208 64\ncamera 1 1 0 0\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"keyframe_depth.txt:1:", "expected 'dfo_keyframe_depth 1'"});
  }
  {
    const std::string dir = fresh("order");
    WriteText(dir + "/keyframes.txt", "13 13 0 0 0 0 0 0 1 4 a.png\n10 10 0 0 0 0 0 0 1 0 b.png\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); },
                     {"keyframes.txt:2:", "expected increasing frame numbers"});
  }
  {
    const std::string dir = fresh("short_line");
    WriteText(dir + "/keyframes.txt", "13 13 0 0 0 0 0 0 1 0\n");
    ExpectInputError([&] { ReadKeyframeDepthFolder(dir); }, {"keyframes.txt:1:", "expected 11"});
  }
}

}  // namespace
}  // namespace dfo::io
