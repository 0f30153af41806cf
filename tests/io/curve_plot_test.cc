// Curve plots: a PNG of the requested size is written, bad series and options are named.
#include "dfo_io/curve_plot.h"

#include <gtest/gtest.h>

#include <cmath>

#include "dfo_core/error.h"
#include "dfo_io/image_io.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

TEST(CurvePlotTest, WritesAPngOfTheRequestedSize) {
  const std::string dir = test::MakeTempDir("curve_plot");
  CurveSeries a{"loss", {}, {}}, b{"other", {}, {}};
  for (int i = 1; i <= 200; ++i) {
    a.x.push_back(i);
    a.y.push_back(1.0 / i + 0.01 * std::sin(i));
    b.x.push_back(i);
    b.y.push_back(0.5 + 0.001 * i);
  }
  CurvePlotOptions options;
  options.width = 640;
  options.height = 360;
  options.log_y = true;
  options.smooth_window = 9;
  options.title = "test";
  WriteCurvePlot(dir + "/sub/plot.png", {a, b}, options);
  const ImageU8 image = ReadRgb(dir + "/sub/plot.png");
  EXPECT_EQ(image.width(), 640);
  EXPECT_EQ(image.height(), 360);
  // Something other than white was drawn.
  int coloured = 0;
  for (int y = 0; y < image.height(); ++y) {
    for (int x = 0; x < image.width(); ++x) {
      coloured += image(x, y, 0) != image(x, y, 2);
    }
  }
  EXPECT_GT(coloured, 100);
}

TEST(CurvePlotTest, MovingAverageIsCentredAndShorterAtTheEnds) {
  const std::vector<double> v = {1, 2, 3, 4, 5};
  const std::vector<double> m = MovingAverage(v, 3);
  EXPECT_DOUBLE_EQ(m[0], 1.5);
  EXPECT_DOUBLE_EQ(m[2], 3.0);
  EXPECT_DOUBLE_EQ(m[4], 4.5);
}

TEST(CurvePlotTest, BadInputIsNamed) {
  const std::string dir = test::MakeTempDir("curve_plot_bad");
  EXPECT_THROW(WriteCurvePlot(dir + "/a.png", {{"x", {1, 2}, {1}}}), InputError);
  EXPECT_THROW(WriteCurvePlot(dir + "/a.png", {{"x", {1}, {NAN}}}), InputError);
  CurvePlotOptions options;
  options.width = 10;
  EXPECT_THROW(WriteCurvePlot(dir + "/a.png", {{"x", {1}, {1}}}, options), ConfigError);
}

TEST(CurvePlotTest, ScatterPlotWithFrontAndNotes) {
  const std::string dir = test::MakeTempDir("scatter_plot");
  ScatterSeries a{"synthetic", {10, 20, 30}, {0.3, 0.1, 0.2}, {"#1", "#2", "#3"}, {0, 1}};
  ScatterSeries b{"kitti", {15, 25}, {1.5, 1.7}, {}, {0}};
  ScatterPlotOptions options;
  options.width = 640;
  options.height = 400;
  options.log_y = true;  // less than a decade in view per series: ticks still drawn
  options.notes = {"#1 a", "#2 b", "#3 c"};
  WriteScatterPlot(dir + "/s.png", {a, b}, options);
  const ImageU8 image = ReadRgb(dir + "/s.png");
  EXPECT_EQ(image.width(), 640);
  EXPECT_EQ(image.height(), 400);
  // Bad input is named.
  EXPECT_THROW(WriteScatterPlot(dir + "/b.png", {{"x", {1, 2}, {1}, {}, {}}}), InputError);
  EXPECT_THROW(WriteScatterPlot(dir + "/b.png", {{"x", {1}, {1}, {"a", "b"}, {}}}), InputError);
  EXPECT_THROW(WriteScatterPlot(dir + "/b.png", {{"x", {1}, {1}, {}, {3}}}), InputError);
  EXPECT_THROW(WriteScatterPlot(dir + "/b.png", {{"x", {NAN}, {1}, {}, {}}}), InputError);
  options.notes.assign(30, "note");  // no room left for the plot
  EXPECT_THROW(WriteScatterPlot(dir + "/b.png", {a}, options), ConfigError);
}

}  // namespace
}  // namespace dfo::io
