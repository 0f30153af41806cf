#include "dfo_io/dataset.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <thread>

#include "dfo_core/error.h"
#include "dfo_io/camera_yaml.h"
#include "dfo_io/image_io.h"
#include "dfo_io/kitti_dataset.h"
#include "dfo_io/trajectory_io.h"
#include "dfo_io/tum_dataset.h"
#include "tests/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

namespace fs = std::filesystem;
using test_util::ExpectInputError;
using test_util::WriteText;

// A gray test image whose pixels encode the frame index.
ImageU8 Pattern(int width, int height, int index) {
  ImageU8 image(width, height, 1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x)
      image(x, y) = static_cast<uint8_t>((x * 7 + y * 3 + index) % 256);
  }
  return image;
}

std::string ProjectionRow(const std::string& label, double fx, double cx, double cy,
                          double tx = 0.0) {
  char buf[256];
  std::snprintf(buf, sizeof(buf), "%s: %.6e 0 %.6e %.6e 0 %.6e %.6e 0 0 0 1 0\n", label.c_str(), fx,
                cx, fx * tx, fx, cy);
  return buf;
}

// A crafted KITTI sequence: n gray 40x30 images, P0..P3, times 0.1 s apart, poses moving 1 m
// along z per frame. Returns the dataset root.
struct KittiFixture {
  std::string root;
  std::string seq_dir;
  int n = 5;
  int width = 40;
  int height = 30;
};

KittiFixture MakeKitti(const std::string& tag, int n = 5) {
  KittiFixture f;
  f.n = n;
  f.root = test::MakeTempDir(tag);
  f.seq_dir = f.root + "/sequences/07";
  fs::create_directories(f.seq_dir + "/image_0");
  std::string times, poses;
  for (int i = 0; i < n; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.png", i);
    WriteImage(f.seq_dir + "/image_0" + name, Pattern(f.width, f.height, i));
    times += std::to_string(0.1 * i) + "\n";
    poses += "1 0 0 0 0 1 0 0 0 0 1 " + std::to_string(1.0 * i) + "\n";
  }
  WriteText(f.seq_dir + "/times.txt", times);
  WriteText(f.root + "/poses/07.txt", poses);
  WriteText(f.seq_dir + "/calib.txt", ProjectionRow("P0", 50.0, 19.5, 14.5) +
                                          ProjectionRow("P1", 50.0, 19.5, 14.5, -0.54) +
                                          ProjectionRow("P2", 50.0, 19.5, 14.5, 0.06) +
                                          ProjectionRow("P3", 50.0, 19.5, 14.5, -0.48));
  return f;
}

DatasetOptions KittiOptions(const KittiFixture& f) {
  DatasetOptions o;
  o.type = "kitti";
  o.path = f.root;
  o.sequence = "07";
  o.image_width = 20;
  o.image_height = 15;
  return o;
}

// --- Real data ---------------------------------------------------------------------------------

TEST(KittiRealData, Sequence06Extract) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  DatasetOptions o;
  o.type = "kitti";
  o.path = test::SharedDataDir() + "/kitti";
  o.sequence = "06";
  const Sequence seq = OpenSequence(o);
  ASSERT_EQ(seq.size(), 51u);
  EXPECT_EQ(seq.native_camera().width, 1226);
  EXPECT_EQ(seq.native_camera().height, 370);
  EXPECT_DOUBLE_EQ(seq.native_camera().fx, 707.0912);
  EXPECT_DOUBLE_EQ(seq.native_camera().fy, 707.0912);
  EXPECT_DOUBLE_EQ(seq.native_camera().cx, 601.8873);
  EXPECT_DOUBLE_EQ(seq.native_camera().cy, 183.1104);
  const PinholeCamera cam = seq.camera();
  EXPECT_EQ(cam.width, 416);
  EXPECT_EQ(cam.height, 128);
  EXPECT_NEAR(cam.fx, 707.0912 * 416.0 / 1226.0, 1e-9);
  EXPECT_NEAR(cam.fy, 707.0912 * 128.0 / 370.0, 1e-9);
  EXPECT_NEAR(cam.cx, (601.8873 + 0.5) * 416.0 / 1226.0 - 0.5, 1e-9);
  EXPECT_EQ(seq.timestamp_ns(1), SecondsToNs(1.044989e-01));
  ASSERT_TRUE(seq.has_ground_truth());
  EXPECT_FALSE(seq.has_depth());
  const SE3d& first = *seq.frame(0).world_from_cam;
  EXPECT_LT((first.Matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-9);
  EXPECT_NEAR(seq.frame(1).world_from_cam->translation().z(), 1.198998, 1e-6);
  EXPECT_EQ(seq.GroundTruth().size(), 51u);

  const LoadedFrame frame = seq.Load(50);
  EXPECT_EQ(frame.image.width(), 416);
  EXPECT_EQ(frame.image.height(), 128);
  EXPECT_EQ(frame.image.channels(), 1);
  EXPECT_TRUE(frame.depth_m.empty());
  EXPECT_EQ(frame.camera.fx, cam.fx);
  EXPECT_NO_THROW(seq.Validate());
}

TEST(KittiRealData, RangeColourFallbackAndSequenceFolderPath) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  DatasetOptions o;
  o.type = "kitti";
  o.path = test::SharedDataDir() + "/kitti/sequences/06";  // the sequence folder itself
  o.first = 10;
  o.last = 20;
  o.color = true;  // no image_2 in the extract: image_0 replicated to RGB
  o.keep_native = true;
  const Sequence seq = OpenSequence(o);
  ASSERT_EQ(seq.size(), 11u);
  EXPECT_EQ(seq.frame(0).source_index, 10);
  ASSERT_TRUE(seq.has_ground_truth());  // found through ../../poses/06.txt
  const ImageU8 image = seq.LoadImage(0);
  EXPECT_EQ(image.width(), 1226);
  EXPECT_EQ(image.channels(), 3);
  EXPECT_EQ(image(100, 100, 0), image(100, 100, 2));
}

TEST(TumRealData, Fr3CabinetKeyframes) {
  DFO_SKIP_WITHOUT_SHARED_DATA();
  DatasetOptions o;
  o.type = "tum";
  o.path = test::SharedDataDir() + "/tum/fr3_cabinet_keyframes";
  o.color = true;
  o.depth = true;
  const Sequence seq = OpenSequence(o);
  ASSERT_EQ(seq.size(), 58u);
  EXPECT_DOUBLE_EQ(seq.depth_scale(), 5000.0);
  EXPECT_DOUBLE_EQ(seq.native_camera().fx, 535.4);
  EXPECT_DOUBLE_EQ(seq.native_camera().cy, 247.6);
  EXPECT_NEAR(seq.camera().fx, 535.4 * 416.0 / 640.0, 1e-9);
  for (size_t i = 0; i < seq.size(); ++i) {
    EXPECT_TRUE(seq.frame(i).world_from_cam.has_value()) << i;
    EXPECT_FALSE(seq.frame(i).depth_path.empty()) << i;
  }
  // Stamps coincide with groundtruth.txt here: the poses are the file's own.
  const Trajectory gt =
      ReadTumTrajectory(test::SharedDataDir() + "/tum/fr3_cabinet_keyframes/groundtruth.txt");
  ASSERT_EQ(gt.size(), 58u);
  for (size_t i = 0; i < seq.size(); ++i) {
    EXPECT_EQ(seq.timestamp_ns(i), gt[i].timestamp_ns);
    EXPECT_LT((seq.frame(i).world_from_cam->Matrix() - gt[i].world_from_cam.Matrix()).norm(), 1e-9);
  }
  const LoadedFrame frame = seq.Load(3);
  EXPECT_EQ(frame.image.channels(), 3);
  ASSERT_EQ(frame.depth_m.width(), 416);
  ASSERT_EQ(frame.depth_m.height(), 128);
  // Depth in metres: an indoor scene of a few metres; every value is an exact PNG value / 5000
  // (no averaging).
  int valid = 0;
  for (const float d : frame.depth_m.vector()) {
    if (d <= 0) continue;
    ++valid;
    EXPECT_LT(d, 10.0f);
    const double raw = d * 5000.0;
    EXPECT_NEAR(raw, std::round(raw), 1e-2);
  }
  EXPECT_GT(valid, 416 * 128 / 2);
  EXPECT_NO_THROW(seq.Validate());
}

// --- Crafted KITTI -----------------------------------------------------------------------------

TEST(KittiDataset, CraftedSequenceLoads) {
  const KittiFixture f = MakeKitti("kitti_ok");
  const Sequence seq = OpenSequence(KittiOptions(f));
  ASSERT_EQ(seq.size(), 5u);
  EXPECT_EQ(seq.timestamp_ns(3), SecondsToNs(0.3));
  EXPECT_NEAR(seq.frame(4).world_from_cam->translation().z(), 4.0, 1e-12);
  const ImageU8 image = seq.LoadImage(2);
  EXPECT_EQ(image.width(), 20);
  EXPECT_EQ(image.height(), 15);
  const ImageU8 native = seq.LoadNativeImage(2);
  EXPECT_EQ(native(5, 4), Pattern(40, 30, 2)(5, 4));
  EXPECT_NEAR(seq.camera().fx, 25.0, 1e-12);
  EXPECT_NEAR(seq.camera().cx, (19.5 + 0.5) * 0.5 - 0.5, 1e-12);
  EXPECT_NO_THROW(seq.Validate());
}

TEST(KittiDataset, ColourCameraUsesP2AndMovesGroundTruth) {
  const KittiFixture f = MakeKitti("kitti_colour", 3);
  fs::create_directories(f.seq_dir + "/image_2");
  for (int i = 0; i < f.n; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.png", i);
    ImageU8 rgb(f.width, f.height, 3, 0);
    for (int y = 0; y < f.height; ++y) {
      for (int x = 0; x < f.width; ++x) rgb(x, y, 0) = 200;
    }
    WriteImage(f.seq_dir + "/image_2" + name, rgb);
  }
  DatasetOptions o = KittiOptions(f);
  o.color = true;
  const Sequence seq = OpenSequence(o);
  const ImageU8 image = seq.LoadImage(0);
  ASSERT_EQ(image.channels(), 3);
  EXPECT_EQ(image(3, 3, 0), 200);
  EXPECT_EQ(image(3, 3, 1), 0);
  // P2 = K [I | t], t = (0.06, 0, 0): camera 2 sits at x = -0.06 in camera 0's frame.
  EXPECT_NEAR(seq.frame(1).world_from_cam->translation().x(), -0.06, 1e-6);
  EXPECT_NEAR(seq.frame(1).world_from_cam->translation().z(), 1.0, 1e-12);
  // No depth_2, and depth_0 is from another viewpoint: no depth.
  EXPECT_FALSE(seq.has_depth());
}

TEST(KittiDataset, DepthFolderIsReadAsMetres) {
  const KittiFixture f = MakeKitti("kitti_depth", 2);
  for (int i = 0; i < f.n; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.png", i);
    ImageU16 raw(f.width, f.height, 1, static_cast<uint16_t>(256 * 10));  // 10 m
    raw(0, 0) = 0;
    WriteU16(f.seq_dir + "/depth_0" + name, raw);
  }
  DatasetOptions o = KittiOptions(f);
  o.depth = true;
  o.keep_native = true;
  const Sequence seq = OpenSequence(o);
  ASSERT_TRUE(seq.has_depth());
  const LoadedFrame frame = seq.Load(1);
  ASSERT_EQ(frame.depth_m.width(), 40);
  EXPECT_FLOAT_EQ(frame.depth_m(5, 5), 10.0f);
  EXPECT_FLOAT_EQ(frame.depth_m(0, 0), 0.0f);
}

// dataset.depth_dir: maps named after the images, metres x 256, replace the dataset's own.
TEST(DepthDir, MapsNamedAfterTheImagesReplaceTheDatasetsOwn) {
  const KittiFixture f = MakeKitti("kitti_depth_dir", 3);
  const std::string maps = test::MakeTempDir("kitti_depth_dir_maps");
  for (int i = 0; i < f.n; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.png", i);
    WriteU16(f.seq_dir + "/depth_0" + name, ImageU16(f.width, f.height, 1, 256 * 10));
    WriteU16(maps + name, ImageU16(f.width, f.height, 1, static_cast<uint16_t>(256 * (2 + i))));
  }
  DatasetOptions o = KittiOptions(f);
  o.depth = true;
  o.keep_native = true;
  EXPECT_FLOAT_EQ(OpenSequence(o).Load(1).depth_m(5, 5), 10.0f);  // the sequence's depth_0/
  o.depth_dir = maps;
  const Sequence seq = OpenSequence(o);
  ASSERT_TRUE(seq.has_depth());
  EXPECT_EQ(seq.frame(2).depth_path, maps + "/000002.png");
  EXPECT_FLOAT_EQ(seq.Load(1).depth_m(5, 5), 3.0f);
  EXPECT_FLOAT_EQ(seq.Load(2).depth_m(5, 5), 4.0f);

  // A folder dataset (images img_10.png ...) gets them by the images' names too, in metres x 256.
  const std::string root = test::MakeTempDir("folder_depth_dir");
  WriteText(root + "/camera.yaml", "fx: 30\nfy: 31\ncx: 15.5\ncy: 11.5\nwidth: 32\nheight: 24\n");
  const std::string folder_maps = root + "_maps";
  fs::create_directories(folder_maps);
  for (int i = 0; i < 2; ++i) {
    WriteImage(root + "/img_" + std::to_string(10 + i) + ".png", Pattern(32, 24, i));
    WriteU16(folder_maps + "/img_" + std::to_string(10 + i) + ".png", ImageU16(32, 24, 1, 256 * 5));
  }
  DatasetOptions folder;
  folder.type = "folder";
  folder.path = root;
  folder.keep_native = true;
  folder.depth = true;
  folder.depth_dir = folder_maps;
  EXPECT_FLOAT_EQ(OpenSequence(folder).Load(1).depth_m(3, 3), 5.0f);
}

TEST(DepthDir, MissingFolderMissingMapAndVideoAreNamed) {
  const KittiFixture f = MakeKitti("kitti_depth_dir_bad", 3);
  DatasetOptions o = KittiOptions(f);
  o.depth_dir = f.root + "/no_such_maps";
  ExpectInputError([&] { OpenSequence(o); },
                   {"dataset.depth_dir = '" + o.depth_dir + "'", "no such folder"});
  const std::string maps = test::MakeTempDir("kitti_depth_dir_partial");
  WriteU16(maps + "/000000.png", ImageU16(f.width, f.height, 1, 256));
  o.depth_dir = maps;
  ExpectInputError([&] { OpenSequence(o); },
                   {"frame 1", "has no depth map " + maps + "/000001.png", "000001.png"});
  // Frames outside the range used need no map.
  o.last = 0;
  EXPECT_NO_THROW(OpenSequence(o));
  // A map of another size than the images is refused when it is read, naming it.
  WriteU16(maps + "/000000.png", ImageU16(f.width / 2, f.height, 1, 256));
  o.depth = true;
  ExpectInputError([&] { OpenSequence(o).Load(0); },
                   {maps + "/000000.png", "expected the image size 40x30"});
  DatasetOptions video;
  video.type = "video";
  video.path = "/x.mp4";
  video.depth_dir = maps;
  try {
    video.Check();
    FAIL() << "video with depth_dir accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.depth_dir"), std::string::npos) << e.what();
  }
}

TEST(KittiErrors, MissingFolder) {
  DatasetOptions o;
  o.path = "/nonexistent/kitti";
  ExpectInputError([&] { OpenSequence(o); },
                   {"KITTI sequence folder not found", "/nonexistent/kitti/sequences/00"});
}

TEST(KittiErrors, MissingFiles) {
  KittiFixture f = MakeKitti("kitti_no_times");
  fs::remove(f.seq_dir + "/times.txt");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {"times file not found", f.seq_dir + "/times.txt"});
  f = MakeKitti("kitti_no_calib");
  fs::remove(f.seq_dir + "/calib.txt");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {"KITTI calibration file not found", f.seq_dir + "/calib.txt"});
  f = MakeKitti("kitti_no_images");
  fs::remove_all(f.seq_dir + "/image_0");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); }, {"no image folder", "image_0"});
  // Ground truth is optional (KITTI 11-21 have none).
  f = MakeKitti("kitti_no_gt");
  fs::remove(f.root + "/poses/07.txt");
  const Sequence seq = OpenSequence(KittiOptions(f));
  EXPECT_FALSE(seq.has_ground_truth());
  EXPECT_TRUE(seq.GroundTruth().empty());
}

TEST(KittiErrors, CalibWithoutP0) {
  const KittiFixture f = MakeKitti("kitti_nop0");
  WriteText(f.seq_dir + "/calib.txt", ProjectionRow("P1", 50, 19.5, 14.5, -0.54));
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {f.seq_dir + "/calib.txt", "no 'P0:' row"});
}

TEST(KittiErrors, SecondRowOfTheSameLabel) {
  const KittiFixture f = MakeKitti("kitti_two_p0");
  WriteText(f.seq_dir + "/calib.txt", ProjectionRow("P0", 50, 19.5, 14.5) +
                                          ProjectionRow("P1", 50, 19.5, 14.5, -0.54) +
                                          ProjectionRow("P0", 60, 19.5, 14.5));
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {f.seq_dir + "/calib.txt:3", "a second 'P0:' row", "line 1"});
}

TEST(KittiErrors, NonNumericCalib) {
  const KittiFixture f = MakeKitti("kitti_nan");
  WriteText(f.seq_dir + "/calib.txt",
            ProjectionRow("P0", 50, 19.5, 14.5) + "P1: 50 0 19.5 x 0 50 14.5 0 0 0 1 0\n");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {f.seq_dir + "/calib.txt:2", "non-numeric value 'x'", "'P1'"});
  WriteText(f.seq_dir + "/calib.txt", "P0: 1 2 3\n");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {"calib.txt:1", "has 3 numbers, expected 12"});
  WriteText(f.seq_dir + "/calib.txt", "hello world\n");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); }, {"calib.txt:1", "labelled row"});
}

TEST(KittiErrors, WrongCalibration) {
  const KittiFixture f = MakeKitti("kitti_badcalib");
  WriteText(f.seq_dir + "/calib.txt", ProjectionRow("P0", -50, 19.5, 14.5));
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {"calib.txt row P0", "wrong calibration", "fx"});
  WriteText(f.seq_dir + "/calib.txt", ProjectionRow("P0", 50, 400, 14.5));
  ExpectInputError(
      [&] { OpenSequence(KittiOptions(f)); },
      {"calib.txt row P0", "principal point (400, 14.5) lies outside the 40x30 image"});
}

TEST(KittiErrors, TimesCountDiffers) {
  const KittiFixture f = MakeKitti("kitti_times_count");
  WriteText(f.seq_dir + "/times.txt", "0\n0.1\n0.2\n");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {"times.txt", "3 timestamps", "5 images"});
}

TEST(KittiErrors, TimesGoingBackwards) {
  const KittiFixture f = MakeKitti("kitti_times_back");
  WriteText(f.seq_dir + "/times.txt", "0\n0.1\n0.2\n0.15\n0.3\n");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); },
                   {"times.txt:4", "timestamps going backwards"});
  WriteText(f.seq_dir + "/times.txt", "0\n0.1\nabc\n0.15\n0.3\n");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); }, {"times.txt:3", "'abc'"});
}

TEST(KittiErrors, GroundTruthCountDiffers) {
  const KittiFixture f = MakeKitti("kitti_gt_count");
  WriteText(f.root + "/poses/07.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 1\n");
  ExpectInputError([&] { OpenSequence(KittiOptions(f)); }, {"07.txt"});
}

TEST(KittiErrors, ImagesOfDifferentSizes) {
  const KittiFixture f = MakeKitti("kitti_sizes");
  WriteImage(f.seq_dir + "/image_0/000003.png", Pattern(41, 30, 3));
  const Sequence seq = OpenSequence(KittiOptions(f));  // lazy: opening reads only the first
  EXPECT_NO_THROW(seq.LoadImage(2));
  ExpectInputError([&] { seq.LoadImage(3); },
                   {"frame 3", "images of different sizes in one sequence", "000003.png", "41x30",
                    "expected 40x30"});
  ExpectInputError([&] { seq.Validate(); },
                   {"frame 3", "images of different sizes in one sequence", "000003.png"});
}

TEST(KittiErrors, CorruptImageNamesFrame) {
  const KittiFixture f = MakeKitti("kitti_corrupt");
  WriteText(f.seq_dir + "/image_0/000002.png", "this is not a PNG");
  const Sequence seq = OpenSequence(KittiOptions(f));
  ExpectInputError([&] { seq.LoadImage(2); }, {"frame 2", "000002.png", "cannot decode"});
  ExpectInputError([&] { seq.Validate(); }, {"frame 2", "000002.png"});
}

TEST(KittiErrors, FrameRangeOutsideRecording) {
  const KittiFixture f = MakeKitti("kitti_range");
  DatasetOptions o = KittiOptions(f);
  o.first = 7;
  ExpectInputError([&] { OpenSequence(o); }, {"dataset.first = 7", "5 frames"});
  o.first = 1;
  o.last = 3;
  EXPECT_EQ(OpenSequence(o).size(), 3u);
}

TEST(DatasetOptions, CheckNamesFieldValueAndRule) {
  DatasetOptions o;
  o.path = "/x";
  EXPECT_NO_THROW(o.Check());
  o.type = "euroc";
  EXPECT_THROW(o.Check(), ConfigError);
  o.type = "kitti";
  o.first = -2;
  try {
    o.Check();
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.first = -2 violates >= 0"), std::string::npos);
  }
  o.first = 0;
  o.path = "";
  EXPECT_THROW(o.Check(), ConfigError);
}

// --- Crafted TUM -------------------------------------------------------------------------------

// A TUM folder named `name` with three 32x24 colour frames at 0, 1, 2 s (+ base), depth at
// slightly shifted times, and ground truth at 0, 2 s (and 10 s).
std::string MakeTum(const std::string& name, bool with_camera_yaml) {
  const std::string root = test::MakeTempDir("tum") + "/" + name;
  fs::create_directories(root + "/rgb");
  fs::create_directories(root + "/depth");
  std::string rgb = "# color images\n# timestamp filename\n", depth = "# depth\n";
  for (int i = 0; i < 3; ++i) {
    const std::string stamp = std::to_string(100 + i) + ".000000";
    WriteImage(root + "/rgb/" + stamp + ".png", Pattern(32, 24, i));
    rgb += stamp + " rgb/" + stamp + ".png\n";
    const std::string dstamp = std::to_string(100 + i) + ".010000";
    ImageU16 raw(32, 24, 1, 5000);  // 1 m
    WriteU16(root + "/depth/" + dstamp + ".png", raw);
    depth += dstamp + " depth/" + dstamp + ".png\n";
  }
  WriteText(root + "/rgb.txt", rgb);
  WriteText(root + "/depth.txt", depth);
  // gt: at 100 s identity; at 102 s moved 2 m in x and rotated 90 deg about z.
  WriteText(root + "/groundtruth.txt",
            "# ground truth\n100.0 0 0 0 0 0 0 1\n102.0 2 0 0 0 0 0.7071067811865476 "
            "0.7071067811865476\n");
  if (with_camera_yaml) {
    WriteText(root + "/camera.yaml",
              "model: pinhole\nwidth: 32\nheight: 24\nfx: 30\nfy: 30\ncx: 15.5\ncy: 11.5\n"
              "depth_scale: 5000.0\n");
  }
  return root;
}

DatasetOptions TumOptions(const std::string& root) {
  DatasetOptions o;
  o.type = "tum";
  o.path = root;
  o.keep_native = true;
  o.depth = true;
  return o;
}

TEST(TumDataset, InterpolatesGroundTruthAndAssociatesDepth) {
  const std::string root = MakeTum("crafted", true);
  DatasetOptions o = TumOptions(root);
  o.tum_max_gt_gap = 5.0;
  const Sequence seq = OpenSequence(o);
  ASSERT_EQ(seq.size(), 3u);
  for (size_t i = 0; i < 3; ++i) ASSERT_TRUE(seq.frame(i).world_from_cam) << i;
  // Frame 1 at 101 s: halfway, 1 m in x and 45 deg about z.
  const SE3d mid = *seq.frame(1).world_from_cam;
  EXPECT_NEAR(mid.translation().x(), 1.0, 1e-9);
  EXPECT_NEAR(mid.so3().Angle(), M_PI / 4, 1e-9);
  EXPECT_NEAR(mid.so3().Log().z(), M_PI / 4, 1e-9);
  EXPECT_EQ(seq.frame(1).depth_path, root + "/depth/101.010000.png");
  const LoadedFrame frame = seq.Load(1);
  EXPECT_FLOAT_EQ(frame.depth_m(3, 3), 1.0f);
  EXPECT_EQ(frame.image.channels(), 1);
}

TEST(TumDataset, NearestModeAndGaps) {
  const std::string root = MakeTum("crafted", true);
  DatasetOptions o = TumOptions(root);
  o.tum_gt_mode = "nearest";
  Sequence seq = OpenSequence(o);
  EXPECT_TRUE(seq.frame(0).world_from_cam.has_value());
  EXPECT_FALSE(seq.frame(1).world_from_cam.has_value());  // 1 s from the nearest pose
  EXPECT_TRUE(seq.frame(2).world_from_cam.has_value());
  // Interpolate across a 2 s gap is refused with the default max gap (0.1 s): no pose at 101 s.
  o.tum_gt_mode = "interpolate";
  seq = OpenSequence(o);
  EXPECT_FALSE(seq.frame(1).world_from_cam.has_value());
  EXPECT_EQ(seq.GroundTruth().size(), 2u);
  // Depth 10 ms away is refused with a 5 ms limit.
  o.tum_max_depth_diff = 0.005;
  seq = OpenSequence(o);
  EXPECT_FALSE(seq.has_depth());
}

// A camera.yaml with a lens model (in the folder, or named by dataset.camera) undistorts TUM's
// images and, with the nearest source pixel, its depth maps.
TEST(TumDataset, LensModelAndDatasetCamera) {
  const std::string root = MakeTum("crafted", true);
  const std::string lens_yaml = test::MakeTempDir("tum_lens") + "/lens.yaml";
  WriteText(lens_yaml,
            "model: radtan\nwidth: 32\nheight: 24\nfx: 30\nfy: 30\ncx: 15.5\ncy: 11.5\n"
            "depth_scale: 5000.0\nk1: -0.2\nk2: 0\np1: 0\np2: 0\n");
  DatasetOptions o = TumOptions(root);
  o.camera = lens_yaml;
  const Sequence seq = OpenSequence(o);
  ASSERT_NE(seq.undistorter(), nullptr);
  const ImageU8 raw = ReadGray(seq.frame(1).image_path);
  const ImageU8 image = seq.LoadImage(1);
  EXPECT_NE(image.vector(), raw.vector());
  EXPECT_EQ(image.vector(), seq.undistorter()->Apply(raw).vector());
  const ImageF depth = seq.LoadDepth(1);
  for (float d : depth.vector()) EXPECT_TRUE(d == 0.0f || d == 1.0f) << d;  // never blended
  // Without dataset.camera: the folder's pinhole camera.yaml.
  EXPECT_EQ(OpenSequence(TumOptions(root)).undistorter(), nullptr);
  o.camera = root + "/none.yaml";
  ExpectInputError([&] { OpenSequence(o); }, {"camera file not found", root + "/none.yaml"});
}

TEST(TumDataset, AssociationIsGreedyByTimeDifference) {
  // associate.py: a=[0, 10], b=[4, 9] within 6: pairs by increasing |diff|: (10,9)=1, (0,4)=4.
  const auto m = AssociateTumStamps({0, 10}, {4, 9}, 6);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(size_t{0}, size_t{0}));
  EXPECT_EQ(m[1], std::make_pair(size_t{1}, size_t{1}));
  // a=[8, 10], b=[9]: a tie at difference 1, the earlier a wins; the other stays unmatched.
  const auto tie = AssociateTumStamps({8, 10}, {9}, 6);
  ASSERT_EQ(tie.size(), 1u);
  EXPECT_EQ(tie[0].first, 0u);
  // Strictly closer than the limit.
  EXPECT_TRUE(AssociateTumStamps({0}, {6}, 6).empty());
}

TEST(TumDataset, FreiburgDefaultCameraByFolderName) {
  const std::string root = MakeTum("rgbd_dataset_freiburg3_long_office", false);
  // The camera is for 640x480 images: our 32x24 crafted images are refused with a clear message.
  ExpectInputError([&] { OpenSequence(TumOptions(root)); },
                   {"freiburg default", "640x480", "32x24"});
  PinholeCamera cam;
  std::string sensor;
  ASSERT_TRUE(TumDefaultCamera("/data/rgbd_dataset_freiburg1_xyz/", &cam, &sensor));
  EXPECT_EQ(sensor, "fr1");
  EXPECT_DOUBLE_EQ(cam.fx, 517.3);
  ASSERT_TRUE(TumDefaultCamera("/data/fr2_desk", &cam, &sensor));
  EXPECT_EQ(sensor, "fr2");
  EXPECT_DOUBLE_EQ(cam.cx, 325.1);
  EXPECT_FALSE(TumDefaultCamera("/data/my_room", &cam, &sensor));
}

TEST(TumErrors, NoCameraAndNoFreiburgName) {
  const std::string root = MakeTum("my_room", false);
  ExpectInputError([&] { OpenSequence(TumOptions(root)); },
                   {"no camera.yaml", "fr1/fr2/fr3", "camera.yaml"});
}

TEST(TumErrors, RgbTimestampsGoingBackwards) {
  const std::string root = MakeTum("crafted", true);
  WriteText(root + "/rgb.txt",
            "# c\n100.0 rgb/100.000000.png\n102.0 rgb/102.000000.png\n101.0 rgb/101.000000.png\n");
  ExpectInputError([&] { OpenSequence(TumOptions(root)); },
                   {"rgb.txt:4", "timestamps going backwards"});
  WriteText(root + "/rgb.txt", "100.0\n");
  ExpectInputError([&] { OpenSequence(TumOptions(root)); },
                   {"rgb.txt:1", "expected 'timestamp filename'"});
}

TEST(TumErrors, MissingFolderAndMissingImage) {
  ExpectInputError([] { OpenSequence(TumOptions("/nonexistent/tum")); },
                   {"TUM RGB-D sequence folder not found", "/nonexistent/tum"});
  const std::string no_list = MakeTum("crafted", true);
  fs::remove(no_list + "/rgb.txt");
  ExpectInputError([&] { OpenSequence(TumOptions(no_list)); },
                   {"TUM file list not found", no_list + "/rgb.txt"});
  const std::string root = MakeTum("crafted", true);
  fs::remove(root + "/rgb/101.000000.png");
  const Sequence seq = OpenSequence(TumOptions(root));
  ExpectInputError([&] { seq.LoadImage(1); }, {"frame 1", "101.000000.png", "not found"});
}

// --- Image folders and camera.yaml --------------------------------------------------------------

std::string MakeFolder(const std::string& tag, const std::string& camera_yaml, int n = 4) {
  const std::string root = test::MakeTempDir(tag);
  for (int i = 0; i < n; ++i) {
    WriteImage(root + "/img_" + std::to_string(10 + i) + ".png", Pattern(32, 24, i));
  }
  if (!camera_yaml.empty()) WriteText(root + "/camera.yaml", camera_yaml);
  return root;
}

DatasetOptions FolderOptions(const std::string& root) {
  DatasetOptions o;
  o.type = "folder";
  o.path = root;
  o.image_width = 16;
  o.image_height = 12;
  return o;
}

const char kCamera[] = "fx: 30\nfy: 31\ncx: 15.5\ncy: 11.5\nwidth: 32\nheight: 24\n";

TEST(FolderDataset, ImagesSortedWithFpsTimestamps) {
  const std::string root = MakeFolder("folder_fps", std::string(kCamera) + "fps: 20\n");
  const Sequence seq = OpenSequence(FolderOptions(root));
  ASSERT_EQ(seq.size(), 4u);
  EXPECT_EQ(seq.frame(0).image_path, root + "/img_10.png");
  EXPECT_EQ(seq.timestamp_ns(3), SecondsToNs(0.15));
  EXPECT_DOUBLE_EQ(seq.camera().fy, 31.0 * 0.5);
  EXPECT_EQ(seq.LoadImage(1).width(), 16);
  EXPECT_FALSE(seq.has_ground_truth());
}

// dataset.camera given as a pipe is read once: a sequence reloaded at another size comes from
// the one opened (dfo_run switches to a learned model's input size this way).
TEST(FolderDataset, CameraFromAPipeAndAnotherOutputSize) {
  const std::string root = MakeFolder("folder_pipe", "");
  const std::string fifo = root + "/camera_pipe";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  std::thread writer([&] { WriteText(fifo, kCamera); });  // blocks until the reader opens it
  DatasetOptions o = FolderOptions(root);
  o.camera = fifo;
  const Sequence seq = OpenSequence(o);
  writer.join();
  const Sequence larger = seq.WithOutputSize(24, 18);
  EXPECT_EQ(larger.output_width(), 24);
  EXPECT_EQ(larger.output_height(), 18);
  EXPECT_DOUBLE_EQ(larger.camera().fx, 30.0 * 0.75);
  EXPECT_EQ(larger.LoadImage(2).width(), 24);
  EXPECT_EQ(seq.output_width(), 16);  // the original is unchanged
  EXPECT_THROW(seq.WithOutputSize(0, 18), ConfigError);
}

TEST(FolderDataset, TimestampsFile) {
  const std::string root =
      MakeFolder("folder_times", std::string(kCamera) + "timestamps: stamps.txt\n");
  WriteText(root + "/stamps.txt", "5\n5.5\n6\n7\n");
  const Sequence seq = OpenSequence(FolderOptions(root));
  EXPECT_EQ(seq.timestamp_ns(1), SecondsToNs(5.5));
  WriteText(root + "/stamps.txt", "5\n5.5\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); },
                   {"stamps.txt", "2 timestamps", "4 images"});
}

TEST(FolderErrors, CameraYamlProblems) {
  ExpectInputError([] { OpenSequence(FolderOptions(MakeFolder("folder_nocam", ""))); },
                   {"camera file not found", "camera.yaml"});
  std::string root = MakeFolder("folder_typo", std::string(kCamera) + "fsp: 10\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); },
                   {"camera.yaml:7", "unknown camera key 'fsp'", "did you mean 'fps'"});
  root = MakeFolder("folder_nan", "fx: abc\nfy: 31\ncx: 15.5\ncy: 11.5\nwidth: 32\nheight: 24\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); },
                   {"camera.yaml:1", "'fx'", "expected a number, found 'abc'"});
  root = MakeFolder("folder_missing", "fx: 30\nfy: 31\ncx: 15.5\nwidth: 32\nheight: 24\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); }, {"'cy' is missing"});
  root = MakeFolder("folder_pp", "fx: 30\nfy: 31\ncx: 15.5\ncy: -20\nwidth: 32\nheight: 24\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); },
                   {"camera.yaml", "principal point", "outside"});
  root = MakeFolder("folder_size", "fx: 30\nfy: 31\ncx: 15.5\ncy: 11.5\nwidth: 64\nheight: 48\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); }, {"64x48", "32x24"});
  root = MakeFolder("folder_yaml", "fx: [30\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); }, {"camera.yaml", "malformed YAML"});
  root = MakeFolder("folder_dist", std::string(kCamera) + "distortion: [0.1, 0, 0, 0]\n");
  ExpectInputError([&] { OpenSequence(FolderOptions(root)); }, {"camera.yaml:7", "distortion"});
}

TEST(CameraYaml, WriteReadRoundTripAndSharedFormat) {
  const std::string dir = test::MakeTempDir("camera_yaml");
  CameraYaml c;
  c.camera = PinholeCamera(535.4, 539.2, 320.1, 247.6, 640, 480);
  c.depth_scale = 5000.0;
  c.fps = 30.0;
  WriteCameraYaml(dir + "/camera.yaml", c);
  const CameraYaml back = ReadCameraYaml(dir + "/camera.yaml");
  EXPECT_EQ(back.camera.fx, c.camera.fx);
  EXPECT_EQ(back.camera.cy, c.camera.cy);
  EXPECT_EQ(back.camera.width, 640);
  EXPECT_EQ(*back.depth_scale, 5000.0);
  EXPECT_EQ(*back.fps, 30.0);
  if (!test::SharedDataDir().empty()) {
    const CameraYaml tum =
        ReadCameraYaml(test::SharedDataDir() + "/tum/fr3_cabinet_keyframes/camera.yaml");
    EXPECT_EQ(tum.camera.fx, 535.4);
    EXPECT_EQ(*tum.depth_scale, 5000.0);
  }
}

// --- Depth resizing -----------------------------------------------------------------------------

TEST(ResizeDepth, NeverAveragesAndKeepsValidity) {
  // Two surfaces (2 m, 8 m) in a checkerboard with holes (0).
  ImageF depth(64, 48, 1, 0.0f);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      if ((x + y) % 3 == 0) continue;  // hole
      depth(x, y) = ((x / 4 + y / 4) % 2 == 0) ? 2.0f : 8.0f;
    }
  }
  for (const auto& [w, h] :
       std::vector<std::pair<int, int>>{{16, 12}, {21, 13}, {64, 48}, {100, 70}}) {
    const ImageF out = ResizeDepth(depth, w, h);
    ASSERT_EQ(out.width(), w);
    ASSERT_EQ(out.height(), h);
    int valid = 0;
    for (const float d : out.vector()) {
      EXPECT_TRUE(d == 0.0f || d == 2.0f || d == 8.0f) << d;
      valid += d > 0;
    }
    if (w < 64) {
      EXPECT_EQ(valid, w * h) << "every footprint holds a valid pixel";
    }
  }
  // A footprint of only holes stays invalid; a single valid pixel survives alone.
  ImageF sparse(8, 8, 1, 0.0f);
  sparse(1, 1) = 5.0f;
  const ImageF small = ResizeDepth(sparse, 2, 2);
  EXPECT_FLOAT_EQ(small(0, 0), 5.0f);
  EXPECT_FLOAT_EQ(small(1, 0), 0.0f);
  EXPECT_FLOAT_EQ(small(0, 1), 0.0f);
  EXPECT_FLOAT_EQ(small(1, 1), 0.0f);
}

}  // namespace
}  // namespace dfo::io

namespace dfo::io {
namespace {

// dataset.processing_width: the width rounded down to the pyramid's multiple, the height that
// keeps the native aspect ratio rounded to the nearest one (DSO's 616 x 184 for both KITTI frame
// sizes here).
TEST(ProcessingSize, KeepsTheAspectRatioAtMultiplesOfThePyramid) {
  PinholeCamera half_kitti;
  half_kitti.width = 620;
  half_kitti.height = 188;
  EXPECT_EQ(ProcessingSize(half_kitti, 616, 8), std::make_pair(616, 184));
  EXPECT_EQ(ProcessingSize(half_kitti, 620, 8), std::make_pair(616, 184));  // 620 -> 616
  PinholeCamera full_kitti;
  full_kitti.width = 1226;
  full_kitti.height = 370;
  EXPECT_EQ(ProcessingSize(full_kitti, 616, 8), std::make_pair(616, 184));
  PinholeCamera vga;
  vga.width = 640;
  vga.height = 480;
  EXPECT_EQ(ProcessingSize(vga, 640, 8), std::make_pair(640, 480));   // 4:3 is not squashed
  EXPECT_EQ(ProcessingSize(vga, 600, 16), std::make_pair(592, 448));  // 444 -> 448
  EXPECT_EQ(ProcessingSize(vga, 3, 8), std::make_pair(8, 8));         // at least one multiple
  try {
    PinholeCamera tall;
    tall.width = 100;
    tall.height = 1000;
    ProcessingSize(tall, 1000, 8);  // 1000 x 10000
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.processing_width = 1000"), std::string::npos)
        << e.what();
  }
}

TEST(ProcessingSize, OptionsRefuseNegativeWidthsAndKeepNative) {
  DatasetOptions o;
  o.path = "/data";
  o.processing_width = -1;
  EXPECT_THROW(o.Check(), ConfigError);
  o.processing_width = 616;
  o.Check();
  o.keep_native = true;
  try {
    o.Check();
    ADD_FAILURE() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.keep_native"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace dfo::io
