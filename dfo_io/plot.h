// Evaluation plots written as PNG files with OpenCV (no display needed).
#ifndef DFO_IO_PLOT_H_
#define DFO_IO_PLOT_H_

#include <string>
#include <vector>

#include "dfo_core/trajectory.h"

namespace dfo::io {

// Options of WriteTrajectoryPlot.
struct TrajectoryPlotOptions {
  int width = 1200;                            // image width in pixels, >= 400
  int height = 900;                            // image height in pixels, >= 300
  std::string title = "Trajectory, top view";  // first line at the top
  // Further lines printed under the title (figures such as "ATE rmse 1.303 m, se3 alignment").
  std::vector<std::string> text_lines;
  // Label of the error colour bar.
  std::string error_label = "ATE [m]";
  // Throws ConfigError naming the field, its value and the rule.
  void Check() const;
};

// Top view of a ground truth and an aligned estimate (both world_from_cam, same world frame).
// The view is the x-z plane (ground plane of the KITTI camera frame: x right, z forward, drawn
// upwards) unless the y extent of the paths exceeds the smaller of the x and z extents, in which
// case the two axes of largest extent are used (e.g. x-y for TUM's z-up motion-capture frame).
// Equal scale on both axes, grid and tick labels in metres, a start marker, the ground truth in
// dark grey and the estimate coloured by `errors` (one per estimate pose, e.g. ATE) with a colour
// bar; with `errors` empty the estimate is drawn in one colour. Creates missing parent folders.
// Throws InputError when errors has another size than the estimate, when both trajectories are
// empty, or when the file cannot be written.
void WriteTrajectoryPlot(const std::string& path, const Trajectory& ground_truth,
                         const Trajectory& estimate, const std::vector<double>& errors,
                         const TrajectoryPlotOptions& options = {});

// One estimate of a multi-trajectory plot.
struct LabelledTrajectory {
  std::string label;      // legend text, e.g. "windowed (Sim3-aligned)"
  Trajectory trajectory;  // world_from_cam, in the ground truth's world frame (aligned)
};

// Top view of a ground truth and several estimates, each in its own colour with a legend entry
// (frontend-only against windowed in dfo_run). Same view, scale, grid and start marker as
// WriteTrajectoryPlot; no error colouring. Up to 6 estimates. Creates missing parent folders.
// Throws InputError when every trajectory is empty, there are more than 6 estimates, or the file
// cannot be written; ConfigError on bad options.
void WriteTrajectoriesPlot(const std::string& path, const Trajectory& ground_truth,
                           const std::vector<LabelledTrajectory>& estimates,
                           const TrajectoryPlotOptions& options = {});

}  // namespace dfo::io

#endif  // DFO_IO_PLOT_H_
