// The DFO networks in LibTorch (internal: includes <torch/torch.h>; only .cc files of dfo_learned,
// apps/dfo_train.cc and tests include it).
//
//  * DepthNet: DispNet-style encoder-decoder (Mayer et al. 2016, as used by SfMLearner), with
//    nearest-upsample + 3x3 conv in the decoder instead of transposed convolutions (those fall
//    back to single-threaded BLAS on this CPU). It predicts a sigmoid map s_l per pyramid level,
//    depth_l = 1 / (10 * s_l + 0.01) as in the DFO paper (so depth is in [0.0999, 100] m).
//  * FeatureNet: U-Net with residual attention blocks; the image, average-pooled to each decoder
//    level's size, is concatenated at every decoder level (keeps spatial information); per level l
//    a C_l-channel feature map (ReLU, then a fixed 3x3 Gaussian smoothing) and an attention branch
//    giving one mask logit per pixel. Training relaxes the mask with a Gumbel-sigmoid
//    (GumbelSigmoid, temperature 1 -> 0.1 in the paper); inference keeps the top rho_l fraction of
//    each level's pixels (HardTopMask). A per-level reconstruction head (Reconstruct) decodes the
//    image back from the features for the autoencoder loss.
//
// Conventions shared by both: the input is an N x 3 x H x W float RGB image in [0, 1]; the
// networks normalise it internally with NetworkOptions::input_mean/input_std. Level 0 is the
// input resolution, level l has size (H >> l) x (W >> l) (H and W divisible by 2^(levels-1)).
// Outputs are lists indexed by level, finest first. Both networks are plain torch::nn::Module
// holders, so the trainer calls forward with autograd and the Siamese use (both views through the
// same FeatureNet) is just two forward calls.
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_NETWORKS_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_NETWORKS_H_

#include <torch/torch.h>

#include <cstdint>
#include <vector>

#include "dfo_frontend/learned/network_options.h"

namespace dfo::learned {

// depth = 1 / (10 * s + 0.01) (DFO paper, as Monodepth's disparity-to-depth with 0.1..100 m).
torch::Tensor DepthFromSigmoid(const torch::Tensor& sigmoid);
constexpr double kMinNetworkDepth = 1.0 / 10.01;  // s = 1
constexpr double kMaxNetworkDepth = 100.0;        // s = 0

// (image - mean) / std per channel; image N x 3 x H x W.
torch::Tensor NormalizeImage(const torch::Tensor& image, const NetworkOptions& options);

// The image average-pooled to every level: element l is N x 3 x (H >> l) x (W >> l) (level 0 is
// the input). The 2x2 averaging matches dfo_core's image pyramid.
std::vector<torch::Tensor> ImagePyramid(const torch::Tensor& image, int num_levels);

// The 3 x 3 Gaussian kernel [1 2 1]^T [1 2 1] / 16 the feature maps are smoothed with.
torch::Tensor GaussianKernel3x3();
// Depthwise 3 x 3 Gaussian smoothing of every channel of x (N x C x H x W), replicate padding (so
// a constant map stays constant).
torch::Tensor GaussianSmooth3x3(const torch::Tensor& x);

// Gumbel-sigmoid relaxation of Bernoulli masks (Jang et al. 2017, binary case):
// sigmoid((logits + log(u) - log(1 - u)) / temperature), u ~ U(0, 1) drawn from `generator`
// (nullopt = torch's default generator) on the generator's device and moved to the logits' (a CPU
// generator gives CUDA logits the CPU's noise). temperature > 0; 1 -> 0.1 over training in the
// paper.
torch::Tensor GumbelSigmoid(const torch::Tensor& logits, double temperature,
                            c10::optional<at::Generator> generator = c10::nullopt);

// Hard inference mask: per image (logits N x 1 x H x W), exactly
// max(1, round(rho * H * W)) pixels with the largest logits are 1, the rest 0 (kUInt8, same
// shape). Ties are broken by torch::topk (deterministic on CPU). rho in (0, 1].
torch::Tensor HardTopMask(const torch::Tensor& logits, double rho);

// ---------------------------------------------------------------------------------------------
// DepthNet

// Output of DepthNet::forward, lists indexed by level (finest first).
struct DepthNetOutput {
  std::vector<torch::Tensor> sigmoid;  // s_l, N x 1 x H_l x W_l in (0, 1)
  std::vector<torch::Tensor> depth;    // DepthFromSigmoid(s_l), metres
};

class DepthNetImpl : public torch::nn::Module {
 public:
  // Throws ConfigError when options.Check() fails. Weights are NOT initialised deterministically
  // here: call InitializeWeights (Networks does).
  explicit DepthNetImpl(const NetworkOptions& options);
  // image: N x 3 x H x W RGB in [0, 1]; H, W divisible by 2^(num_levels - 1).
  DepthNetOutput forward(const torch::Tensor& image);
  // Sets the bias of every level's disparity head so that a zero input to it gives depth_m
  // (sigmoid s = (1 / depth_m - 0.01) / 10). depth_m in (0.1, 100), else ConfigError.
  void SetInitialDepth(double depth_m);
  const NetworkOptions& options() const { return options_; }

 private:
  NetworkOptions options_;
  torch::nn::ModuleList encoder_{nullptr};     // per stage: Sequential(conv s2, ELU, conv, ELU)
  torch::nn::ModuleList upconv_{nullptr};      // per decoder scale: conv after upsampling
  torch::nn::ModuleList iconv_{nullptr};       // per decoder scale: conv after concatenation
  torch::nn::ModuleList disp_heads_{nullptr};  // per output level: conv -> 1 channel
};
TORCH_MODULE(DepthNet);

// ---------------------------------------------------------------------------------------------
// FeatureNet

// Residual attention block: trunk T = conv3x3-ReLU-conv3x3, soft spatial attention
// M = sigmoid(conv3x3(x) -> 1 channel); out = ReLU(x + (1 + M) * T(x)) (the attention residual
// learning of Wang et al. 2017, "Residual Attention Network", in its lightest form).
class ResidualAttentionBlockImpl : public torch::nn::Module {
 public:
  explicit ResidualAttentionBlockImpl(int channels);
  torch::Tensor forward(const torch::Tensor& x);
  // Sets the trunk's last convolution to zero, so the block starts as the identity (ReLU(x) =
  // x for its non-negative inputs); InitializeWeights does this ("zero-init residual", Goyal et
  // al. 2017): without normalisation layers, 7 blocks otherwise grow activations ~100-fold.
  void ZeroTrunk();

 private:
  torch::nn::Conv2d trunk1_{nullptr}, trunk2_{nullptr}, attention_{nullptr};
};
TORCH_MODULE(ResidualAttentionBlock);

// Output of FeatureNet::forward, lists indexed by level (finest first).
struct FeatureNetOutput {
  std::vector<torch::Tensor> features;     // N x C_l x H_l x W_l, >= 0 (ReLU then Gaussian)
  std::vector<torch::Tensor> mask_logits;  // N x 1 x H_l x W_l (attention branch, unbounded)
};

class FeatureNetImpl : public torch::nn::Module {
 public:
  // Throws ConfigError when options.Check() fails.
  explicit FeatureNetImpl(const NetworkOptions& options);
  // image: N x 3 x H x W RGB in [0, 1]; H, W divisible by 2^(num_levels - 1).
  FeatureNetOutput forward(const torch::Tensor& image);
  // Autoencoder head: per level, the RGB image (N x 3 x H_l x W_l, sigmoid, in [0, 1])
  // reconstructed from that level's features; compare with ImagePyramid(image) for the AE loss.
  std::vector<torch::Tensor> Reconstruct(const std::vector<torch::Tensor>& features);
  const NetworkOptions& options() const { return options_; }

 private:
  NetworkOptions options_;
  torch::nn::ModuleList encoder_{nullptr};       // per stage: Sequential(conv s2, ReLU, RAB)
  torch::nn::ModuleList decoder_conv_{nullptr};  // per level: conv after concatenation
  torch::nn::ModuleList decoder_rab_{nullptr};   // per level >= 1: residual attention block
  torch::nn::ModuleList heads_{nullptr};        // per level: conv3x3 -> C_l features + 1 mask logit
  torch::nn::ModuleList recon_heads_{nullptr};  // per level: conv-ReLU-conv -> 3, sigmoid
};
TORCH_MODULE(FeatureNet);

// ---------------------------------------------------------------------------------------------
// Both networks with their options: what a model file holds.
class NetworksImpl : public torch::nn::Module {
 public:
  // Builds both networks and initialises every weight deterministically from `seed` (He-uniform
  // convolution weights, zero biases, drawn from a private generator: the global torch RNG is
  // neither used nor changed). Throws ConfigError on bad options.
  explicit NetworksImpl(const NetworkOptions& options, uint64_t seed = 0);
  const NetworkOptions& options() const { return options_; }
  DepthNet depth{nullptr};
  FeatureNet feature{nullptr};

 private:
  NetworkOptions options_;
};
TORCH_MODULE(Networks);

// Re-initialises every Conv2d of `module` (recursively) from `seed`: weights uniform in
// +-sqrt(6 / fan_in) (He), biases 0, then the last trunk convolution of every residual attention
// block to 0 (ZeroTrunk). Same seed -> bit-identical weights.
void InitializeWeights(torch::nn::Module& module, uint64_t seed);

// Stores every 4-D parameter of `module` in channels_last (NHWC) memory format: oneDNN's fast
// convolution path on this CPU (DESIGN.md: ~1.6-1.8x). Feed channels_last inputs as well.
void ToChannelsLast(torch::nn::Module& module);

// Number of scalar parameters of a module.
int64_t NumParameters(const torch::nn::Module& module);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_NETWORKS_H_
