// Shapes and widths of the DFO networks (torch-free, so configuration code and apps can use it
// without compiling LibTorch headers). The networks themselves are in internal/networks.h.
#ifndef DFO_FRONTEND_LEARNED_NETWORK_OPTIONS_H_
#define DFO_FRONTEND_LEARNED_NETWORK_OPTIONS_H_

#include <cstdint>
#include <vector>

namespace dfo::learned {

// Shapes and widths of both networks (stored in every model file).
struct NetworkOptions {
  // Size the model is trained for (pixels). The networks are fully convolutional and run on any
  // size whose sides are divisible by 2^(num_levels - 1); this is the size model files record.
  int input_width = 416;
  int input_height = 128;
  // Pyramid levels of both outputs, in [1, 6] (the paper: 4).
  int num_levels = 4;
  // Feature channels C_l per level (finest first), num_levels entries, each in [1, 256].
  std::vector<int> channels = {8, 8, 16, 16};
  // Patch side K_l per level (odd, in [1, 9]); metadata for the tracker, not used by the networks.
  std::vector<int> patch_sizes = {3, 3, 3, 3};
  // Target density rho_l of the selection mask per level, each in (0, 1]: the fraction of the
  // level's pixels kept by the hard inference mask and the KL sparsity target in training.
  std::vector<double> rho = {0.015, 0.04, 0.08, 0.16};
  // Input normalisation applied inside both networks: (rgb - mean) / std per channel (std > 0).
  std::vector<double> input_mean = {0.45, 0.45, 0.45};
  std::vector<double> input_std = {0.225, 0.225, 0.225};
  // DepthNet encoder widths, one stage per entry, stage i at 1 / 2^(i+1) of the input; at least
  // num_levels entries (the decoder outputs levels 0..num_levels-1), each in [1, 1024].
  std::vector<int> depth_encoder_widths = {16, 32, 64, 96, 128};
  // DepthNet decoder widths at scale 1 / 2^i (i = 0 is full resolution), same length as
  // depth_encoder_widths, each in [1, 1024].
  std::vector<int> depth_decoder_widths = {8, 16, 32, 64, 96};
  // FeatureNet encoder widths, exactly num_levels entries: stage i at 1 / 2^(i+1); the last one is
  // the bottleneck. Each in [1, 1024].
  std::vector<int> feature_encoder_widths = {16, 24, 32, 48};
  // FeatureNet decoder widths per output level (finest first), num_levels entries, in [1, 1024].
  std::vector<int> feature_decoder_widths = {8, 16, 24, 32};
  // Width of the hidden layer of each level's reconstruction head (autoencoder loss), >= 1.
  int reconstruction_width = 16;

  // Throws ConfigError naming the field ("network.channels has 3 entries, expected num_levels =
  // 4"), its value and the rule.
  void Check() const;
  // Number of pixels of level l for an input of width x height: (width >> l) * (height >> l).
  static int64_t LevelPixels(int width, int height, int level);
};

// Peak memory (MiB) of training these networks on batches of `batch_size` 3-frame snippets at
// input_width x input_height, estimated before the first iteration (dfo_train compares it with
// train.memory_limit_mb): 300 MiB + 1.2 x 100 bytes x W x pixels x batch_size, where W counts the
// networks' feature maps per input pixel (each layer's width times its share of the input's
// pixels: 70 for the default widths). Fitted to dfo_train's peak resident memory with the default
// widths at 208 x 64 (batch 4 and 8), 416 x 128 (batch 4) and 832 x 256 (batch 2): 621-3015 MiB.
double EstimateTrainingMemoryMib(const NetworkOptions& network, int batch_size);

// Equality of every field (used to compare a model file with a configuration).
bool operator==(const NetworkOptions& a, const NetworkOptions& b);
inline bool operator!=(const NetworkOptions& a, const NetworkOptions& b) { return !(a == b); }

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_NETWORK_OPTIONS_H_
