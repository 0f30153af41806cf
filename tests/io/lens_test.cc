#include "dfo_io/lens.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_io/camera_yaml.h"
#include "dfo_io/dataset.h"
#include "dfo_io/image_io.h"
#include "tests/io/io_test_util.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

namespace fs = std::filesystem;
using test_util::ExpectInputError;
using test_util::WriteText;

// Two frames of the project's synthetic street, pinhole, 416 x 128, about 80 deg wide.
const SyntheticSequence& Street() {
  static const SyntheticSequence* sequence = [] {
    SyntheticOptions options;
    options.num_frames = 6;
    return new SyntheticSequence(options);
  }();
  return *sequence;
}

cv::Mat CameraMatrix(const PinholeCamera& c) {
  return (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
}

cv::Mat Coefficients(const LensDistortion& lens) {
  if (lens.model == LensModel::kEquidistant) {
    return (cv::Mat_<double>(4, 1) << lens.k1, lens.k2, lens.k3, lens.k4);
  }
  return (cv::Mat_<double>(5, 1) << lens.k1, lens.k2, lens.p1, lens.p2, lens.k3);
}

// Distorted pixels of undistorted normalised points (x, y), by OpenCV's forward models.
std::vector<cv::Point2d> Distort(const std::vector<cv::Point2d>& normalised, const PinholeCamera& c,
                                 const LensDistortion& lens) {
  std::vector<cv::Point2d> out;
  if (lens.model == LensModel::kEquidistant) {
    cv::fisheye::distortPoints(normalised, out, CameraMatrix(c), Coefficients(lens));
  } else {
    std::vector<cv::Point3d> rays;
    for (const auto& p : normalised) rays.emplace_back(p.x, p.y, 1.0);
    cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), CameraMatrix(c),
                      Coefficients(lens), out);
  }
  return out;
}

// The picture the lens makes of a pinhole rendering: each distorted pixel takes the pinhole pixel
// of the same ray, found by OpenCV's iterative undistortPoints (run to convergence) and checked
// by distorting it back with the forward model; pixels whose ray leaves the pinhole image or does
// not round-trip to 1e-3 px are 0 and marked invalid in *valid (255 = valid).
ImageU8 DistortImage(const ImageU8& pinhole, const PinholeCamera& c, const LensDistortion& lens,
                     cv::Mat* valid) {
  std::vector<cv::Point2d> distorted;
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) distorted.emplace_back(u, v);
  }
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-14);
  std::vector<cv::Point2d> normalised;
  if (lens.model == LensModel::kEquidistant) {
    cv::fisheye::undistortPoints(distorted, normalised, CameraMatrix(c), Coefficients(lens),
                                 cv::noArray(), cv::noArray(), criteria);
  } else {
    cv::undistortPoints(distorted, normalised, CameraMatrix(c), Coefficients(lens), cv::noArray(),
                        cv::noArray(), criteria);
  }
  const std::vector<cv::Point2d> back = Distort(normalised, c, lens);
  cv::Mat map_x(c.height, c.width, CV_32FC1), map_y(c.height, c.width, CV_32FC1);
  *valid = cv::Mat(c.height, c.width, CV_8UC1, cv::Scalar(0));
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      const size_t i = static_cast<size_t>(v) * c.width + u;
      const double x = c.fx * normalised[i].x + c.cx;
      const double y = c.fy * normalised[i].y + c.cy;
      const bool ok = std::hypot(back[i].x - u, back[i].y - v) < 1e-3 && x >= 0 &&
                      x <= c.width - 1 && y >= 0 && y <= c.height - 1;
      map_x.at<float>(v, u) = ok ? static_cast<float>(x) : -10.0f;
      map_y.at<float>(v, u) = ok ? static_cast<float>(y) : -10.0f;
      valid->at<uint8_t>(v, u) = ok ? 255 : 0;
    }
  }
  const cv::Mat src(pinhole.height(), pinhole.width(), CV_8UC(pinhole.channels()),
                    const_cast<uint8_t*>(pinhole.data()));
  ImageU8 out(c.width, c.height, pinhole.channels());
  cv::Mat dst(c.height, c.width, CV_8UC(pinhole.channels()), out.data());
  cv::remap(src, dst, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  return out;
}

std::string CameraYamlText(const PinholeCamera& c, const std::string& lens_keys) {
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "width: %d\nheight: %d\nfx: %.17g\nfy: %.17g\ncx: %.17g\ncy: %.17g\nfps: 10\n",
                c.width, c.height, c.fx, c.fy, c.cx, c.cy);
  return buf + lens_keys;
}

struct LensCase {
  const char* name;
  LensDistortion lens;
  std::string keys;  // the camera.yaml lines of the lens
};

std::vector<LensCase> Lenses() {
  LensCase radtan{"radtan", {}, ""};
  radtan.lens.model = LensModel::kRadtan;
  radtan.lens.k1 = -0.25;
  radtan.lens.k2 = 0.06;
  radtan.lens.p1 = 0.002;
  radtan.lens.p2 = -0.0015;
  radtan.lens.k3 = -0.01;
  radtan.keys = "model: radtan\nk1: -0.25\nk2: 0.06\np1: 0.002\np2: -0.0015\nk3: -0.01\n";
  LensCase equidistant{"equidistant", {}, ""};
  equidistant.lens.model = LensModel::kEquidistant;
  equidistant.lens.k1 = -0.03;
  equidistant.lens.k2 = 0.012;
  equidistant.lens.k3 = -0.006;
  equidistant.lens.k4 = 0.001;
  equidistant.keys = "model: equidistant\nk1: -0.03\nk2: 0.012\nk3: -0.006\nk4: 0.001\n";
  return {radtan, equidistant};
}

// The output pixels whose distorted position (by the forward model, independent of the maps)
// lies inside the distorted image, 2 px from its border, with valid distorted pixels around it,
// and 2 px inside the pinhole image; also checks the Undistorter's map against that position.
cv::Mat ValidInterior(const PinholeCamera& c, const LensDistortion& lens, const cv::Mat& valid,
                      const Undistorter& undistorter, cv::Mat* forward_x, cv::Mat* forward_y) {
  std::vector<cv::Point2d> normalised;
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      normalised.emplace_back((u - c.cx) / c.fx, (v - c.cy) / c.fy);
    }
  }
  const std::vector<cv::Point2d> d = Distort(normalised, c, lens);
  *forward_x = cv::Mat(c.height, c.width, CV_32FC1);
  *forward_y = cv::Mat(c.height, c.width, CV_32FC1);
  for (int v = 0; v < c.height; ++v) {
    for (int u = 0; u < c.width; ++u) {
      forward_x->at<float>(v, u) = static_cast<float>(d[static_cast<size_t>(v) * c.width + u].x);
      forward_y->at<float>(v, u) = static_cast<float>(d[static_cast<size_t>(v) * c.width + u].y);
    }
  }
  cv::Mat mask(c.height, c.width, CV_8UC1, cv::Scalar(0));
  double worst_map_error = 0.0;
  for (int v = 2; v < c.height - 2; ++v) {
    for (int u = 2; u < c.width - 2; ++u) {
      const cv::Point2d p = d[static_cast<size_t>(v) * c.width + u];
      if (!(p.x >= 2 && p.x <= c.width - 3 && p.y >= 2 && p.y <= c.height - 3)) continue;
      worst_map_error = std::max(
          worst_map_error, (undistorter.SourcePixel(u, v) - Eigen::Vector2d(p.x, p.y)).norm());
      const int x0 = static_cast<int>(std::floor(p.x)), y0 = static_cast<int>(std::floor(p.y));
      if (valid.at<uint8_t>(y0, x0) && valid.at<uint8_t>(y0, x0 + 1) &&
          valid.at<uint8_t>(y0 + 1, x0) && valid.at<uint8_t>(y0 + 1, x0 + 1)) {
        mask.at<uint8_t>(v, u) = 255;
      }
    }
  }
  // The maps are float: a few thousandths of a pixel.
  EXPECT_LT(worst_map_error, 0.01);
  return mask;
}

double MeanAbsDiff(const ImageU8& a, const ImageU8& b, const cv::Mat& mask) {
  double sum = 0.0;
  size_t n = 0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      if (!mask.at<uint8_t>(y, x)) continue;
      for (int ch = 0; ch < a.channels(); ++ch) sum += std::abs(a(x, y, ch) - b(x, y, ch));
      n += a.channels();
    }
  }
  return n == 0 ? 1e9 : sum / n;
}

// Distorted renderings of the street, written as an image folder with the distorted camera,
// come back through OpenSequence as the pinhole renderings. Bound: making the distorted picture
// and undistorting it each interpolate bilinearly, which blurs the street's fine texture by 1.3 to
// 1.7 grey levels on average (measured); no undistortion gives 22 to 28, the radtan tangential
// coefficients swapped about 4 (both checked below). The undistorted frame also equals the
// distorted file resampled at the forward model's positions computed here (measured: 0.0000).
TEST(LensUndistortion, DistortedFolderGivesThePinholeFrames) {
  const PinholeCamera c = Street().camera();
  for (const LensCase& lens_case : Lenses()) {
    for (const bool color : {false, true}) {
      SCOPED_TRACE(std::string(lens_case.name) + (color ? " colour" : " grey"));
      const std::string dir = test::MakeTempDir(std::string("lens_") + lens_case.name);
      std::vector<ImageU8> pinhole;
      cv::Mat valid;
      for (int i : {0, 5}) {
        const SyntheticFrame frame = Street().RenderFrame(i);
        pinhole.push_back(color ? frame.rgb : frame.gray);
        char name[32];
        std::snprintf(name, sizeof(name), "/%06d.png", i);
        WriteImage(dir + name, DistortImage(pinhole.back(), c, lens_case.lens, &valid));
      }
      WriteText(dir + "/camera.yaml", CameraYamlText(c, lens_case.keys));
      DatasetOptions o;
      o.type = "folder";
      o.path = dir;
      o.color = color;
      o.keep_native = true;
      const Sequence seq = OpenSequence(o);
      ASSERT_NE(seq.undistorter(), nullptr);
      EXPECT_EQ(seq.undistorter()->lens().model, lens_case.lens.model);
      EXPECT_EQ(seq.native_camera().fx, c.fx);  // same intrinsics after undistortion
      EXPECT_EQ(seq.native_camera().cy, c.cy);
      // Barrel and fisheye lenses undistorted to the same intrinsics fill the whole image.
      EXPECT_EQ(seq.undistorter()->empty_fraction(), 0.0);
      cv::Mat forward_x, forward_y;
      const cv::Mat mask =
          ValidInterior(c, lens_case.lens, valid, *seq.undistorter(), &forward_x, &forward_y);
      EXPECT_GT(cv::countNonZero(mask), 0.6 * c.width * c.height);
      for (size_t i = 0; i < seq.size(); ++i) {
        const ImageU8 undistorted = seq.LoadImage(i);
        const double mad = MeanAbsDiff(undistorted, pinhole[i], mask);
        const ImageU8 raw =
            color ? ReadRgb(seq.frame(i).image_path) : ReadGray(seq.frame(i).image_path);
        EXPECT_LT(mad, 2.5) << "frame " << i;
        // Without undistortion the frames are far off.
        EXPECT_GT(MeanAbsDiff(raw, pinhole[i], mask), 5.0 * mad) << "frame " << i;
        // The distorted file resampled at the forward model's positions (computed here with
        // cv::projectPoints / cv::fisheye::distortPoints): the same image up to rounding.
        ImageU8 reference(c.width, c.height, raw.channels());
        cv::Mat dst(c.height, c.width, CV_8UC(raw.channels()), reference.data());
        const cv::Mat src(c.height, c.width, CV_8UC(raw.channels()),
                          const_cast<uint8_t*>(raw.data()));
        cv::remap(src, dst, forward_x, forward_y, cv::INTER_LINEAR);
        EXPECT_LT(MeanAbsDiff(undistorted, reference, mask), 0.05) << "frame " << i;
      }
      if (lens_case.lens.model == LensModel::kRadtan) {
        // The tangential coefficients swapped (a p1/p2 mix-up) are measurably worse.
        LensDistortion swapped = lens_case.lens;
        std::swap(swapped.p1, swapped.p2);
        const Undistorter wrong(c, swapped, "test");
        const ImageU8 raw =
            color ? ReadRgb(seq.frame(0).image_path) : ReadGray(seq.frame(0).image_path);
        EXPECT_GT(MeanAbsDiff(wrong.Apply(raw), pinhole[0], mask),
                  1.5 * MeanAbsDiff(seq.LoadImage(0), pinhole[0], mask));
      }
      // Resized output: the undistorted image resized, with the pinhole intrinsics resized.
      o.keep_native = false;
      o.image_width = 208;
      o.image_height = 64;
      const Sequence small = OpenSequence(o);
      EXPECT_EQ(small.LoadImage(1).vector(), Resize(seq.LoadImage(1), 208, 64).vector());
      EXPECT_DOUBLE_EQ(small.camera().fx, c.Resized(208, 64).fx);
    }
  }
}

// Depth maps (TUM) are undistorted with the nearest source pixel: no value is invented.
TEST(LensUndistortion, DepthTakesNearestValues) {
  const PinholeCamera c(60, 60, 31.5, 23.5, 64, 48);
  LensDistortion lens;
  lens.model = LensModel::kRadtan;
  lens.k1 = -0.2;
  const Undistorter u(c, lens, "test");
  ImageF depth(64, 48, 1);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) depth(x, y) = (x / 8 + y / 8) % 3 == 0 ? 0.0f : 1.0f + x / 8;
  }
  const ImageF out = u.ApplyDepth(depth);
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      const float d = out(x, y);
      EXPECT_TRUE(d == 0.0f || d == std::floor(d)) << x << ", " << y << ": " << d;
      const Eigen::Vector2d s = u.SourcePixel(x, y);
      const int sx = static_cast<int>(std::lround(s.x())),
                sy = static_cast<int>(std::lround(s.y()));
      EXPECT_EQ(d, depth(sx, sy)) << x << ", " << y;
    }
  }
}

// radtan with all coefficients 0 (and the old all-zero `distortion` list) changes nothing.
TEST(LensUndistortion, ZeroRadtanIsPinhole) {
  const std::string dir = test::MakeTempDir("lens_zero");
  const ImageU8 image = Street().RenderFrame(0).gray;
  WriteImage(dir + "/000000.png", image);
  WriteText(dir + "/camera.yaml", CameraYamlText(Street().camera(),
                                                 "model: radtan\nk1: 0\nk2: 0\np1: 0\np2: 0\n"
                                                 "distortion: [0, 0, 0, 0, 0]\n"));
  DatasetOptions o;
  o.type = "folder";
  o.path = dir;
  o.keep_native = true;
  const Sequence seq = OpenSequence(o);
  EXPECT_EQ(seq.undistorter(), nullptr);
  EXPECT_EQ(seq.LoadImage(0).vector(), image.vector());
}

TEST(LensUndistortion, MostlyEmptyResultIsRefused) {
  const PinholeCamera c = Street().camera();
  LensDistortion lens;
  lens.model = LensModel::kRadtan;
  lens.k1 = 20.0;  // pincushion far beyond any lens: most output pixels map outside the image
  ExpectInputError([&] { const Undistorter refused(c, lens, "/x/camera.yaml"); },
                   {"/x/camera.yaml", "radtan", "empty", "more than 50 % is refused"});
  const std::string dir = test::MakeTempDir("lens_empty");
  WriteImage(dir + "/000000.png", Street().RenderFrame(0).gray);
  WriteText(dir + "/camera.yaml",
            CameraYamlText(c, "model: radtan\nk1: 20\nk2: 0\np1: 0\np2: 0\n"));
  DatasetOptions o;
  o.type = "folder";
  o.path = dir;
  ExpectInputError([&] { OpenSequence(o); }, {dir + "/camera.yaml", "output image empty"});
  // A moderate pincushion is accepted, with black (0) corners.
  lens.k1 = 0.3;
  const Undistorter moderate(c, lens, "test");
  EXPECT_GT(moderate.empty_fraction(), 0.0);
  EXPECT_LE(moderate.empty_fraction(), 0.5);
  EXPECT_EQ(moderate.Apply(ImageU8(c.width, c.height, 1, 200))(0, 0), 0);
}

// --- camera.yaml lens keys ----------------------------------------------------------------------

TEST(CameraYamlLens, ReadsModelsAndRoundTrips) {
  const std::string dir = test::MakeTempDir("lens_yaml");
  const std::string base = "width: 64\nheight: 48\nfx: 60\nfy: 61\ncx: 31.5\ncy: 23.5\n";
  WriteText(dir + "/r.yaml", base + "model: radtan\nk1: -0.1\nk2: 0.02\np1: 0.001\np2: -0.002\n");
  CameraYaml r = ReadCameraYaml(dir + "/r.yaml");
  EXPECT_EQ(r.lens.model, LensModel::kRadtan);
  EXPECT_EQ(r.lens.k1, -0.1);
  EXPECT_EQ(r.lens.k2, 0.02);
  EXPECT_EQ(r.lens.p1, 0.001);
  EXPECT_EQ(r.lens.p2, -0.002);
  EXPECT_EQ(r.lens.k3, 0.0);  // optional
  r.lens.k3 = 0.005;
  WriteCameraYaml(dir + "/r2.yaml", r);
  const CameraYaml r2 = ReadCameraYaml(dir + "/r2.yaml");
  EXPECT_EQ(r2.lens.model, LensModel::kRadtan);
  EXPECT_EQ(r2.lens.p2, -0.002);
  EXPECT_EQ(r2.lens.k3, 0.005);
  WriteText(dir + "/e.yaml", base + "model: equidistant\nk1: 0.1\nk2: 0.2\nk3: 0.3\nk4: 0.4\n");
  const CameraYaml e = ReadCameraYaml(dir + "/e.yaml");
  EXPECT_EQ(e.lens.model, LensModel::kEquidistant);
  EXPECT_EQ(e.lens.k4, 0.4);
  WriteCameraYaml(dir + "/e2.yaml", e);
  const CameraYaml e2 = ReadCameraYaml(dir + "/e2.yaml");
  EXPECT_EQ(e2.lens.model, LensModel::kEquidistant);
  EXPECT_EQ(e2.lens.k3, 0.3);
  EXPECT_EQ(e2.lens.k4, 0.4);
  WriteText(dir + "/p.yaml", base + "model: pinhole\n");
  EXPECT_EQ(ReadCameraYaml(dir + "/p.yaml").lens.model, LensModel::kPinhole);
}

TEST(CameraYamlLens, ErrorsNameKeyFileAndLine) {
  const std::string dir = test::MakeTempDir("lens_yaml_errors");
  // Lines 1-6 are the intrinsics; the lens keys start on line 7.
  const std::string base = "width: 64\nheight: 48\nfx: 60\nfy: 61\ncx: 31.5\ncy: 23.5\n";
  const auto expect = [&](const std::string& lens, const std::vector<std::string>& needles) {
    WriteText(dir + "/camera.yaml", base + lens);
    SCOPED_TRACE(lens);
    ExpectInputError([&] { ReadCameraYaml(dir + "/camera.yaml"); }, needles);
  };
  const std::string file = dir + "/camera.yaml";
  expect("model: fisheye\n", {file + ":7", "'model'", "'fisheye'", "pinhole, radtan, equidistant"});
  expect("model: radtan\nk1: -0.1\nk2: 0.02\np1: 0.001\n",
         {file + ":7", "'p2' is missing", "k1 k2 p1 p2"});
  expect("model: radtan\nk1: -0.1\nk2: 0.02\np1: 0.001\np2: 0\nk4: 0.1\n",
         {file + ":12", "'k4'", "not a coefficient of lens model 'radtan'"});
  expect("model: equidistant\nk1: 0.1\nk2: 0.2\nk3: 0.3\n", {file + ":7", "'k4' is missing"});
  expect("model: equidistant\nk1: 0.1\nk2: 0.2\nk3: 0.3\nk4: 0.4\np1: 0\n",
         {file + ":12", "'p1'", "equidistant"});
  expect("k1: 0.1\n", {file + ":7", "'k1'", "'pinhole'", "model: radtan"});
  expect("model: radtan\nk1: abc\nk2: 0\np1: 0\np2: 0\n",
         {file + ":8", "'k1'", "expected a number, found 'abc'"});
  expect("model: radtan\nk1: 0\nk2: 0\np1: 0\np2: 0\nk5: 0\n",
         {file + ":12", "unknown camera key 'k5'"});
  expect("distortion: [0.1, 0, 0, 0]\n", {file + ":7", "distortion", "model: radtan"});
}

}  // namespace
}  // namespace dfo::io
