// Line plots of curves (e.g. training losses over iterations) written as PNG with OpenCV.
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

// Moving average of `values` over `window` points (centred; shorter at the ends).
std::vector<double> MovingAverage(const std::vector<double>& values, int window);

}  // namespace dfo::io

#endif  // DFO_IO_CURVE_PLOT_H_
