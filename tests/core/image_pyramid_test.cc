#include "dfo_core/image_pyramid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dfo_core/error.h"

namespace dfo {
namespace {

// Channel c of the test image is linear in the level-0 pixel coordinates.
double Ramp(double u, double v, int c) {
  return (0.25 + c) * u - (0.5 - 0.3 * c) * v + 7.0 * c + 3.0;
}

ImageF RampImage(int width, int height, int channels) {
  ImageF img(width, height, channels);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < channels; ++c) img(x, y, c) = static_cast<float>(Ramp(x, y, c));
    }
  }
  return img;
}

TEST(ImagePyramid, OptionsCheckNamesTheField) {
  ImagePyramidOptions options;
  EXPECT_NO_THROW(options.Check());
  options.num_levels = 0;
  try {
    options.Check();
    FAIL() << "num_levels = 0 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("pyramid.num_levels = 0 violates >= 1"), std::string::npos)
        << e.what();
  }
  options.num_levels = 3;
  options.min_level_size = 0;
  try {
    options.Check();
    FAIL() << "min_level_size = 0 accepted";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("pyramid.min_level_size"), std::string::npos) << e.what();
  }
}

TEST(ImagePyramid, LinearRampStaysTheSameRampInEachLevelsCoordinates) {
  // Odd sizes on purpose: 417 x 131 -> 208 x 65 -> 104 x 32 -> 52 x 16.
  const PinholeCamera cam(350.0, 340.0, 207.3, 64.9, 417, 131);
  const ImageF image = RampImage(cam.width, cam.height, 2);
  const ImagePyramid pyramid(image, cam);
  ASSERT_EQ(pyramid.num_levels(), 4);
  const int expected_w[] = {417, 208, 104, 52};
  const int expected_h[] = {131, 65, 32, 16};
  for (int l = 0; l < pyramid.num_levels(); ++l) {
    const ImageF& level = pyramid.level(l);
    const PinholeCamera& level_cam = pyramid.camera(l);
    EXPECT_EQ(level.width(), expected_w[l]);
    EXPECT_EQ(level.height(), expected_h[l]);
    EXPECT_EQ(level.channels(), 2);
    EXPECT_EQ(level_cam.width, level.width());
    EXPECT_EQ(level_cam.height, level.height());
    const double s = std::ldexp(1.0, l);
    for (int y = 0; y < level.height(); ++y) {
      for (int x = 0; x < level.width(); ++x) {
        // Level pixel x covers level-0 pixels [x 2^l, (x+1) 2^l), centred at (x + 0.5) 2^l - 0.5.
        const double u0 = (x + 0.5) * s - 0.5, v0 = (y + 0.5) * s - 0.5;
        for (int c = 0; c < 2; ++c) ASSERT_NEAR(level(x, y, c), Ramp(u0, v0, c), 2e-3);
      }
    }
    // A 3D point projected with the level's camera lands where the level shows it.
    for (double z : {1.0, 9.0}) {
      for (double fu : {0.2, 0.5, 0.9}) {
        const Eigen::Vector3d p =
            cam.Unproject(Eigen::Vector2d(fu * cam.width, 0.4 * cam.height), z);
        const Eigen::Vector2d u0 = cam.Project(p);
        const Eigen::Vector2d ul = level_cam.Project(p);
        ASSERT_TRUE(level_cam.IsInImage(ul));
        for (int c = 0; c < 2; ++c) {
          EXPECT_NEAR(level.Bilinear(ul.x(), ul.y(), c), Ramp(u0.x(), u0.y(), c), 2e-3);
        }
      }
    }
  }
}

TEST(ImagePyramid, DownsampleHalfAveragesBlocks) {
  ImageF img(3, 2);
  // 1 2 | 9
  // 3 6 | 9   (last odd column dropped)
  img(0, 0) = 1;
  img(1, 0) = 2;
  img(0, 1) = 3;
  img(1, 1) = 6;
  img(2, 0) = img(2, 1) = 9;
  const ImageF half = DownsampleHalf(img);
  ASSERT_EQ(half.width(), 1);
  ASSERT_EQ(half.height(), 1);
  EXPECT_FLOAT_EQ(half(0, 0), 3.0f);
  EXPECT_THROW(DownsampleHalf(ImageF(1, 5)), InputError);
}

TEST(ImagePyramid, GradientsAreExactForRampsAndCentralForQuadratics) {
  const ImageF ramp = RampImage(20, 9, 2);
  const ImageGradients g = ComputeGradients(ramp);
  for (int y = 0; y < ramp.height(); ++y) {
    for (int x = 0; x < ramp.width(); ++x) {
      for (int c = 0; c < 2; ++c) {
        // Borders included: one-sided differences are exact for a linear image.
        ASSERT_NEAR(g.gx(x, y, c), 0.25 + c, 1e-4);
        ASSERT_NEAR(g.gy(x, y, c), -(0.5 - 0.3 * c), 1e-4);
      }
    }
  }
  ImageF quad(12, 7);
  for (int y = 0; y < 7; ++y) {
    for (int x = 0; x < 12; ++x) quad(x, y) = static_cast<float>(x * x + 0.5 * y * y);
  }
  const ImageGradients gq = ComputeGradients(quad);
  EXPECT_FLOAT_EQ(gq.gx(5, 3), 10.0f);   // d(x^2)/dx = 2x
  EXPECT_FLOAT_EQ(gq.gy(5, 3), 3.0f);    // d(0.5 y^2)/dy = y
  EXPECT_FLOAT_EQ(gq.gx(0, 3), 1.0f);    // one-sided at the border: 1 - 0
  EXPECT_FLOAT_EQ(gq.gx(11, 3), 21.0f);  // 121 - 100
  // An axis of size 1 has no derivative.
  const ImageGradients g1 = ComputeGradients(RampImage(5, 1, 1));
  EXPECT_FLOAT_EQ(g1.gy(2, 0), 0.0f);
  EXPECT_NEAR(g1.gx(2, 0), 0.25f, 1e-6);
  const ImageGradients g2 = ComputeGradients(RampImage(1, 4, 2));
  EXPECT_FLOAT_EQ(g2.gx(0, 2, 1), 0.0f);
  EXPECT_NEAR(g2.gy(0, 2, 1), -0.2f, 1e-6);
}

TEST(ImagePyramid, GradientsScaleWithTheLevel) {
  const PinholeCamera cam(300.0, 300.0, 207.5, 63.5, 416, 128);
  const ImagePyramid pyramid(RampImage(416, 128, 1), cam);
  for (int l = 0; l < pyramid.num_levels(); ++l) {
    const ImageGradients g = pyramid.Gradients(l);
    const double s = std::ldexp(1.0, l);
    EXPECT_NEAR(g.gx(10, 5), 0.25 * s, 1e-3);
    EXPECT_NEAR(g.gy(10, 5), -0.5 * s, 1e-3);
  }
}

TEST(ImagePyramid, RejectsBadInputWithClearMessages) {
  const PinholeCamera cam(300.0, 300.0, 207.5, 63.5, 416, 128);
  // Size mismatch between image and camera.
  try {
    ImagePyramid p(ImageF(400, 128), cam);
    FAIL() << "size mismatch accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("400x128"), std::string::npos) << what;
    EXPECT_NE(what.find("416x128"), std::string::npos) << what;
  }
  // Too many levels for the image: 416x128 with min size 8 fits 5 levels (26x8), not 6.
  ImagePyramidOptions options;
  options.num_levels = 6;
  try {
    ImagePyramid p(ImageF(416, 128), cam, options);
    FAIL() << "too many levels accepted";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("too small for 6 levels"), std::string::npos) << what;
    EXPECT_NE(what.find("13x4"), std::string::npos) << what;
    EXPECT_NE(what.find("at most 5 levels"), std::string::npos) << what;
  }
  options.num_levels = 5;
  EXPECT_NO_THROW(ImagePyramid(ImageF(416, 128), cam, options));
  options.num_levels = 0;
  EXPECT_THROW(ImagePyramid(ImageF(416, 128), cam, options), ConfigError);
  EXPECT_THROW(ImagePyramid(ImageF(), cam), InputError);
  // Level access out of range is a broken contract.
  const ImagePyramid pyramid(ImageF(416, 128), cam);
  EXPECT_THROW(pyramid.level(4), InternalError);
  EXPECT_THROW(pyramid.camera(-1), InternalError);
  EXPECT_EQ(ImagePyramid().num_levels(), 0);
  EXPECT_EQ(ImagePyramid::MaxLevels(416, 128, 8), 5);
  EXPECT_EQ(ImagePyramid::MaxLevels(7, 128, 8), 0);
}

}  // namespace
}  // namespace dfo
