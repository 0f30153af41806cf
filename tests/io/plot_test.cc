#include "dfo_io/plot.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "dfo_core/error.h"
#include "dfo_io/image_io.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

Trajectory Circle(int n, double radius) {
  Trajectory t;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    t.Add(i, SE3d(SO3d(), Eigen::Vector3d(radius * std::cos(a), 0.0, radius * std::sin(a))));
  }
  return t;
}

TEST(TrajectoryPlot, WritesPngOfTheRequestedSize) {
  const std::string dir = test::MakeTempDir("plot");
  const Trajectory gt = Circle(100, 10.0);
  const Trajectory est = Circle(100, 10.5);
  const std::vector<double> errors(100, 0.5);
  TrajectoryPlotOptions options;
  options.width = 640;
  options.height = 480;
  options.text_lines = {"ATE rmse 0.5 m"};
  WriteTrajectoryPlot(dir + "/sub/a.png", gt, est, errors, options);
  int w = 0, h = 0;
  ReadImageSize(dir + "/sub/a.png", &w, &h);
  EXPECT_EQ(w, 640);
  EXPECT_EQ(h, 480);
  // Not every pixel is background: something was drawn. Errors are optional; a single pose and
  // a path along y (x-y view chosen) are fine too.
  const ImageU8 img = ReadGray(dir + "/sub/a.png");
  size_t dark = 0;
  for (uint8_t v : img.vector()) dark += v < 128;
  EXPECT_GT(dark, 1000u);
  WriteTrajectoryPlot(dir + "/b.png", gt, Trajectory(), {});
  Trajectory vertical;
  for (int i = 0; i < 10; ++i) vertical.Add(i, SE3d(SO3d(), Eigen::Vector3d(0.1 * i, i, 0.0)));
  WriteTrajectoryPlot(dir + "/c.png", vertical, vertical, {});
  EXPECT_TRUE(std::filesystem::exists(dir + "/c.png"));
}

TEST(TrajectoryPlot, RejectsBadInput) {
  const std::string dir = test::MakeTempDir("plot_bad");
  const Trajectory gt = Circle(10, 1.0);
  EXPECT_THROW(WriteTrajectoryPlot(dir + "/a.png", gt, gt, {1.0, 2.0}), InputError);
  EXPECT_THROW(WriteTrajectoryPlot(dir + "/a.png", Trajectory(), Trajectory(), {}), InputError);
  TrajectoryPlotOptions options;
  options.width = 10;
  EXPECT_THROW(WriteTrajectoryPlot(dir + "/a.png", gt, gt, {}, options), ConfigError);
  EXPECT_THROW(WriteTrajectoryPlot(dir + "/a.unknownext", gt, gt, {}), InputError);
}

}  // namespace
}  // namespace dfo::io
