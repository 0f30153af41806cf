#include "dfo_io/video_dataset.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_io/dataset.h"
#include "dfo_io/image_io.h"
#include "dfo_io/lens.h"
#include "dfo_io/video_reader.h"
#include "tests/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

namespace fs = std::filesystem;
using test_util::ExpectInputError;
using test_util::WriteText;

constexpr int kFrames = 10;
constexpr double kFps = 10.0;

// Frames of the project's synthetic street (textured, KITTI-like), rendered once per process.
const SyntheticSequence& Street() {
  static const SyntheticSequence* sequence = [] {
    SyntheticOptions options;
    options.num_frames = kFrames;
    return new SyntheticSequence(options);
  }();
  return *sequence;
}

const std::vector<SyntheticFrame>& StreetFrames() {
  static const std::vector<SyntheticFrame>* frames = [] {
    auto* out = new std::vector<SyntheticFrame>;
    for (int i = 0; i < kFrames; ++i) out->push_back(Street().RenderFrame(i));
    return out;
  }();
  return *frames;
}

// BGR cv::Mat of a grey or RGB dfo image (the VideoWriter's input).
cv::Mat ToBgrOrGray(const ImageU8& image) {
  cv::Mat m(image.height(), image.width(), CV_8UC(image.channels()),
            const_cast<uint8_t*>(image.data()));
  cv::Mat out;
  if (image.channels() == 3) {
    cv::cvtColor(m, out, cv::COLOR_RGB2BGR);
  } else {
    out = m.clone();
  }
  return out;
}

// Writes `frames` as a video at kFps; false when this FFmpeg cannot write the codec.
bool WriteVideo(const std::string& path, const char* fourcc, const std::vector<ImageU8>& frames) {
  const bool color = frames.front().channels() == 3;
  cv::VideoWriter writer(path, cv::CAP_FFMPEG,
                         cv::VideoWriter::fourcc(fourcc[0], fourcc[1], fourcc[2], fourcc[3]), kFps,
                         cv::Size(frames.front().width(), frames.front().height()), color);
  if (!writer.isOpened()) return false;
  for (const ImageU8& f : frames) writer.write(ToBgrOrGray(f));
  writer.release();
  return true;
}

std::string CameraYamlText(const PinholeCamera& c, const std::string& extra = "") {
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "width: %d\nheight: %d\nfx: %.17g\nfy: %.17g\ncx: %.17g\ncy: %.17g\n", c.width,
                c.height, c.fx, c.fy, c.cx, c.cy);
  return buf + extra;
}

// An image folder of the street frames (PNG, grey or RGB) with camera.yaml (fps 10), and the same
// frames as a video in another folder with the same camera.yaml beside it.
struct VideoFixture {
  std::string folder;
  std::string video;
  std::vector<ImageU8> frames;
};

VideoFixture MakeVideoFixture(const std::string& tag, const char* fourcc, const std::string& ext,
                              bool color, const std::string& camera_extra = "fps: 10\n") {
  VideoFixture f;
  const std::string root = test::MakeTempDir(tag);
  f.folder = root + "/frames";
  f.video = root + "/video/street" + ext;
  fs::create_directories(f.folder);
  fs::create_directories(root + "/video");
  for (int i = 0; i < kFrames; ++i) {
    f.frames.push_back(color ? StreetFrames()[i].rgb : StreetFrames()[i].gray);
    char name[32];
    std::snprintf(name, sizeof(name), "/%06d.png", i);
    WriteImage(f.folder + name, f.frames.back());
  }
  const std::string camera = CameraYamlText(Street().camera(), camera_extra);
  WriteText(f.folder + "/camera.yaml", camera);
  WriteText(root + "/video/camera.yaml", camera);
  if (!WriteVideo(f.video, fourcc, f.frames)) f.video.clear();
  return f;
}

DatasetOptions Options(const std::string& type, const std::string& path, bool color) {
  DatasetOptions o;
  o.type = type;
  o.path = path;
  o.color = color;
  o.keep_native = true;
  return o;
}

double MeanAbsDiff(const ImageU8& a, const ImageU8& b) {
  EXPECT_EQ(a.size(), b.size());
  double sum = 0.0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) sum += std::abs(a.data()[i] - b.data()[i]);
  return sum / static_cast<double>(a.size());
}

int MaxAbsDiff(const ImageU8& a, const ImageU8& b) {
  int worst = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) {
    worst = std::max(worst, std::abs(a.data()[i] - b.data()[i]));
  }
  return worst;
}

// --- Lossless video = image folder --------------------------------------------------------------

// FFV1 is lossless: the frames must come back bit for bit, at native size and resized, grey and
// colour, with the folder's fps time stamps (the container's times of a 10 fps video).
TEST(VideoDataset, LosslessFfv1EqualsImageFolder) {
  for (const bool color : {false, true}) {
    SCOPED_TRACE(color ? "colour" : "grey");
    const VideoFixture f =
        MakeVideoFixture(color ? "video_ffv1_rgb" : "video_ffv1_gray", "FFV1", ".mkv", color);
    // FFmpeg is installed with OpenCV's videoio (tools/install_deps.sh): a writer that cannot
    // write FFV1 is a broken installation, not a reason to skip.
    ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
    for (const bool native : {true, false}) {
      DatasetOptions vo = Options("video", f.video, color);
      DatasetOptions fo = Options("folder", f.folder, color);
      vo.keep_native = fo.keep_native = native;
      vo.image_width = fo.image_width = 208;
      vo.image_height = fo.image_height = 64;
      const Sequence video = OpenSequence(vo);
      const Sequence folder = OpenSequence(fo);
      ASSERT_EQ(video.size(), static_cast<size_t>(kFrames));
      ASSERT_EQ(folder.size(), video.size());
      EXPECT_EQ(video.name(), f.video);
      EXPECT_EQ(video.Timestamps(), folder.Timestamps());
      EXPECT_EQ(video.timestamp_ns(7), 700000000);
      EXPECT_EQ(video.camera().fx, folder.camera().fx);
      EXPECT_EQ(video.camera().width, folder.camera().width);
      EXPECT_FALSE(video.has_depth());
      EXPECT_FALSE(video.has_ground_truth());
      for (size_t i = 0; i < video.size(); ++i) {
        const ImageU8 a = video.LoadImage(i);
        const ImageU8 b = folder.LoadImage(i);
        ASSERT_EQ(a.width(), b.width());
        ASSERT_EQ(a.height(), b.height());
        ASSERT_EQ(a.channels(), color ? 3 : 1);
        ASSERT_EQ(a.channels(), b.channels());
        EXPECT_EQ(a.vector(), b.vector()) << "frame " << i << " native " << native;
      }
      EXPECT_NO_THROW(video.Validate());
    }
  }
}

// A colour video read as grey: OpenCV's BGR-to-grey weights, which may differ by 1 from the grey
// values its PNG reader gives for the same colour PNG (documented in video_dataset.h).
TEST(VideoDataset, ColourVideoReadAsGreyIsWithinOneOfTheFolder) {
  const VideoFixture f = MakeVideoFixture("video_ffv1_rgb_as_gray", "FFV1", ".mkv", true);
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  const Sequence video = OpenSequence(Options("video", f.video, false));
  const Sequence folder = OpenSequence(Options("folder", f.folder, false));
  for (size_t i : {0u, 5u}) EXPECT_LE(MaxAbsDiff(video.LoadImage(i), folder.LoadImage(i)), 1);
}

// --- Lossy video --------------------------------------------------------------------------------

// MPEG-4 part 2 (mp4v in .mp4, else XVID in .avi: whichever this FFmpeg writes) at OpenCV's
// default quality. Bound: the mean absolute error of such a video of the synthetic street is 1.4
// to 1.9 grey levels (measured with FFmpeg 5.1; its textures are busier than most real images);
// 4 allows for other encoder versions while still catching a wrong frame (the next frame differs
// by 10 to 16).
TEST(VideoDataset, Mpeg4DecodesCloseToTheSourceFrames) {
  VideoFixture f = MakeVideoFixture("video_mp4v", "mp4v", ".mp4", false);
  if (f.video.empty()) f = MakeVideoFixture("video_xvid", "XVID", ".avi", false);
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg writes neither mp4v (.mp4) nor XVID (.avi)";
  const Sequence video = OpenSequence(Options("video", f.video, false));
  ASSERT_EQ(video.size(), static_cast<size_t>(kFrames));
  for (size_t i = 0; i < video.size(); ++i) {
    const double mad = MeanAbsDiff(video.LoadImage(i), f.frames[i]);
    EXPECT_LT(mad, 4.0) << "frame " << i;
    // Not a neighbouring frame: the street moves by about a metre per frame.
    if (i + 1 < video.size()) {
      EXPECT_GT(MeanAbsDiff(video.LoadImage(i), f.frames[i + 1]), 2 * mad) << "frame " << i;
    }
  }
  EXPECT_EQ(video.timestamp_ns(3), 300000000);
}

// --- Frame selection and access order ------------------------------------------------------------

TEST(VideoDataset, FirstLastStepSelectTheSameFramesAsTheFolder) {
  const VideoFixture f = MakeVideoFixture("video_step", "FFV1", ".mkv", false);
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  for (const std::string type : {"video", "folder"}) {
    SCOPED_TRACE(type);
    DatasetOptions o = Options(type, type == "video" ? f.video : f.folder, false);
    o.first = 2;
    o.last = 9;
    o.step = 3;
    const Sequence seq = OpenSequence(o);
    ASSERT_EQ(seq.size(), 3u);  // frames 2, 5, 8
    for (size_t i = 0; i < seq.size(); ++i) {
      const int source = 2 + 3 * static_cast<int>(i);
      EXPECT_EQ(seq.frame(i).source_index, source);
      EXPECT_EQ(seq.timestamp_ns(i), SecondsToNs(source / kFps));
      EXPECT_EQ(seq.LoadImage(i).vector(), f.frames[source].vector()) << "frame " << source;
    }
    // Open-ended range with a step; a step larger than the range keeps dataset.first alone.
    o.last = -1;
    o.step = 4;
    const Sequence open_ended = OpenSequence(o);
    ASSERT_EQ(open_ended.size(), 2u);  // frames 2, 6
    EXPECT_EQ(open_ended.frame(1).source_index, 6);
    EXPECT_EQ(open_ended.LoadImage(1).vector(), f.frames[6].vector());
    o.step = 100;
    EXPECT_EQ(OpenSequence(o).size(), 1u);
    o.first = 10;
    ExpectInputError([&] { OpenSequence(o); }, {"dataset.first = 10", "10 frames"});
  }
}

// Frame k is the same image whatever the order of the reads; reading in increasing order decodes
// each frame once (no restart from the beginning per frame), going back reopens the file.
TEST(VideoDataset, FramesAreExactInAnyOrderAndSequentialReadingIsLinear) {
  const VideoFixture f = MakeVideoFixture("video_order", "FFV1", ".mkv", true);
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  const Sequence seq = OpenSequence(Options("video", f.video, true));
  ASSERT_NE(seq.video(), nullptr);
  const VideoReader& reader = *seq.video();
  const int64_t decoded_before = reader.decoded_frames();
  const int reopens_before = reader.reopen_count();
  std::vector<ImageU8> in_order;
  for (size_t i = 0; i < seq.size(); ++i) in_order.push_back(seq.LoadImage(i));
  EXPECT_EQ(reader.decoded_frames() - decoded_before, kFrames);
  EXPECT_LE(reader.reopen_count() - reopens_before, 1);  // after the opening scan, if any
  // The same frame again: kept, no decode.
  const int64_t decoded_after_pass = reader.decoded_frames();
  EXPECT_EQ(seq.LoadImage(kFrames - 1).vector(), in_order.back().vector());
  EXPECT_EQ(reader.decoded_frames(), decoded_after_pass);
  // Backwards and skipping around.
  const int reopens_after_pass = reader.reopen_count();
  for (size_t i : {7u, 2u, 3u, 9u, 0u, 0u, 5u}) {
    EXPECT_EQ(seq.LoadImage(i).vector(), in_order[i].vector()) << "frame " << i;
    EXPECT_EQ(seq.LoadImage(i).vector(), f.frames[i].vector()) << "frame " << i;
  }
  EXPECT_EQ(reader.reopen_count() - reopens_after_pass, 3);  // for 7, 2 and the first 0
  // A copy shares the reader and gives the same frames.
  const Sequence copy = seq;
  EXPECT_EQ(copy.LoadImage(4).vector(), in_order[4].vector());
}

// --- Time stamps ---------------------------------------------------------------------------------

TEST(VideoTimestamps, ContainerTimesElseFrameRate) {
  const std::string what = "video x.mp4";
  // Container times increasing: taken as they are (camera.yaml's fps ignored).
  EXPECT_EQ(VideoTimestampsNs({0.0, 33.0, 67.0}, 5.0, 30.0, what),
            (std::vector<int64_t>{0, 33000000, 67000000}));
  // No container times (every frame at 0): i / fps, camera.yaml's before the container's.
  EXPECT_EQ(VideoTimestampsNs({0.0, 0.0, 0.0}, 5.0, 30.0, what),
            (std::vector<int64_t>{0, 200000000, 400000000}));
  EXPECT_EQ(VideoTimestampsNs({0.0, 0.0}, std::nullopt, 25.0, what),
            (std::vector<int64_t>{0, 40000000}));
  // Frames drained from the decoder at the end of an H.264 stream report 0: they continue at the
  // frame interval after the last good time.
  EXPECT_EQ(VideoTimestampsNs({0.0, 100.0, 200.0, 0.0, 0.0}, std::nullopt, 10.0, what),
            (std::vector<int64_t>{0, 100000000, 200000000, 300000000, 400000000}));
  ExpectInputError(
      [&] {
        VideoTimestampsNs({0.0, 0.0}, std::nullopt, 0.0, what);
      },
      {"video x.mp4", "no time for frame 1", "fps"});
}

TEST(VideoTimestamps, ContainerBeforeCameraFpsAndTimestampsFileFirst) {
  // camera.yaml says 5 fps, the container 10: the container's times win.
  const VideoFixture f = MakeVideoFixture("video_fps", "FFV1", ".mkv", false, "fps: 5\n");
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  EXPECT_EQ(OpenSequence(Options("video", f.video, false)).timestamp_ns(2), 200000000);
  // A timestamps file in camera.yaml: one line per frame, used as it is.
  const std::string dir = fs::path(f.video).parent_path().string();
  std::string times;
  for (int i = 0; i < kFrames; ++i) times += std::to_string(1000 + 0.25 * i) + "\n";
  WriteText(dir + "/times.txt", times);
  WriteText(dir + "/camera.yaml", CameraYamlText(Street().camera(), "timestamps: times.txt\n"));
  DatasetOptions o = Options("video", f.video, false);
  o.last = 3;  // the whole video is still counted against the file
  const Sequence seq = OpenSequence(o);
  ASSERT_EQ(seq.size(), 4u);
  EXPECT_EQ(seq.timestamp_ns(3), SecondsToNs(1000.75));
  WriteText(dir + "/times.txt", "1\n2\n");
  ExpectInputError([&] { OpenSequence(o); }, {"times.txt", "2 timestamps", "10 frames"});
}

// --- Camera file and lens ----------------------------------------------------------------------

TEST(VideoDataset, DatasetCameraNamesTheCameraFile) {
  const VideoFixture f = MakeVideoFixture("video_camera_key", "FFV1", ".mkv", false);
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  const std::string other = test::MakeTempDir("video_camera_other") + "/my_camera.yaml";
  PinholeCamera c = Street().camera();
  c.fx *= 1.5;
  WriteText(other, CameraYamlText(c, "fps: 10\n"));
  fs::remove(fs::path(f.video).parent_path() / "camera.yaml");
  DatasetOptions o = Options("video", f.video, false);
  o.camera = other;
  EXPECT_EQ(OpenSequence(o).native_camera().fx, c.fx);
  // Image folders take it too, instead of their own camera.yaml.
  o = Options("folder", f.folder, false);
  o.camera = other;
  EXPECT_EQ(OpenSequence(o).native_camera().fx, c.fx);
}

// A lens model applies to video frames as to image files: the same undistorted frames.
TEST(VideoDataset, LensModelUndistortsVideoFramesAsFolderImages) {
  const VideoFixture f =
      MakeVideoFixture("video_lens", "FFV1", ".mkv", true,
                       "fps: 10\nmodel: equidistant\nk1: -0.02\nk2: 0.01\nk3: -0.004\nk4: 0.001\n");
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  DatasetOptions vo = Options("video", f.video, true);
  DatasetOptions fo = Options("folder", f.folder, true);
  vo.keep_native = fo.keep_native = false;
  const Sequence video = OpenSequence(vo);
  const Sequence folder = OpenSequence(fo);
  ASSERT_NE(video.undistorter(), nullptr);
  for (size_t i : {0u, 6u}) {
    const ImageU8 a = video.LoadImage(i);
    EXPECT_EQ(a.vector(), folder.LoadImage(i).vector()) << "frame " << i;
    EXPECT_GT(MeanAbsDiff(video.LoadNativeImage(i), f.frames[i]), 1.0) << "not undistorted";
  }
}

// --- Errors -------------------------------------------------------------------------------------

TEST(VideoErrors, MissingFileNonVideoAndMissingCamera) {
  const std::string dir = test::MakeTempDir("video_errors");
  ExpectInputError([&] { OpenSequence(Options("video", dir + "/missing.mp4", false)); },
                   {"video file not found", dir + "/missing.mp4"});
  ExpectInputError([&] { OpenSequence(Options("video", dir, false)); }, {dir, "is a folder"});
  WriteText(dir + "/notes.mp4", "this is not a video\n");
  WriteText(dir + "/camera.yaml", CameraYamlText(Street().camera(), "fps: 10\n"));
  ExpectInputError([&] { OpenSequence(Options("video", dir + "/notes.mp4", false)); },
                   {"cannot open video file", dir + "/notes.mp4"});

  const VideoFixture f = MakeVideoFixture("video_no_camera", "FFV1", ".mkv", false);
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  const std::string camera = (fs::path(f.video).parent_path() / "camera.yaml").string();
  fs::remove(camera);
  ExpectInputError([&] { OpenSequence(Options("video", f.video, false)); },
                   {"camera file not found", camera, "dataset.camera"});
  DatasetOptions o = Options("video", f.video, false);
  o.camera = dir + "/nothing.yaml";
  ExpectInputError([&] { OpenSequence(o); }, {"camera file not found", dir + "/nothing.yaml"});
  // A camera of another size than the frames.
  PinholeCamera wrong = Street().camera().Resized(208, 64);
  WriteText(camera, CameraYamlText(wrong, "fps: 10\n"));
  ExpectInputError([&] { OpenSequence(Options("video", f.video, false)); },
                   {camera, "208x64", "416x128", f.video});
  // dataset.camera does not apply to KITTI (calib.txt).
  o = Options("kitti", dir, false);
  o.camera = camera;
  try {
    o.Check();
    ADD_FAILURE() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("dataset.camera"), std::string::npos) << e.what();
  }
}

// A frame the video does not have (here: past its end) names the file and the frame index.
TEST(VideoErrors, FrameThatCannotBeDecodedNamesFileAndIndex) {
  const VideoFixture f = MakeVideoFixture("video_bad_frame", "FFV1", ".mkv", false);
  ASSERT_FALSE(f.video.empty()) << "this OpenCV/FFmpeg cannot write FFV1 to .mkv";
  auto reader = std::make_shared<VideoReader>(f.video);
  std::vector<FrameInfo> frames(2);
  frames[0].image_path = frames[1].image_path = f.video;
  frames[0].video_frame = 1;
  frames[1].video_frame = kFrames + 5;
  frames[1].source_index = 1;
  const Sequence seq(f.video, frames, Street().camera(), 1000.0, Options("video", f.video, false),
                     nullptr, reader);
  EXPECT_EQ(seq.LoadImage(0).vector(), f.frames[1].vector());
  ExpectInputError([&] { seq.LoadImage(1); }, {f.video, "frame " + std::to_string(kFrames + 5),
                                               "cannot decode", "ends after 10 frames"});
  ExpectInputError([&] { seq.Validate(); }, {f.video, "frame 15"});
  // The reader recovers: earlier frames still decode.
  EXPECT_EQ(seq.LoadImage(0).vector(), f.frames[1].vector());
}

// --- Damaged and odd video
// ------------------------------------------------------------------------

constexpr int kLongFrames = 40;

// 40 frames: the street's 10, four times over, grey.
std::vector<ImageU8> LongFrames() {
  std::vector<ImageU8> frames;
  for (int i = 0; i < kLongFrames; ++i) frames.push_back(StreetFrames()[i % kFrames].gray);
  return frames;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// A 40-frame MPEG-4 video with 5,000 bytes overwritten in the middle: every frame the container
// announces is decoded or accounted for (a packet that gives no frame, frames decoded with
// concealed damage), each named in the sequence's warnings; every frame that decoded loads.
TEST(VideoDamage, CorruptBytesAreAccountedForFrameByFrame) {
  const std::string dir = test::MakeTempDir("video_damage");
  const std::string sound = dir + "/street.mp4";
  ASSERT_TRUE(WriteVideo(sound, "mp4v", LongFrames())) << "FFmpeg cannot write MPEG-4";
  WriteText(dir + "/camera.yaml", CameraYamlText(Street().camera(), "fps: 10\n"));
  EXPECT_TRUE(OpenSequence(Options("video", sound, false)).warnings().empty());

  std::string bytes = ReadBytes(sound);
  for (size_t i = 0; i < 5000; ++i) {
    bytes[bytes.size() / 2 + i] = static_cast<char>((i * 7919) & 0xff);
  }
  const std::string damaged = dir + "/damaged.mp4";
  WriteBytes(damaged, bytes);
  VideoReader reader(damaged);
  const VideoIndex index = reader.Scan();
  ASSERT_TRUE(index.complete);
  EXPECT_EQ(index.declared_frames, kLongFrames);
  EXPECT_FALSE(index.declared_estimated);
  EXPECT_FALSE(index.damage.empty());
  EXPECT_EQ(static_cast<int>(index.stamps_ms.size()) + index.undecodable_packets, kLongFrames);
  for (const VideoDamage& d : index.damage) {
    EXPECT_FALSE(d.cause.empty());
    EXPECT_EQ(d.cause.find("0x"), std::string::npos) << "FFmpeg's context pointer: " << d.cause;
  }

  const Sequence seq = OpenSequence(Options("video", damaged, false));
  EXPECT_EQ(seq.size(), index.stamps_ms.size());
  ASSERT_EQ(seq.warnings().size(), index.damage.size());
  for (size_t i = 0; i < index.damage.size(); ++i) {
    const VideoDamage& d = index.damage[i];
    const std::string& w = seq.warnings()[i];
    EXPECT_NE(w.find(damaged), std::string::npos) << w;
    EXPECT_NE(
        w.find(d.frame >= 0 ? "frame " + std::to_string(d.frame) + " " : "no frame came of it"),
        std::string::npos)
        << w;
  }
  for (size_t i = 0; i < seq.size(); ++i) EXPECT_NO_THROW(seq.LoadImage(i)) << "frame " << i;
  // A range that ends before the damage has no warning.
  DatasetOptions o = Options("video", damaged, false);
  o.last = 5;
  EXPECT_TRUE(OpenSequence(o).warnings().empty());
}

// A video cut short: the frames before the cut are read; the container's count (or its duration
// times its frame rate) says how many are missing. An MP4 whose index is gone cannot be opened:
// FFmpeg's reason is in the message.
TEST(VideoDamage, TruncatedVideoSaysHowManyFramesAreMissing) {
  const std::string dir = test::MakeTempDir("video_truncated");
  WriteText(dir + "/camera.yaml", CameraYamlText(Street().camera(), "fps: 10\n"));
  const std::string mkv = dir + "/street.mkv";
  ASSERT_TRUE(WriteVideo(mkv, "FFV1", LongFrames())) << "FFmpeg cannot write FFV1";
  const std::string bytes = ReadBytes(mkv);
  const std::string cut = dir + "/cut.mkv";
  WriteBytes(cut, bytes.substr(0, bytes.size() * 6 / 10));
  const Sequence seq = OpenSequence(Options("video", cut, false));
  EXPECT_GT(seq.size(), 10u);
  EXPECT_LT(seq.size(), static_cast<size_t>(kLongFrames));
  bool counted = false;
  for (const std::string& w : seq.warnings()) {
    if (w.find("announces about 40 frames") != std::string::npos &&
        w.find(std::to_string(seq.size()) + " were decoded") != std::string::npos) {
      counted = true;
    }
  }
  EXPECT_TRUE(counted) << ::testing::PrintToString(seq.warnings());
  for (size_t i = 0; i < seq.size(); ++i) {
    EXPECT_EQ(seq.LoadImage(i).vector(), LongFrames()[i].vector()) << "frame " << i;
  }

  const std::string mp4 = dir + "/street.mp4";
  ASSERT_TRUE(WriteVideo(mp4, "mp4v", LongFrames()));
  const std::string mp4_bytes = ReadBytes(mp4);
  WriteBytes(dir + "/cut.mp4", mp4_bytes.substr(0, mp4_bytes.size() / 2));
  ExpectInputError([&] { OpenSequence(Options("video", dir + "/cut.mp4", false)); },
                   {"cannot open video file", dir + "/cut.mp4", "moov atom not found"});
}

// A stream whose frames change size half-way (two MJPEG streams one after the other): an error
// naming the frame and both sizes, before any frame is processed; the frames before it can be
// selected with dataset.last.
TEST(VideoDamage, AFrameOfAnotherSizeIsAnErrorNamingIt) {
  const std::string dir = test::MakeTempDir("video_sizes");
  WriteText(dir + "/camera.yaml", CameraYamlText(Street().camera(), "fps: 10\n"));
  std::vector<ImageU8> full, half;
  for (int i = 0; i < 5; ++i) {
    const ImageU8& g = StreetFrames()[i].gray;
    full.push_back(g);
    const cv::Mat m(g.height(), g.width(), CV_8UC1, const_cast<uint8_t*>(g.data()));
    cv::Mat small;
    cv::resize(m, small, cv::Size(g.width() / 2, g.height() / 2), 0, 0, cv::INTER_AREA);
    ImageU8 out(small.cols, small.rows, 1);
    std::memcpy(out.data(), small.data, out.size());
    half.push_back(std::move(out));
  }
  ASSERT_TRUE(WriteVideo(dir + "/a.mjpeg", "MJPG", full)) << "FFmpeg cannot write MJPEG";
  ASSERT_TRUE(WriteVideo(dir + "/b.mjpeg", "MJPG", half));
  const std::string both = dir + "/both.mjpeg";
  WriteBytes(both, ReadBytes(dir + "/a.mjpeg") + ReadBytes(dir + "/b.mjpeg"));
  const std::string w = std::to_string(full[0].width()), h = std::to_string(full[0].height());
  const std::string w2 = std::to_string(half[0].width()), h2 = std::to_string(half[0].height());
  ExpectInputError([&] { OpenSequence(Options("video", both, false)); },
                   {both, "frame 5", w2 + " x " + h2, w + " x " + h, "dataset.last: 4"});
  DatasetOptions o = Options("video", both, false);
  o.last = 4;
  const Sequence seq = OpenSequence(o);
  ASSERT_EQ(seq.size(), 5u);
  for (size_t i = 0; i < seq.size(); ++i) EXPECT_NO_THROW(seq.LoadImage(i));
}

}  // namespace
}  // namespace dfo::io
