#include "dfo_frontend/learned/learned_sources.h"

#include <chrono>
#include <cmath>
#include <cstring>
#include <sstream>
#include <utility>

#include "dfo_core/check_option.h"
#include "dfo_core/error.h"
#include "dfo_core/timing.h"
#include "dfo_frontend/learned/internal/device.h"
#include "dfo_frontend/learned/internal/model_file.h"
#include "dfo_frontend/learned/internal/networks.h"

namespace dfo {

namespace {

template <typename T>
std::string ListString(const std::vector<T>& v) {
  std::ostringstream s;
  s << "[";
  for (size_t i = 0; i < v.size(); ++i) s << (i ? ", " : "") << v[i];
  s << "]";
  return s.str();
}

// FNV-1a over the image bytes: part of the cache key, so a reused frame index with another image
// (e.g. two sequences through one model) never returns stale outputs.
uint64_t HashBytes(const uint8_t* data, size_t n) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < n; ++i) {
    h ^= data[i];
    h *= 1099511628211ull;
  }
  return h;
}

struct CacheKey {
  int index = -1;
  int64_t timestamp_ns = 0;
  int width = 0, height = 0, channels = 0;
  uint64_t hash = 0;
  bool operator==(const CacheKey& o) const {
    return index == o.index && timestamp_ns == o.timestamp_ns && width == o.width &&
           height == o.height && channels == o.channels && hash == o.hash;
  }
};

}  // namespace

void LearnedModelOptions::Check() const {
  using internal::CheckOption;
  CheckOption(!model_path.empty(), "learned.model_path", "\"\"", "non-empty");
  CheckOption(num_threads >= 1 && num_threads <= 256, "learned.num_threads", num_threads,
              "in [1, 256]");
  CheckOption(num_levels >= 0 && num_levels <= 6, "learned.num_levels", num_levels,
              "in [0, 6] (0 = the model's)");
  for (size_t i = 0; i < channels.size(); ++i) {
    CheckOption(channels[i] >= 1, "learned.channels[" + std::to_string(i) + "]", channels[i],
                ">= 1");
  }
  for (size_t i = 0; i < rho.size(); ++i) {
    CheckOption(std::isfinite(rho[i]) && rho[i] > 0.0 && rho[i] <= 1.0,
                "learned.rho[" + std::to_string(i) + "]", rho[i], "in (0, 1]");
  }
  learned::CheckDeviceName("learned.device", device);
}

struct LearnedModel::Impl {
  LearnedModelOptions options;
  torch::Device device = torch::kCPU;  // learned.device
  LearnedModelInfo info;
  learned::LoadedModel model;
  // The frame whose outputs are held (valid while either flag is set), and which of them are
  // (each network runs on demand, once per frame: a hand-made-feature run never pays for the
  // feature network).
  CacheKey key;
  bool has_features = false;
  bool has_depth = false;
  FeaturePyramid features;
  DepthPyramid depth;
  LearnedFrameStats stats;
  int64_t runs = 0;

  void Load();
  // Makes the asked-for outputs of `frame` available (running only what is not cached).
  void Run(const Frame& frame, bool want_features, bool want_depth);
  // The InputErrors of Run for the frame's image, without running anything.
  void CheckInput(const Frame& frame) const;
  // InputError unless the frame's sides are divisible by 2^(levels - 1), which a network run on
  // the frame itself needs.
  void CheckDivisible(const Frame& frame) const;
  void StoreDepth(const Frame& frame, const std::vector<torch::Tensor>& depth_levels);
  void StoreFeatures(const Frame& frame, const std::vector<torch::Tensor>& feature_levels,
                     const std::vector<torch::Tensor>& logit_levels);
  std::string What(const Frame& frame) const {
    return "model " + options.model_path + ", frame " + std::to_string(frame.index);
  }
};

void LearnedModel::Impl::Load() {
  options.Check();
  // LibTorch's intra-op pool is process-wide; the default here is 1 thread (DESIGN.md).
  at::set_num_threads(options.num_threads);
  device = learned::ResolveDevice("learned.device", options.device);
  model = learned::LoadModel(options.model_path);
  const std::string prefix = "model file " + options.model_path + ": ";
  learned::NetworkOptions& o = model.options;
  if (options.num_levels != 0 && options.num_levels != o.num_levels) {
    throw InputError(prefix + "num_levels = " + std::to_string(o.num_levels) +
                     ", but the configuration asks for " + std::to_string(options.num_levels) +
                     " (learned.num_levels)");
  }
  if (!options.channels.empty() && options.channels != o.channels) {
    throw InputError(prefix + "channels = " + ListString(o.channels) +
                     ", but the configuration asks for " + ListString(options.channels) +
                     " (learned.channels)");
  }
  if (!options.rho.empty()) {
    if (options.rho.size() != o.rho.size()) {
      throw ConfigError("learned.rho = " + ListString(options.rho) + " has " +
                        std::to_string(options.rho.size()) + " entries; the model " +
                        options.model_path + " has num_levels = " + std::to_string(o.num_levels));
    }
    o.rho = options.rho;
  }
  info.path = options.model_path;
  info.input_width = o.input_width;
  info.input_height = o.input_height;
  info.num_levels = o.num_levels;
  info.channels = o.channels;
  info.patch_sizes = o.patch_sizes;
  info.rho = o.rho;
  if (model.kind == learned::LoadedModel::Kind::kDfo) {
    info.kind = "dfo";
    info.notes = model.notes;
    info.depth_parameters = learned::NumParameters(*model.networks->depth);
    info.feature_parameters = learned::NumParameters(*model.networks->feature);
    // oneDNN's fast path on this CPU is NHWC (DESIGN.md "Training on this CPU").
    learned::ToChannelsLast(*model.networks);
    model.networks->to(device);
    model.networks->eval();
  } else {
    info.kind = "torchscript";
    if (options.depth_at_model_size) {
      throw InputError(prefix +
                       "a TorchScript module gives depth and features in one run at the frame's "
                       "size; learned.depth_at_model_size needs a dfo model file");
    }
    model.script.to(device);
    model.script.eval();
    // Freezing folds parameters into constants and lets optimize_for_inference fuse conv/ReLU
    // and pre-pack weights for oneDNN (torch.jit.optimize_for_inference). Both are optional:
    // a module they cannot handle runs as loaded.
    try {
      torch::jit::Module frozen = torch::jit::freeze(model.script);
      model.script = torch::jit::optimize_for_inference(frozen);
    } catch (const std::exception&) {
    }
  }
}

void LearnedModel::Impl::CheckInput(const Frame& frame) const {
  const ImageU8& image = frame.image;
  if (image.empty()) throw InputError(What(frame) + ": empty image");
  if (image.channels() != 1 && image.channels() != 3) {
    throw InputError(What(frame) + ": image has " + std::to_string(image.channels()) +
                     " channels; expected 1 (grey) or 3 (RGB)");
  }
  if (image.width() != frame.camera.width || image.height() != frame.camera.height) {
    throw InputError(What(frame) + ": image is " + std::to_string(image.width()) + " x " +
                     std::to_string(image.height()) + " but the camera is " +
                     std::to_string(frame.camera.width) + " x " +
                     std::to_string(frame.camera.height));
  }
  const learned::NetworkOptions& o = model.options;
  const int width = image.width(), height = image.height();
  if (options.require_input_size && (width != o.input_width || height != o.input_height)) {
    throw InputError(What(frame) + ": image is " + std::to_string(width) + " x " +
                     std::to_string(height) + "; the model takes " + std::to_string(o.input_width) +
                     " x " + std::to_string(o.input_height) +
                     " (resize the input, or set learned.require_input_size = false)");
  }
  // With depth_at_model_size the depth network runs on a resized copy; the feature network (and
  // a TorchScript module, which refuses depth_at_model_size) runs on the frame itself.
  if (!options.depth_at_model_size) CheckDivisible(frame);
}

void LearnedModel::Impl::CheckDivisible(const Frame& frame) const {
  const int div = 1 << (model.options.num_levels - 1);
  const int width = frame.image.width(), height = frame.image.height();
  if (width % div != 0 || height % div != 0) {
    throw InputError(What(frame) + ": image is " + std::to_string(width) + " x " +
                     std::to_string(height) + "; the model's " +
                     std::to_string(model.options.num_levels) +
                     " levels need sides divisible by " + std::to_string(div));
  }
}

void LearnedModel::Impl::Run(const Frame& frame, bool want_features, bool want_depth) {
  CheckInput(frame);
  const ImageU8& image = frame.image;
  const learned::NetworkOptions& o = model.options;
  const int width = image.width(), height = image.height();
  CacheKey k;
  k.index = frame.index;
  k.timestamp_ns = frame.timestamp_ns;
  k.width = width;
  k.height = height;
  k.channels = image.channels();
  k.hash = HashBytes(image.data(), image.size());
  const bool same_frame = (has_features || has_depth) && k == key;
  if (!same_frame) {
    has_features = false;
    has_depth = false;
  }
  const bool need_features = want_features && !has_features;
  const bool need_depth = want_depth && !has_depth;
  if (!need_features && !need_depth) return;
  if (!same_frame) {
    // A new frame: its figures start from zero.
    stats = LearnedFrameStats();
    stats.frame_index = frame.index;
    ++runs;
  }

  const auto start = std::chrono::steady_clock::now();
  c10::InferenceMode inference_mode;
  // H x W x C bytes -> 1 x 3 x H x W float in [0, 1]; the permuted view is NHWC in memory, the
  // layout the channels_last networks want.
  torch::Tensor input = torch::from_blob(const_cast<uint8_t*>(image.data()),
                                         {height, width, image.channels()}, torch::kUInt8)
                            .permute({2, 0, 1})
                            .unsqueeze(0)
                            .to(torch::kFloat32)
                            .div_(255.0f);
  if (image.channels() == 1) input = input.expand({1, 3, height, width});
  input = input.to(device).contiguous(torch::MemoryFormat::ChannelsLast);

  if (model.kind == learned::LoadedModel::Kind::kDfo) {
    if (need_depth) {
      const bool resize =
          options.depth_at_model_size && (width != o.input_width || height != o.input_height);
      if (!resize) {
        StoreDepth(frame, model.networks->depth->forward(input).depth);
      } else {
        namespace F = torch::nn::functional;
        const bool shrink = width >= o.input_width && height >= o.input_height;
        F::InterpolateFuncOptions to_model =
            F::InterpolateFuncOptions().size(std::vector<int64_t>{o.input_height, o.input_width});
        if (shrink) {
          to_model.mode(torch::kArea);
        } else {
          to_model.mode(torch::kBilinear).align_corners(false);
        }
        const torch::Tensor small =
            F::interpolate(input, to_model).contiguous(torch::MemoryFormat::ChannelsLast);
        std::vector<torch::Tensor> levels = model.networks->depth->forward(small).depth;
        for (size_t l = 0; l < levels.size(); ++l) {
          levels[l] =
              F::interpolate(levels[l], F::InterpolateFuncOptions()
                                            .size(std::vector<int64_t>{height >> l, width >> l})
                                            .mode(torch::kBilinear)
                                            .align_corners(false));
        }
        StoreDepth(frame, levels);
      }
      stats.ran_depth_network = true;
    }
    if (need_features) {
      CheckDivisible(frame);  // the feature network runs on the frame (CheckInput may not have)
      learned::FeatureNetOutput f = model.networks->feature->forward(input);
      StoreFeatures(frame, f.features, f.mask_logits);
      stats.ran_feature_network = true;
    }
  } else {
    // A TorchScript module gives everything in one forward.
    c10::IValue output;
    try {
      output = model.script.forward({input.contiguous()});
    } catch (const std::exception& e) {
      std::string msg = e.what();
      if (const auto* c10_error = dynamic_cast<const c10::Error*>(&e)) {
        msg = c10_error->what_without_backtrace();
      }
      throw InputError(What(frame) +
                       ": TorchScript forward failed: " + msg.substr(0, msg.find('\n')));
    }
    learned::ScriptOutputs s = learned::CheckScriptOutputs(output, o, width, height, What(frame));
    // Both outputs at once, so the module runs only on a new frame (stats freshly zeroed).
    StoreDepth(frame, s.depth);
    StoreFeatures(frame, s.features, s.mask_logits);
    stats.ran_depth_network = true;
    stats.ran_feature_network = true;
  }
  stats.network_ms += MsSince(start);
  key = k;
}

void LearnedModel::Impl::StoreDepth(const Frame& frame,
                                    const std::vector<torch::Tensor>& depth_levels) {
  const learned::NetworkOptions& o = model.options;
  const int width = frame.image.width(), height = frame.image.height();
  depth.levels.clear();
  for (int l = 0; l < o.num_levels; ++l) {
    const int w = width >> l, h = height >> l;
    // Depth: non-finite or <= 0 -> 0 (invalid), as the DepthSource contract asks.
    torch::Tensor d = depth_levels[l].to(torch::kCPU, torch::kFloat32).contiguous().view({h, w});
    const torch::Tensor d_bad = ~torch::isfinite(d);
    stats.nonfinite_depth += d_bad.sum().item<int64_t>();
    d = torch::where(d_bad | (d <= 0), torch::zeros_like(d), d).contiguous();
    ImageF depth_map(w, h, 1);
    std::memcpy(depth_map.data(), d.data_ptr<float>(), sizeof(float) * w * h);
    depth.levels.push_back(std::move(depth_map));
  }
  has_depth = true;
}

void LearnedModel::Impl::StoreFeatures(const Frame& frame,
                                       const std::vector<torch::Tensor>& feature_levels,
                                       const std::vector<torch::Tensor>& logit_levels) {
  const learned::NetworkOptions& o = model.options;
  const int width = frame.image.width(), height = frame.image.height();
  features.levels.clear();
  for (int l = 0; l < o.num_levels; ++l) {
    const int w = width >> l, h = height >> l;
    // Features: non-finite values -> 0; their pixels (and non-finite logits) are never selected.
    // One pass in plain loops over the network's output, read as H x W x C (the channels_last
    // layout the networks give, so no copy): the same result as tensor operations, but those
    // took ~7 ms per frame at 416 x 128 in layout conversions and temporaries.
    const int c = static_cast<int>(feature_levels[l].size(1));
    const size_t n = static_cast<size_t>(w) * h;
    const torch::Tensor f_hwc =
        feature_levels[l].to(torch::kCPU, torch::kFloat32).permute({0, 2, 3, 1}).contiguous();
    const torch::Tensor l_hw = logit_levels[l].to(torch::kCPU, torch::kFloat32).contiguous();
    const float* f_src = f_hwc.data_ptr<float>();
    const float* l_src = l_hw.data_ptr<float>();
    FeatureLevel level(w, h, c, frame.camera.PyramidLevel(l));  // zeros
    std::vector<uint8_t> pixel_bad(n, 0);
    std::vector<float> logits(n);
    for (size_t p = 0; p < n; ++p) {
      const float* v = f_src + p * c;
      for (int ch = 0; ch < c; ++ch) {
        if (std::isfinite(v[ch])) {
          level.data[static_cast<size_t>(ch) * n + p] = v[ch];
        } else {
          ++stats.nonfinite_features;
          pixel_bad[p] = 1;
        }
      }
      if (!std::isfinite(l_src[p])) {
        ++stats.nonfinite_logits;
        pixel_bad[p] = 1;
      }
      logits[p] = pixel_bad[p] ? -1e30f : l_src[p];
    }
    const torch::Tensor mask =
        learned::HardTopMask(torch::from_blob(logits.data(), {1, 1, h, w}, torch::kFloat32),
                             o.rho[l])
            .contiguous();
    const uint8_t* m = mask.data_ptr<uint8_t>();
    level.mask.resize(n);
    for (size_t p = 0; p < n; ++p) level.mask[p] = pixel_bad[p] ? 0 : m[p];
    level.ZScore();
    features.levels.push_back(std::move(level));
  }
  has_features = true;
}

LearnedModel::LearnedModel(const LearnedModelOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->options = options;
  impl_->Load();
}

LearnedModel::~LearnedModel() = default;

const LearnedModelInfo& LearnedModel::info() const { return impl_->info; }
const LearnedModelOptions& LearnedModel::options() const { return impl_->options; }

void LearnedModel::CheckInput(const Frame& frame) const { impl_->CheckInput(frame); }

void LearnedModel::CheckFrameSize(int width, int height, bool features) const {
  const LearnedModelOptions& options = impl_->options;
  const learned::NetworkOptions& o = impl_->model.options;
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if (options.require_input_size && (width != o.input_width || height != o.input_height)) {
    throw ConfigError("dataset image size " + size + " differs from the input size " +
                      std::to_string(o.input_width) + "x" + std::to_string(o.input_height) +
                      " of the learned model " + options.model_path +
                      "; set dataset.image_width/image_height to it, or "
                      "learned.require_input_size = false");
  }
  const int div = 1 << (o.num_levels - 1);
  const bool on_frame = features || !options.depth_at_model_size;
  if (on_frame && (width % div != 0 || height % div != 0)) {
    throw ConfigError(
        "dataset image size " + size + ": the " + std::to_string(o.num_levels) +
        " levels of the learned model " + options.model_path + " need sides divisible by " +
        std::to_string(div) + " where a network runs on the frame itself (" +
        (features ? std::string("frontend.features = learned")
                  : std::string("learned.depth_at_model_size = false")) +
        "); set dataset.processing_width (it rounds to that) or dataset.image_width / "
        "image_height to multiples of " + std::to_string(div));
  }
}

const FeaturePyramid& LearnedModel::Features(const Frame& frame) {
  impl_->Run(frame, /*want_features=*/true, /*want_depth=*/false);
  return impl_->features;
}

const DepthPyramid& LearnedModel::Depth(const Frame& frame) {
  impl_->Run(frame, /*want_features=*/false, /*want_depth=*/true);
  return impl_->depth;
}

const LearnedFrameStats& LearnedModel::last_stats() const { return impl_->stats; }
int64_t LearnedModel::num_runs() const { return impl_->runs; }

std::shared_ptr<LearnedModel> LoadLearnedModel(const LearnedModelOptions& options) {
  return std::make_shared<LearnedModel>(options);
}

namespace {

class LearnedFeatureSource : public FeatureSource {
 public:
  explicit LearnedFeatureSource(std::shared_ptr<LearnedModel> model) : model_(std::move(model)) {
    DFO_CHECK(model_ != nullptr) << "MakeLearnedFeatureSource needs a model";
  }
  std::string name() const override { return "learned"; }
  FeaturePyramid Compute(const Frame& frame, int num_levels) override {
    const int model_levels = model_->info().num_levels;
    if (num_levels < 1 || num_levels > model_levels) {
      throw ConfigError(
          "the tracker asks for " + std::to_string(num_levels) + " feature levels; the model " +
          model_->info().path + " has " + std::to_string(model_levels) +
          " (frontend.tracker.num_levels must be in [1, " + std::to_string(model_levels) + "])");
    }
    const FeaturePyramid& all = model_->Features(frame);
    FeaturePyramid out;
    out.levels.assign(all.levels.begin(), all.levels.begin() + num_levels);
    return out;
  }

 private:
  std::shared_ptr<LearnedModel> model_;
};

class LearnedDepthSource : public DepthSource {
 public:
  explicit LearnedDepthSource(std::shared_ptr<LearnedModel> model) : model_(std::move(model)) {
    DFO_CHECK(model_ != nullptr) << "MakeLearnedDepthSource needs a model";
  }
  std::string name() const override { return "learned"; }
  void Check(const Frame& frame, int num_levels) const override {
    DFO_CHECK(num_levels >= 1) << "num_levels = " << num_levels;
    model_->CheckInput(frame);
  }
  DepthPyramid Compute(const Frame& frame, int num_levels) override {
    DFO_CHECK(num_levels >= 1) << "num_levels = " << num_levels;
    const DepthPyramid& all = model_->Depth(frame);
    DepthPyramid out;
    const int n = std::min(num_levels, all.num_levels());
    out.levels.assign(all.levels.begin(), all.levels.begin() + n);
    while (out.num_levels() < num_levels) {
      const ImageF& last = out.levels.back();
      if (last.width() < 2 || last.height() < 2) {
        throw InputError("frame " + std::to_string(frame.index) + ": depth level " +
                         std::to_string(out.num_levels() - 1) + " is " +
                         std::to_string(last.width()) + " x " + std::to_string(last.height()) +
                         ", too small for another level");
      }
      out.levels.push_back(DownsampleDepthHalf(last));
    }
    return out;
  }

 private:
  std::shared_ptr<LearnedModel> model_;
};

}  // namespace

std::unique_ptr<FeatureSource> MakeLearnedFeatureSource(std::shared_ptr<LearnedModel> model) {
  return std::make_unique<LearnedFeatureSource>(std::move(model));
}

std::unique_ptr<DepthSource> MakeLearnedDepthSource(std::shared_ptr<LearnedModel> model) {
  return std::make_unique<LearnedDepthSource>(std::move(model));
}

void WriteUntrainedModel(const std::string& path, const learned::NetworkOptions& options,
                         uint64_t seed, const std::string& notes) {
  learned::Networks networks(options, seed);
  learned::SaveModel(path, *networks, notes);
}

}  // namespace dfo
