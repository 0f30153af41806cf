// Learned feature and depth sources: the DFO networks (or a TorchScript model trained elsewhere)
// behind the frontend's FeatureSource / DepthSource interfaces. Torch-free header (pimpl).
//
//   LearnedModelOptions options;
//   options.model_path = "models/dfo_default.pt";
//   std::shared_ptr<LearnedModel> model = LoadLearnedModel(options);  // throws InputError
//   std::unique_ptr<FeatureSource> features = MakeLearnedFeatureSource(model);
//   std::unique_ptr<DepthSource> depth = MakeLearnedDepthSource(model);
//
// Both sources share ONE model. Each network runs only when its output is asked for, at most
// once per frame (the last frame's outputs are cached, keyed by frame index, timestamp and image
// content): hand-made features with learned depth run the depth network alone. A TorchScript
// module gives both outputs in one forward.
//
// Model files (details in dfo_frontend/learned/internal/model_file.h):
//  * dfo's own format ("dfo-model" version 1): one torch::serialize archive with both networks'
//    weights and the metadata (input size, levels, channels and patch size per level, mask
//    density rho per level, input normalisation mean/std, all network widths, free-text notes).
//  * TorchScript (a model trained elsewhere in PyTorch, torch.jit.save): attributes
//    dfo_input_width, dfo_input_height, dfo_num_levels (int), dfo_channels, dfo_patch_sizes
//    (List[int]), dfo_rho (List[float]); forward(image) with image 1 x 3 x H x W float32 RGB in
//    [0, 1] returns a tuple (depth, features, mask_logits) of lists with one tensor per level
//    (finest first, level l of size (H >> l) x (W >> l)): depth 1 x 1 x H_l x W_l in metres,
//    features 1 x C_l x H_l x W_l, mask logits 1 x 1 x H_l x W_l (the top rho_l fraction of each
//    level is selectable).
//
// Non-finite network outputs never crash and never throw: non-finite depths become 0 (invalid),
// non-finite feature values become 0 and their pixels leave the selection mask. A frame whose
// outputs are all non-finite therefore has no valid depth and no selectable pixel, and the
// tracker reports it lost (TrackingStatus::kLost), as for any frame without usable points. The
// counts are in LearnedModel::last_stats().
#ifndef DFO_FRONTEND_LEARNED_LEARNED_SOURCES_H_
#define DFO_FRONTEND_LEARNED_LEARNED_SOURCES_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dfo_core/frame.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/learned/network_options.h"

namespace dfo {

// The default model file (default.dfo, trained on synthetic streets), found without a path
// relative to the working directory: $DFO_MODEL_DIR/default.dfo when the environment variable
// DFO_MODEL_DIR is set; otherwise the source tree's models/default.dfo when that file exists (a
// program of dfo's own build); otherwise the copy installed with the package
// (<prefix>/share/dfo/models/default.dfo). The file is not opened here.
std::string DefaultModelPath();

// Options of the learned sources (YAML section "learned").
struct LearnedModelOptions {
  // Path of the model file (dfo model or TorchScript following the contract above). Required.
  std::string model_path;
  // LibTorch intra-op threads, >= 1. Note: a process-wide LibTorch setting (LibTorch's default
  // here is 1). With another busy process on a 2-core machine, 1 can be faster than 2.
  int num_threads = 2;
  // Levels the configuration expects the model to have: 0 = whatever the file has; otherwise
  // the file must have exactly this many (InputError naming the file and num_levels otherwise).
  int num_levels = 0;
  // Feature channels per level the configuration expects: empty = whatever the file has;
  // otherwise it must equal the file's list.
  std::vector<int> channels;
  // Mask density per level replacing the file's rho: empty = the file's; otherwise one value
  // per model level, each in (0, 1].
  std::vector<double> rho;
  // true: frames must have exactly the model's input size (InputError naming the frame
  // otherwise). false: any size whose sides are divisible by 2^(levels - 1) (the networks are
  // fully convolutional; outputs are checked per frame).
  bool require_input_size = true;
  // true: the depth network runs on the frame resized to the model's input size (area averaging
  // when shrinking, bilinear when growing) and each level's depth is resized back to the frame's
  // level (bilinear), so that a model trained at one size gives its depth to frames of another
  // (e.g. tracking at twice the model's size); the feature network still runs on the frame. A
  // dfo model file only (InputError at load for TorchScript). false: the networks run on the frame.
  bool depth_at_model_size = false;
  // Where the networks run: "cpu", "cuda" (the current CUDA device) or "cuda:N". A CUDA device
  // needs a LibTorch built with CUDA (README: pointing CMake at one); Debian's libtorch is built
  // for the CPU only, and asking it for "cuda" is a ConfigError when the model is loaded.
  std::string device = "cpu";

  // Throws ConfigError naming the field ("learned.num_threads = 0 violates >= 1").
  void Check() const;
};

// What was loaded.
struct LearnedModelInfo {
  std::string path;      // the model file
  std::string kind;      // "dfo" or "torchscript"
  int input_width = 0;   // pixels
  int input_height = 0;  // pixels
  int num_levels = 0;
  std::vector<int> channels;       // C_l per level
  std::vector<int> patch_sizes;    // K_l per level
  std::vector<double> rho;         // effective mask density per level (after the override)
  std::string notes;               // the file's notes ("dfo" kind only)
  int64_t depth_parameters = 0;    // scalar parameters of the depth network ("dfo" kind only)
  int64_t feature_parameters = 0;  // same for the feature network
};

// Figures of the last frame the networks ran on.
struct LearnedFrameStats {
  int frame_index = -1;
  double network_ms = 0.0;           // wall time of the networks run on it, incl. conversions
  bool ran_depth_network = false;    // the depth network ran on this frame
  bool ran_feature_network = false;  // the feature network ran on this frame
  int64_t nonfinite_depth = 0;       // depth values replaced by 0 (all levels)
  int64_t nonfinite_features = 0;    // feature values replaced by 0 (all levels and channels)
  int64_t nonfinite_logits = 0;      // mask logits treated as "never select"
};

// One loaded model, shared by the learned feature and depth sources. Not thread-safe.
class LearnedModel {
 public:
  // Loads and checks the model file; throws ConfigError on bad options and InputError (naming
  // the file and the field) on a missing file, a file of another format, invalid metadata, or a
  // model whose num_levels/channels differ from the options'.
  explicit LearnedModel(const LearnedModelOptions& options);
  ~LearnedModel();
  LearnedModel(const LearnedModel&) = delete;
  LearnedModel& operator=(const LearnedModel&) = delete;

  const LearnedModelInfo& info() const;
  const LearnedModelOptions& options() const;

  // The feature / depth network's outputs for `frame` at all model levels (each network runs
  // on the first call for a frame; a second call for the same frame returns the stored result).
  // Features are z-scored per channel and level and carry the hard top-rho selection mask;
  // depth is in metres, 0 = invalid. Throws InputError naming the frame (and the model) for an
  // empty image, an image of 2 or 4+ channels, an image whose size differs from its camera's or
  // from the model's input size (see require_input_size), and for TorchScript outputs of the
  // wrong shape.
  const FeaturePyramid& Features(const Frame& frame);
  const DepthPyramid& Depth(const Frame& frame);
  // Throws the InputError that Features and Depth would throw for the frame's image (see
  // above; TorchScript output shapes aside), without running a network.
  void CheckInput(const Frame& frame) const;
  // For start-up, before any frame: throws ConfigError naming the keys when frames of width x
  // height cannot be given to the model: another size than its input size with
  // require_input_size, or sides not divisible by 2^(levels - 1) where a network runs on the
  // frame itself (the feature network when `features`, the depth network unless
  // depth_at_model_size).
  void CheckFrameSize(int width, int height, bool features) const;

  // Figures of the last frame the networks ran on (not updated by cache hits).
  const LearnedFrameStats& last_stats() const;
  // Number of frames the networks have run on so far (frames that missed the cache).
  int64_t num_runs() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Loads a model (LearnedModel's constructor) into a shared_ptr for the sources.
std::shared_ptr<LearnedModel> LoadLearnedModel(const LearnedModelOptions& options);

// Feature source "learned": the model's feature pyramid. Compute(frame, num_levels) returns the
// first num_levels model levels; asking for more levels than the model has throws ConfigError.
std::unique_ptr<FeatureSource> MakeLearnedFeatureSource(std::shared_ptr<LearnedModel> model);

// Depth source "learned": the depth network's pyramid. Levels beyond the model's are made by
// DownsampleDepthHalf from the coarsest model level.
std::unique_ptr<DepthSource> MakeLearnedDepthSource(std::shared_ptr<LearnedModel> model);

// Writes an untrained model with valid shapes (weights initialised from `seed`) in dfo's model
// format: for tests and as the starting point of training. Throws ConfigError on bad options,
// InputError when the file cannot be written.
void WriteUntrainedModel(const std::string& path, const learned::NetworkOptions& options = {},
                         uint64_t seed = 0, const std::string& notes = "untrained");

}  // namespace dfo

#endif  // DFO_FRONTEND_LEARNED_LEARNED_SOURCES_H_
