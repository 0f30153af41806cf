// Image sequences from disk: KITTI odometry, TUM RGB-D, plain image folders and video files,
// behind one Sequence type.
//
// A Sequence is the list of frames of one recording (timestamp, image file or video frame,
// optional depth file, optional ground-truth pose) plus the native camera. Frames are loaded on
// demand, undistorted when the camera has a lens model (dfo_io/lens.h), then resized to the
// requested resolution (default: the networks' 416 x 128) with the intrinsics rescaled to match
// (PinholeCamera::Resized). Depth maps are resized without ever mixing invalid (0) pixels into
// valid ones (ResizeDepth).
//
// Frame selection, for every type: frames dataset.first, first + step, first + 2 step, ... up to
// dataset.last (inclusive), indices of the full recording (SelectFrameRange).
//
// Layouts (see also the per-format headers):
//  - kitti:  <path>/sequences/<seq>/{image_0|image_2}/NNNNNN.png, calib.txt (rows "P0:".."P3:",
//            12 numbers each), times.txt (seconds), optional depth_0/ (16-bit PNG, metres = v/256),
//            optional <path>/poses/<seq>.txt (ground truth; KITTI sequences 11-21 have none).
//            `path` may also name the sequence folder itself (the one holding calib.txt).
//  - tum:    <path>/rgb.txt, depth.txt, groundtruth.txt ('#' comments), rgb/ depth/ images,
//            optional camera.yaml; depth scale 5000 (see tum_dataset.h).
//  - folder: <path>/camera.yaml plus image files sorted by name (see folder_dataset.h).
//  - video:  <path> is a video file, its camera.yaml beside it (see video_dataset.h).
// dataset.depth_dir, when set, names a folder of depth maps (<image stem>.png, metres x 256) that
// replaces the dataset's own (kitti, tum, folder).
// dataset.camera, when set, names the camera.yaml of a folder, TUM sequence or video instead.
//
// Every error about the data is a dfo::InputError naming the file and the line or frame index.
#ifndef DFO_IO_DATASET_H_
#define DFO_IO_DATASET_H_

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"
#include "dfo_core/lie.h"
#include "dfo_core/trajectory.h"

namespace dfo::io {

class Undistorter;  // dfo_io/lens.h
class VideoReader;  // dfo_io/video_reader.h

// 16-bit depth maps of KITTI's depth_N/ folders (dfo_synth writes them so) and of
// DatasetOptions::depth_dir (dfo_eval stereo-depth, dfo_train --write-depth): metres =
// value / kDepthFolderScale.
constexpr double kDepthFolderScale = 256.0;

// What to open and how to load it. Mirrors the `dataset` section of the configuration
// (DatasetOptionsFromConfig in dfo_io/config_schema.h).
struct DatasetOptions {
  std::string type = "kitti";   // kitti | tum | folder | video
  std::string path;             // dataset root or video file (see the layouts above); must be set
  std::string camera;           // camera.yaml of folder, tum and video; "" = the default place
                                // (<path>/camera.yaml; video: camera.yaml beside the file); must
                                // be "" for kitti (calib.txt)
  std::string sequence = "00";  // KITTI sequence name (folder under sequences/); unused otherwise
  int first = 0;                // first frame used (index in the full recording), >= 0
  int last = -1;                // last frame used, inclusive; -1 = the recording's last frame
  int step = 1;                 // take every step-th frame from first on, >= 1
  int image_width = 416;        // width of loaded images in pixels, > 0 (unless keep_native)
  int image_height = 128;       // height of loaded images in pixels, > 0 (unless keep_native)
  bool keep_native = false;     // true: load images at their native size, ignore width/height
  // > 0: the processing width; the application replaces image_width/image_height with
  // ProcessingSize(native camera, processing_width, its pyramid's multiple) once the recording
  // is open (the native size is known only then). 0 = off; >= 0, not with keep_native.
  int processing_width = 0;
  bool color = false;  // true: RGB images (KITTI image_2 when present); false: gray
  bool depth = false;  // true: load ground-truth depth maps with the images, if any
  // "" = the dataset's own depth maps (KITTI depth_N/, TUM depth/). Otherwise a folder of depth
  // maps named after the images (<image file stem>.png, 16-bit, metres x 256, 0 = none: what
  // `dfo_eval stereo-depth` and `dfo_train --write-depth` write), aligned with the images as
  // stored and of their size, used instead; every selected frame needs one. Not for video.
  std::string depth_dir;

  // TUM RGB-D association (seconds), see tum_dataset.h.
  double tum_max_depth_diff = 0.02;         // rgb <-> depth, as TUM's associate.py (0.02 s)
  std::string tum_gt_mode = "interpolate";  // interpolate | nearest
  double tum_max_gt_diff = 0.02;            // nearest mode (and fallback): max |t_gt - t_frame|
  double tum_max_gt_gap = 0.1;  // interpolate mode: max spacing of the two bracketing gt poses

  // Throws dfo::ConfigError naming the field, its value and the rule ("dataset.first = -2
  // violates >= 0").
  void Check() const;
};

// The frame size for a processing width: `width` rounded down to a multiple of `multiple` (at
// least `multiple`), and the height that keeps the native aspect ratio at that width, rounded to
// the nearest multiple (KITTI's 620 x 188 and 1226 x 370 frames at width 616 or 620, multiple 8:
// 616 x 184).
// `multiple` is 2^(levels - 1) for a pyramid whose levels must halve exactly; >= 1. Throws
// ConfigError naming dataset.processing_width when the result exceeds 8192 pixels a side.
std::pair<int, int> ProcessingSize(const PinholeCamera& native, int width, int multiple);

// One frame of a sequence, as listed by the dataset (nothing loaded).
struct FrameInfo {
  int64_t timestamp_ns = 0;
  std::string image_path;  // image file, or the video file when video_frame >= 0
  int video_frame = -1;    // frame number in the video file image_path; -1: an image file
  std::string depth_path;  // "" when this frame has no depth map
  int source_index = 0;    // index in the full recording (before first/last/step), for messages
  std::optional<SE3d> world_from_cam;  // ground-truth pose of this camera, when known
};

// A frame loaded at the output resolution.
struct LoadedFrame {
  int index = 0;  // index within the sequence
  int64_t timestamp_ns = 0;
  ImageU8 image;         // 1 channel (gray) or 3 channels (RGB), output resolution
  ImageF depth_m;        // depth in metres at output resolution, 0 = invalid; empty when not loaded
  PinholeCamera camera;  // intrinsics matching `image`
  std::optional<SE3d> world_from_cam;  // ground truth, when known
};

// A recording: its frames, camera and loading options. Build it with OpenSequence (or the
// per-format Open*Sequence functions); the constructor is for readers and tests. Copies share the
// video reader (thread-safe) and the undistortion maps.
class Sequence {
 public:
  // `native_camera` describes the images on disk (for a lens with distortion: its fx, fy, cx, cy
  // and size, which the undistorted images keep); `depth_scale` converts 16-bit depth PNG values
  // to metres (metres = value / depth_scale). `frames` must be non-empty. `undistorter` (nullptr:
  // none) undistorts every image and depth map before resizing; it must be for native_camera.
  // `video` (nullptr: none) decodes the frames whose video_frame >= 0.
  Sequence(std::string name, std::vector<FrameInfo> frames, PinholeCamera native_camera,
           double depth_scale, DatasetOptions options,
           std::shared_ptr<const Undistorter> undistorter = nullptr,
           std::shared_ptr<VideoReader> video = nullptr);

  // Human-readable name used in messages, e.g. "KITTI 06" or the folder path.
  const std::string& name() const { return name_; }
  size_t size() const { return frames_.size(); }
  const FrameInfo& frame(size_t i) const;
  const std::vector<FrameInfo>& frames() const { return frames_; }
  int64_t timestamp_ns(size_t i) const { return frame(i).timestamp_ns; }

  // Intrinsics of the images at native size (after undistortion, when the lens has a model).
  const PinholeCamera& native_camera() const { return native_camera_; }
  // The lens undistortion applied to every frame; nullptr for rectified (pinhole) images.
  const Undistorter* undistorter() const { return undistorter_.get(); }
  // The video the frames are decoded from; nullptr for image files.
  const VideoReader* video() const { return video_.get(); }
  // Intrinsics of loaded images (native camera resized to the output resolution).
  PinholeCamera camera() const;
  // Output resolution (native size when keep_native).
  int output_width() const;
  int output_height() const;

  double depth_scale() const { return depth_scale_; }
  // Whether any frame has a depth map / a ground-truth pose.
  bool has_depth() const;
  bool has_ground_truth() const;
  // Ground-truth poses of the frames that have one, stamped with the frames' timestamps.
  Trajectory GroundTruth() const;
  // All timestamps, in frame order.
  std::vector<int64_t> Timestamps() const;

  // Image of frame i at the output resolution (gray or RGB by options().color), undistorted.
  // Throws InputError naming the frame and file (and the video frame) when the image is missing,
  // corrupt or of a size other than the native one ("images of different sizes in one
  // sequence"). Video frames read in increasing order cost one decode each (video_reader.h).
  ImageU8 LoadImage(size_t i) const;
  // Image at native resolution, undistorted (same checks).
  ImageU8 LoadNativeImage(size_t i) const;
  // Depth of frame i in metres at the output resolution (0 = invalid); empty image when the
  // frame has no depth map. Throws InputError as LoadImage.
  ImageF LoadDepth(size_t i) const;
  // Image, ground truth and (when options().depth) depth of frame i at the output resolution.
  LoadedFrame Load(size_t i) const;

  // Reads every image (and depth map) once: all must exist, decode and have the native size
  // (video frames are decoded). Throws InputError on the first offending frame.
  void Validate() const;

  const DatasetOptions& options() const { return options_; }

  // What opening the recording found that does not stop it, one line each naming the file and the
  // frame: video frames decoded with concealed damage (processed as decoded), frames the container
  // announces that gave no image (missing from frames()). Empty for a sound recording.
  const std::vector<std::string>& warnings() const { return warnings_; }
  void set_warnings(std::vector<std::string> warnings) { warnings_ = std::move(warnings); }

  // The same recording loaded at another output size: options().image_width/height replaced
  // (ConfigError, as OpenSequence, when they break DatasetOptions' rules; keep_native stays as
  // it is). Nothing is read again, so a camera file given as a pipe (--set
  // dataset.camera=<(...)) serves both.
  Sequence WithOutputSize(int width, int height) const;

  // The same recording with its depth maps taken from `folder` (DatasetOptions::depth_dir):
  // each frame's map is <folder>/<image file stem>.png, metres x 256. Throws InputError naming
  // dataset.depth_dir when the folder is missing or a frame has no map there (the first such
  // frame and file), ConfigError for frames decoded from a video.
  Sequence WithDepthFolder(const std::string& folder) const;

 private:
  std::string FramePrefix(size_t i) const;

  std::string name_;
  std::vector<FrameInfo> frames_;
  PinholeCamera native_camera_;
  double depth_scale_ = 1.0;
  DatasetOptions options_;
  std::shared_ptr<const Undistorter> undistorter_;
  std::shared_ptr<VideoReader> video_;
  std::vector<std::string> warnings_;
};

// Opens the sequence described by `options` (checked first): dispatches on options.type.
Sequence OpenSequence(const DatasetOptions& options);

// Resizes a depth map (metres, 0 = invalid) without averaging: each output pixel takes the source
// pixel under its centre; when that one is invalid, the valid source pixel nearest to the centre
// within the output pixel's footprint; 0 when the footprint has none. Never mixes depths of
// different surfaces, never spreads invalid pixels over valid ones.
ImageF ResizeDepth(const ImageF& depth, int width, int height);

// Helpers shared by the readers (exposed for tests and other readers).

// Keeps frames options.first, first + step, ... up to options.last (last = -1: to the end) and
// sets each frame's source_index to its index in `frames`; InputError when the range is empty or
// outside the recording. `what` names the recording in the message.
std::vector<FrameInfo> SelectFrameRange(std::vector<FrameInfo> frames,
                                        const DatasetOptions& options, const std::string& what);

// Throws InputError naming `what` when the principal point lies outside the image or a focal
// length is not positive ("wrong calibration").
void CheckCalibration(const PinholeCamera& camera, const std::string& what);

// The camera.yaml a folder, TUM sequence or video uses: options.camera when set, else
// `default_path`.
std::string CameraYamlPath(const DatasetOptions& options, const std::string& default_path);

// Image files (png, jpg, jpeg, ppm, pgm, bmp, tif, tiff; case-insensitive) in `folder`, sorted by
// name. InputError when the folder does not exist.
std::vector<std::string> ListImageFiles(const std::string& folder);

}  // namespace dfo::io

#endif  // DFO_IO_DATASET_H_
