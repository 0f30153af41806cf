// Line plots of curves (e.g. training losses over iterations) and scatter plots (e.g. accuracy
// against speed with a Pareto front) written as PNG with OpenCV.
#ifndef DFO_IO_CURVE_PLOT_H_
#define DFO_IO_CURVE_PLOT_H_

#include <string>
#include <vector>

namespace dfo::io {

// One curve: points (x[i], y[i]); x and y of equal length. Non-finite points are skipped (and
// points with y <= 0 on a log axis).
struct CurveSeries {
  std::string name;  // legend text
  std::vector<double> x;
  std::vector<double> y;
};

// Options of WriteCurvePlot.
struct CurvePlotOptions {
  int width = 1000;   // image width in pixels, >= 300
  int height = 600;   // image height in pixels, >= 200
  std::string title;  // top line; "" = none
  std::string x_label = "iteration";
  std::string y_label = "loss";
  bool log_y = false;  // logarithmic y axis (decades labelled)
  // Moving-average window (points) applied to every curve before drawing, >= 1 (1 = raw). The
  // raw curve is drawn faintly underneath when > 1.
  int smooth_window = 1;

  // Throws ConfigError naming the field, its value and the rule.
  void Check() const;
};

// Draws every series in its own colour on shared axes (grid, tick labels, legend) and writes the
// PNG to `path`, creating missing parent folders. Throws InputError when a series has x and y of
// different lengths, when no series has a drawable point, or when the file cannot be written.
void WriteCurvePlot(const std::string& path, const std::vector<CurveSeries>& series,
                    const CurvePlotOptions& options = {});

// One set of points of a scatter plot, in one colour.
struct ScatterSeries {
  std::string name;  // legend text
  std::vector<double> x;
  std::vector<double> y;
  // Optional text beside each point (empty, or one per point).
  std::vector<std::string> labels;
  // Indices of points joined by a line in this order and ringed, e.g. the Pareto front.
  std::vector<size_t> front;
};

// Options of WriteScatterPlot.
struct ScatterPlotOptions {
  int width = 1000;   // image width in pixels, >= 300
  int height = 700;   // image height in pixels, >= 200
  std::string title;  // top line; "" = none
  std::string x_label = "x";
  std::string y_label = "y";
  bool log_y = false;  // logarithmic y axis (points with y <= 0 are skipped)
  // Text lines drawn under the x axis (e.g. "#1 translation_ratio=0.05"); the plot area
  // shrinks to make room (17 pixels a line).
  std::vector<std::string> notes;

  // Throws ConfigError naming the field, its value and the rule.
  void Check() const;
};

// Draws every series' points (filled circles, one colour per series, labels beside them) and
// its front (a line through the points and a ring around each) on shared axes with grid, tick
// labels and a legend, and writes the PNG to `path` (parent folders created). Throws InputError
// when labels or y have another length than x, a front index is out of range, no point is
// drawable, or the file cannot be written.
void WriteScatterPlot(const std::string& path, const std::vector<ScatterSeries>& series,
                      const ScatterPlotOptions& options = {});

// Moving average of `values` over `window` points (centred; shorter at the ends).
std::vector<double> MovingAverage(const std::vector<double>& values, int window);

}  // namespace dfo::io

#endif  // DFO_IO_CURVE_PLOT_H_
