#include "dfo_frontend/feature_source.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "dfo_core/check_option.h"
#include "dfo_core/error.h"
#include "dfo_core/image_pyramid.h"

namespace dfo {

void HandmadeFeatureOptions::Check() const {
  internal::CheckOption(
      descriptor == "intensity" || descriptor == "intensity_gradients" || descriptor == "rich",
      "handmade.descriptor", descriptor, "one of {intensity, intensity_gradients, rich}");
  internal::CheckOption(
      std::isfinite(blur_sigma_px) && blur_sigma_px >= 0.0 && blur_sigma_px <= 3.0,
      "handmade.blur_sigma_px", blur_sigma_px, "in [0, 3]");
  internal::CheckOption(std::isfinite(keyframe_blur_sigma_px) && keyframe_blur_sigma_px <= 3.0,
                        "handmade.keyframe_blur_sigma_px", keyframe_blur_sigma_px,
                        "in [0, 3], or < 0 for handmade.blur_sigma_px");
}

namespace {

// Grey image in [0, 1] from a 1- or 3-channel 8-bit image (ITU-R BT.601 weights, as the
// synthetic renderer's grey).
ImageF ToGray(const ImageU8& image, int frame_index) {
  if (image.channels() != 1 && image.channels() != 3) {
    std::ostringstream msg;
    msg << "frame " << frame_index << ": image has " << image.channels()
        << " channels; expected 1 (grey) or 3 (RGB)";
    throw InputError(msg.str());
  }
  return GreyLevels(image, 1.0f / 255.0f);
}

// 3x3 box mean with clamped borders.
ImageF BoxBlur3(const ImageF& image) {
  const int w = image.width(), h = image.height();
  ImageF out(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float s = 0.0f;
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = std::min(std::max(y + dy, 0), h - 1);
        for (int dx = -1; dx <= 1; ++dx) {
          s += image(std::min(std::max(x + dx, 0), w - 1), yy);
        }
      }
      out(x, y) = s * (1.0f / 9.0f);
    }
  }
  return out;
}

void CopyChannel(const ImageF& image, FeatureLevel* level, int c) {
  std::copy(image.data(), image.data() + image.size(), level->Channel(c));
}

}  // namespace

HandmadeFeatureSource::HandmadeFeatureSource(const HandmadeFeatureOptions& options)
    : options_(options) {
  options_.Check();
}

int HandmadeFeatureSource::num_channels() const {
  if (options_.descriptor == "intensity") return 1;
  return options_.descriptor == "rich" ? 5 : 3;
}

FeaturePyramid HandmadeFeatureSource::Compute(const Frame& frame, int num_levels) {
  DFO_CHECK(num_levels >= 1) << num_levels;
  if (frame.image.empty()) {
    throw InputError("frame " + std::to_string(frame.index) + ": the image is empty");
  }
  ImagePyramidOptions pyramid_options;
  pyramid_options.num_levels = num_levels;
  pyramid_options.min_level_size = 4;
  ImagePyramid pyramid;
  try {
    pyramid = ImagePyramid(ToGray(frame.image, frame.index), frame.camera, pyramid_options);
  } catch (const ConfigError&) {
    throw;
  } catch (const InputError& e) {
    throw InputError("frame " + std::to_string(frame.index) + ": " + e.what());
  }
  FeaturePyramid out;
  const int channels = num_channels();
  for (int l = 0; l < num_levels; ++l) {
    ImageF gray = pyramid.level(l);
    if (options_.blur_sigma_px > 0.0) gray = GaussianBlur(gray, options_.blur_sigma_px);
    const ImageGradients g = ComputeGradients(gray);
    FeatureLevel level(gray.width(), gray.height(), channels, pyramid.camera(l));
    level.derivative_order.assign(channels, 0);
    CopyChannel(gray, &level, 0);
    if (channels >= 3) {
      CopyChannel(g.gx, &level, 1);
      CopyChannel(g.gy, &level, 2);
      level.derivative_order[1] = level.derivative_order[2] = 1;
    }
    if (channels == 5) {
      CopyChannel(BoxBlur3(gray), &level, 3);
      level.derivative_order[4] = 1;
      float* mag = level.Channel(4);
      for (size_t i = 0; i < gray.size(); ++i) {
        mag[i] = std::sqrt(g.gx.data()[i] * g.gx.data()[i] + g.gy.data()[i] * g.gy.data()[i]);
      }
    }
    level.ZScore();
    out.levels.push_back(std::move(level));
  }
  return out;
}

std::unique_ptr<FeatureSource> MakeFeatureSource(const std::string& name,
                                                 const HandmadeFeatureOptions& handmade) {
  if (name == "handmade") return std::make_unique<HandmadeFeatureSource>(handmade);
  if (name == "learned") {
    // The learned source needs a loaded model (LibTorch, dfo::learned), which dfo::frontend
    // cannot link; the application makes it and hands it to the Frontend.
    throw ConfigError(
        "frontend.features = learned: the learned feature source comes from a model file loaded "
        "by the application (learned.model; dfo_run and dfo_bench do this), not from "
        "MakeFeatureSource");
  }
  throw ConfigError("frontend.features = " + name + " violates one of {handmade, learned}");
}

}  // namespace dfo
