#include "dfo_io/config_schema.h"

namespace dfo::io {
namespace {

ConfigSchema BuildSchema() {
  ConfigSchema s;

  // Defaults mirror DatasetOptions (dfo_io/dataset.h); a test checks that they agree.
  s.AddSection("dataset", "Input sequence: which recording to read and how to load its frames.");
  s.AddString("dataset.type", "kitti",
              "Dataset layout: KITTI odometry, TUM RGB-D or an image folder")
      .OneOf({"kitti", "tum", "folder"});
  s.AddString("dataset.path", "",
              "Dataset root (KITTI: folder holding sequences/ and poses/; TUM: sequence folder; "
              "folder: image folder with camera.yaml)");
  s.AddString("dataset.sequence", "00", "KITTI sequence name (folder under sequences/)");
  s.AddInt("dataset.first", 0, "First frame used (index in the recording)").Min(0);
  s.AddInt("dataset.last", -1, "Last frame used, inclusive; -1 = the recording's last frame")
      .Min(-1);
  s.AddInt("dataset.image_width", 416, "Width of loaded images in pixels (intrinsics rescaled)")
      .GreaterThan(0);
  s.AddInt("dataset.image_height", 128, "Height of loaded images in pixels (intrinsics rescaled)")
      .GreaterThan(0);
  s.AddBool("dataset.keep_native", false,
            "Load images at their native size and ignore image_width/image_height");
  s.AddBool("dataset.color", false, "Load RGB images (KITTI image_2 when present) instead of gray");
  s.AddBool("dataset.depth", false,
            "Load the dataset's ground-truth depth maps with the images (TUM depth/, KITTI "
            "depth_0/), for depth metrics");
  s.AddDouble("dataset.tum_max_depth_diff", 0.02,
              "TUM: max time difference in seconds between an rgb and its depth image "
              "(associate.py)")
      .GreaterThan(0);
  s.AddString("dataset.tum_gt_mode", "interpolate",
              "TUM: ground truth per frame by interpolating the bracketing poses or taking the "
              "nearest")
      .OneOf({"interpolate", "nearest"});
  s.AddDouble("dataset.tum_max_gt_diff", 0.02,
              "TUM: max time difference in seconds to the nearest ground-truth pose")
      .GreaterThan(0);
  s.AddDouble("dataset.tum_max_gt_gap", 0.1,
              "TUM: max spacing in seconds of two ground-truth poses interpolated between")
      .GreaterThan(0);

  // Defaults mirror SyntheticOptions (dfo_core/synthetic/options.h).
  s.AddSection("synth", "Procedural synthetic street sequence (dfo_synth).");
  s.AddInt("synth.seed", 1, "Seed of the world, the drive and the textures").Min(0);
  s.AddInt("synth.frames", 500, "Number of frames").Min(1);
  s.AddInt("synth.width", 416, "Image width in pixels").Min(16).Max(4096);
  s.AddInt("synth.height", 128, "Image height in pixels").Min(16).Max(4096);
  s.AddDouble("synth.fov_deg", 80.0, "Horizontal field of view in degrees")
      .GreaterThan(10)
      .LessThan(150);

  s.AddSection("run", "Running dfo: where results go and how.");
  s.AddString("run.output_dir", "results",
              "Folder for trajectories, metrics and config_effective.yaml (created)");
  s.AddBool("run.deterministic", true,
            "Identical results run to run (fixed seeds, ordered reductions), possibly slower");
  s.AddInt("run.threads", 2, "Worker threads; 0 = all hardware threads").Min(0);
  return s;
}

}  // namespace

const ConfigSchema& DfoSchema() {
  static const ConfigSchema schema = BuildSchema();
  return schema;
}

DatasetOptions DatasetOptionsFromConfig(const Config& config) {
  DatasetOptions o;
  o.type = config.GetString("dataset.type");
  o.path = config.GetString("dataset.path");
  o.sequence = config.GetString("dataset.sequence");
  o.first = config.GetInt("dataset.first");
  o.last = config.GetInt("dataset.last");
  o.image_width = config.GetInt("dataset.image_width");
  o.image_height = config.GetInt("dataset.image_height");
  o.keep_native = config.GetBool("dataset.keep_native");
  o.color = config.GetBool("dataset.color");
  o.depth = config.GetBool("dataset.depth");
  o.tum_max_depth_diff = config.GetDouble("dataset.tum_max_depth_diff");
  o.tum_gt_mode = config.GetString("dataset.tum_gt_mode");
  o.tum_max_gt_diff = config.GetDouble("dataset.tum_max_gt_diff");
  o.tum_max_gt_gap = config.GetDouble("dataset.tum_max_gt_gap");
  if (!o.path.empty()) o.Check();
  return o;
}

}  // namespace dfo::io
