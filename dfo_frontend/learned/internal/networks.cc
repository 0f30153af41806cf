#include "dfo_frontend/learned/internal/networks.h"

#include <ATen/CPUGeneratorImpl.h>

#include <cmath>
#include <sstream>
#include <string>

#include "dfo_core/error.h"

namespace dfo::learned {

namespace F = torch::nn::functional;

namespace {

torch::nn::Conv2d Conv(int in, int out, int kernel, int stride = 1) {
  return torch::nn::Conv2d(
      torch::nn::Conv2dOptions(in, out, kernel).stride(stride).padding(kernel / 2));
}

// Nearest-neighbour upsampling to an exact size (sizes need not be exact multiples of 2: the
// stride-2 encoder rounds odd sizes up).
torch::Tensor UpsampleTo(const torch::Tensor& x, int64_t height, int64_t width) {
  return F::interpolate(
      x,
      F::InterpolateFuncOptions().size(std::vector<int64_t>{height, width}).mode(torch::kNearest));
}

void CheckInput(const torch::Tensor& image, const NetworkOptions& options, const char* who) {
  DFO_CHECK(image.dim() == 4 && image.size(1) == 3)
      << who << ": expected an N x 3 x H x W image, got " << image.sizes();
  const int64_t div = int64_t{1} << (options.num_levels - 1);
  DFO_CHECK(image.size(2) % div == 0 && image.size(3) % div == 0)
      << who << ": image " << image.size(3) << " x " << image.size(2)
      << " has sides not divisible by 2^(num_levels - 1) = " << div;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Small functions

torch::Tensor DepthFromSigmoid(const torch::Tensor& sigmoid) {
  // DFO paper / SfMLearner: disparity = 10 * s + 0.01, depth = 1 / disparity.
  return 1.0 / (10.0 * sigmoid + 0.01);
}

torch::Tensor NormalizeImage(const torch::Tensor& image, const NetworkOptions& options) {
  const auto opts = torch::TensorOptions().dtype(image.dtype()).device(image.device());
  const torch::Tensor mean =
      torch::tensor({options.input_mean[0], options.input_mean[1], options.input_mean[2]}, opts)
          .view({1, 3, 1, 1});
  const torch::Tensor inv_std =
      torch::tensor(
          {1.0 / options.input_std[0], 1.0 / options.input_std[1], 1.0 / options.input_std[2]},
          opts)
          .view({1, 3, 1, 1});
  return (image - mean) * inv_std;
}

std::vector<torch::Tensor> ImagePyramid(const torch::Tensor& image, int num_levels) {
  std::vector<torch::Tensor> out;
  out.reserve(num_levels);
  out.push_back(image);
  for (int l = 1; l < num_levels; ++l) out.push_back(torch::avg_pool2d(out.back(), {2, 2}));
  return out;
}

torch::Tensor GaussianKernel3x3() {
  const torch::Tensor k1 = torch::tensor({1.0f, 2.0f, 1.0f}) / 4.0f;
  return torch::outer(k1, k1);
}

torch::Tensor GaussianSmooth3x3(const torch::Tensor& x) {
  // [1 2 1] / 4 = [1 1] / 2 * [1 1] / 2, so the 3x3 Gaussian is two 2x2 box filters of stride 1.
  // The first one pads by 1 and averages only the pixels inside the image, which at a border
  // equals averaging a replicate-padded image ((x0 + x0) / 2 = x0); the second one pads nothing.
  // Exactly the replicate-padded depthwise 3x3 convolution, but ~3x faster on this CPU in
  // channels_last (a depthwise convolution over 8 full-resolution channels took ~1.7 ms).
  const torch::Tensor once = torch::avg_pool2d(x, {2, 2}, {1, 1}, {1, 1}, /*ceil_mode=*/false,
                                               /*count_include_pad=*/false);
  return torch::avg_pool2d(once, {2, 2}, {1, 1}, {0, 0});
}

torch::Tensor GumbelSigmoid(const torch::Tensor& logits, double temperature,
                            c10::optional<at::Generator> generator) {
  DFO_CHECK(temperature > 0.0) << "Gumbel-sigmoid temperature " << temperature << " must be > 0";
  // u in [eps, 1 - eps] keeps the logistic noise finite. Drawn on the generator's device (the
  // trainer's are CPU generators: the same noise for every training device), then moved to the
  // logits'.
  constexpr double kEps = 1e-6;
  const torch::Device draw_device =
      generator.has_value() && generator->defined() ? generator->device() : logits.device();
  const torch::Tensor u = torch::rand(logits.sizes(), generator,
                                      logits.options().device(draw_device).requires_grad(false))
                              .clamp(kEps, 1.0 - kEps)
                              .to(logits.device());
  const torch::Tensor noise = torch::log(u) - torch::log1p(-u);
  return torch::sigmoid((logits + noise) / temperature);
}

torch::Tensor HardTopMask(const torch::Tensor& logits, double rho) {
  DFO_CHECK(logits.dim() == 4 && logits.size(1) == 1)
      << "HardTopMask expects N x 1 x H x W logits, got " << logits.sizes();
  DFO_CHECK(rho > 0.0 && rho <= 1.0) << "rho = " << rho << " violates (0, 1]";
  const int64_t n = logits.size(0);
  const int64_t pixels = logits.size(2) * logits.size(3);
  const int64_t k = std::max<int64_t>(
      1, std::min<int64_t>(pixels, std::llround(rho * static_cast<double>(pixels))));
  const torch::Tensor flat = logits.reshape({n, pixels});
  const torch::Tensor idx =
      std::get<1>(flat.topk(k, /*dim=*/1, /*largest=*/true, /*sorted=*/false));
  torch::Tensor mask = torch::zeros({n, pixels}, logits.options().dtype(torch::kUInt8));
  mask.scatter_(1, idx, 1);
  return mask.view(logits.sizes());
}

// ---------------------------------------------------------------------------------------------
// DepthNet

DepthNetImpl::DepthNetImpl(const NetworkOptions& options) : options_(options) {
  options_.Check();
  const std::vector<int>& enc = options_.depth_encoder_widths;
  const std::vector<int>& dec = options_.depth_decoder_widths;
  const int stages = static_cast<int>(enc.size());
  const int levels = options_.num_levels;
  encoder_ = register_module("encoder", torch::nn::ModuleList());
  for (int i = 0; i < stages; ++i) {
    const int in = i == 0 ? 3 : enc[i - 1];
    const int k = i == 0 ? 5 : 3;  // a wider first receptive field, as DispNet's 7x7 but cheaper
    encoder_->push_back(torch::nn::Sequential(Conv(in, enc[i], k, 2), torch::nn::ELU(),
                                              Conv(enc[i], enc[i], 3), torch::nn::ELU()));
  }
  // Decoder scale i (resolution 1 / 2^i), i = 0 .. stages - 1, stored at index i.
  upconv_ = register_module("upconv", torch::nn::ModuleList());
  iconv_ = register_module("iconv", torch::nn::ModuleList());
  for (int i = 0; i < stages; ++i) {
    const int up_in = i == stages - 1 ? enc[stages - 1] : dec[i + 1];
    upconv_->push_back(Conv(up_in, dec[i], 3));
    const int skip = i >= 1 ? enc[i - 1] : 0;
    const int coarser_disp = i < levels - 1 ? 1 : 0;
    iconv_->push_back(Conv(dec[i] + skip + coarser_disp, dec[i], 3));
  }
  disp_heads_ = register_module("disp_heads", torch::nn::ModuleList());
  for (int l = 0; l < levels; ++l) disp_heads_->push_back(Conv(dec[l], 1, 3));
}

void DepthNetImpl::SetInitialDepth(double depth_m) {
  if (!(depth_m > 0.1 && depth_m < 100.0)) {
    std::ostringstream msg;
    msg << "initial depth " << depth_m << " m is outside the depth network's range (0.1, 100) m";
    throw ConfigError(msg.str());
  }
  const double s = (1.0 / depth_m - 0.01) / 10.0;
  torch::NoGradGuard no_grad;
  for (size_t l = 0; l < disp_heads_->size(); ++l) {
    disp_heads_[l]->as<torch::nn::Conv2dImpl>()->bias.fill_(std::log(s / (1.0 - s)));
  }
}

DepthNetOutput DepthNetImpl::forward(const torch::Tensor& image) {
  CheckInput(image, options_, "DepthNet");
  const int stages = static_cast<int>(options_.depth_encoder_widths.size());
  const int levels = options_.num_levels;
  const int64_t height = image.size(2), width = image.size(3);

  std::vector<torch::Tensor> skips;  // skips[i]: encoder stage i at 1 / 2^(i+1)
  torch::Tensor x = NormalizeImage(image, options_);
  for (int i = 0; i < stages; ++i) {
    x = encoder_[i]->as<torch::nn::SequentialImpl>()->forward(x);
    skips.push_back(x);
  }

  DepthNetOutput out;
  out.sigmoid.resize(levels);
  torch::Tensor y = skips.back();
  torch::Tensor coarser_disp;
  for (int i = stages - 1; i >= 0; --i) {
    const int64_t h = i >= 1 ? skips[i - 1].size(2) : height;
    const int64_t w = i >= 1 ? skips[i - 1].size(3) : width;
    y = F::elu(upconv_[i]->as<torch::nn::Conv2dImpl>()->forward(UpsampleTo(y, h, w)));
    std::vector<torch::Tensor> cat;
    cat.reserve(3);
    cat.push_back(y);
    if (i >= 1) cat.push_back(skips[i - 1]);
    if (i < levels - 1) cat.push_back(UpsampleTo(coarser_disp, h, w));
    y = F::elu(iconv_[i]->as<torch::nn::Conv2dImpl>()->forward(torch::cat(cat, 1)));
    if (i < levels) {
      coarser_disp = torch::sigmoid(disp_heads_[i]->as<torch::nn::Conv2dImpl>()->forward(y));
      out.sigmoid[i] = coarser_disp;
    }
  }
  out.depth.reserve(levels);
  for (const torch::Tensor& s : out.sigmoid) out.depth.push_back(DepthFromSigmoid(s));
  return out;
}

// ---------------------------------------------------------------------------------------------
// FeatureNet

ResidualAttentionBlockImpl::ResidualAttentionBlockImpl(int channels) {
  trunk1_ = register_module("trunk1", Conv(channels, channels, 3));
  trunk2_ = register_module("trunk2", Conv(channels, channels, 3));
  attention_ = register_module("attention", Conv(channels, 1, 3));
}

void ResidualAttentionBlockImpl::ZeroTrunk() {
  torch::NoGradGuard no_grad;
  trunk2_->weight.zero_();
  trunk2_->bias.zero_();
}

torch::Tensor ResidualAttentionBlockImpl::forward(const torch::Tensor& x) {
  const torch::Tensor trunk = trunk2_->forward(torch::relu(trunk1_->forward(x)));
  const torch::Tensor attention = torch::sigmoid(attention_->forward(x));
  return torch::relu(x + (1.0 + attention) * trunk);
}

FeatureNetImpl::FeatureNetImpl(const NetworkOptions& options) : options_(options) {
  options_.Check();
  const std::vector<int>& enc = options_.feature_encoder_widths;
  const std::vector<int>& dec = options_.feature_decoder_widths;
  const int levels = options_.num_levels;
  encoder_ = register_module("encoder", torch::nn::ModuleList());
  for (int i = 0; i < levels; ++i) {
    const int in = i == 0 ? 3 : enc[i - 1];
    encoder_->push_back(torch::nn::Sequential(Conv(in, enc[i], 3, 2), torch::nn::ReLU(),
                                              ResidualAttentionBlock(enc[i])));
  }
  decoder_conv_ = register_module("decoder_conv", torch::nn::ModuleList());
  decoder_rab_ = register_module("decoder_rab", torch::nn::ModuleList());
  heads_ = register_module("heads", torch::nn::ModuleList());
  recon_heads_ = register_module("recon_heads", torch::nn::ModuleList());
  for (int l = 0; l < levels; ++l) {
    const int up_in = l == levels - 1 ? enc[levels - 1] : dec[l + 1];
    const int skip = l >= 1 ? enc[l - 1] : 0;
    decoder_conv_->push_back(Conv(up_in + skip + 3, dec[l], 3));
    // The full-resolution level has no attention block: it is the most expensive stage (the
    // DESIGN notes: the full-resolution decoder is ~45% of a plain U-Net's FLOPs).
    if (l >= 1) decoder_rab_->push_back(ResidualAttentionBlock(dec[l]));
    // One 3x3 convolution gives the C_l feature channels and, as channel C_l, the attention
    // branch's mask logit (one call instead of two: at full resolution a convolution costs
    // ~1 ms whatever its width, so separate heads doubled the cost).
    heads_->push_back(Conv(dec[l], options_.channels[l] + 1, 3));
    recon_heads_->push_back(
        torch::nn::Sequential(Conv(options_.channels[l], options_.reconstruction_width, 3),
                              torch::nn::ReLU(), Conv(options_.reconstruction_width, 3, 3)));
  }
}

FeatureNetOutput FeatureNetImpl::forward(const torch::Tensor& image) {
  CheckInput(image, options_, "FeatureNet");
  const int levels = options_.num_levels;
  const torch::Tensor normalized = NormalizeImage(image, options_);
  const std::vector<torch::Tensor> image_levels = ImagePyramid(normalized, levels);

  std::vector<torch::Tensor> skips;  // skips[i]: encoder stage i at 1 / 2^(i+1)
  torch::Tensor x = normalized;
  for (int i = 0; i < levels; ++i) {
    x = encoder_[i]->as<torch::nn::SequentialImpl>()->forward(x);
    skips.push_back(x);
  }

  FeatureNetOutput out;
  out.features.resize(levels);
  out.mask_logits.resize(levels);
  torch::Tensor y = skips.back();
  for (int l = levels - 1; l >= 0; --l) {
    const torch::Tensor& img = image_levels[l];
    std::vector<torch::Tensor> cat;
    cat.reserve(3);
    cat.push_back(UpsampleTo(y, img.size(2), img.size(3)));
    if (l >= 1) cat.push_back(skips[l - 1]);
    cat.push_back(img);
    y = torch::relu(decoder_conv_[l]->as<torch::nn::Conv2dImpl>()->forward(torch::cat(cat, 1)));
    if (l >= 1) y = decoder_rab_[l - 1]->as<ResidualAttentionBlockImpl>()->forward(y);
    const torch::Tensor heads = heads_[l]->as<torch::nn::Conv2dImpl>()->forward(y);
    const int64_t c = options_.channels[l];
    out.features[l] = GaussianSmooth3x3(torch::relu(heads.slice(1, 0, c)));
    out.mask_logits[l] = heads.slice(1, c, c + 1);
  }
  return out;
}

std::vector<torch::Tensor> FeatureNetImpl::Reconstruct(const std::vector<torch::Tensor>& features) {
  DFO_CHECK(static_cast<int>(features.size()) == options_.num_levels)
      << "Reconstruct: " << features.size() << " feature levels, expected " << options_.num_levels;
  std::vector<torch::Tensor> out;
  out.reserve(features.size());
  for (size_t l = 0; l < features.size(); ++l) {
    out.push_back(
        torch::sigmoid(recon_heads_[l]->as<torch::nn::SequentialImpl>()->forward(features[l])));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------
// Both

NetworksImpl::NetworksImpl(const NetworkOptions& options, uint64_t seed) : options_(options) {
  options_.Check();
  // torch::nn::Conv2d's constructor draws its default initialisation from the global generator;
  // restore its state so that building networks never changes other code's random numbers.
  at::Generator global = at::detail::getDefaultCPUGenerator();
  const torch::Tensor global_state = global.get_state();
  depth = register_module("depth", DepthNet(options_));
  feature = register_module("feature", FeatureNet(options_));
  global.set_state(global_state);
  InitializeWeights(*this, seed);
}

void InitializeWeights(torch::nn::Module& module, uint64_t seed) {
  at::Generator gen = at::make_generator<at::CPUGeneratorImpl>(seed);
  torch::NoGradGuard no_grad;
  auto init = [&gen](torch::nn::Conv2dImpl* conv) {
    const int64_t fan_in = conv->weight.size(1) * conv->weight.size(2) * conv->weight.size(3);
    const double bound = std::sqrt(6.0 / static_cast<double>(fan_in));
    // Drawn in float on the CPU with the private generator, then copied (any device/layout).
    torch::Tensor w = torch::empty(conv->weight.sizes(), torch::kFloat32);
    w.uniform_(-bound, bound, gen);
    conv->weight.copy_(w);
    if (conv->bias.defined()) conv->bias.zero_();
  };
  // modules() lists in registration order (depth first), so the draw order is fixed. The module
  // itself is tested separately: modules(true) needs it to be held by a shared_ptr, which is not
  // the case inside a constructor.
  if (auto* conv = dynamic_cast<torch::nn::Conv2dImpl*>(&module)) init(conv);
  for (const std::shared_ptr<torch::nn::Module>& m : module.modules(/*include_self=*/false)) {
    if (auto* conv = m->as<torch::nn::Conv2dImpl>()) init(conv);
  }
  if (auto* block = dynamic_cast<ResidualAttentionBlockImpl*>(&module)) block->ZeroTrunk();
  for (const std::shared_ptr<torch::nn::Module>& m : module.modules(/*include_self=*/false)) {
    if (auto* block = m->as<ResidualAttentionBlockImpl>()) block->ZeroTrunk();
  }
}

void ToChannelsLast(torch::nn::Module& module) {
  torch::NoGradGuard no_grad;
  for (torch::Tensor& p : module.parameters()) {
    if (p.dim() == 4) p.set_data(p.contiguous(torch::MemoryFormat::ChannelsLast));
  }
}

int64_t NumParameters(const torch::nn::Module& module) {
  int64_t n = 0;
  for (const torch::Tensor& p : module.parameters()) n += p.numel();
  return n;
}

}  // namespace dfo::learned
