#include "dfo_core/image_pyramid.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "dfo_core/error.h"

namespace dfo {

void ImagePyramidOptions::Check() const {
  if (num_levels < 1) {
    throw ConfigError("pyramid.num_levels = " + std::to_string(num_levels) + " violates >= 1");
  }
  if (min_level_size < 1) {
    throw ConfigError("pyramid.min_level_size = " + std::to_string(min_level_size) +
                      " violates >= 1");
  }
}

ImageF GaussianBlur(const ImageF& image, double sigma) {
  const int radius = static_cast<int>(std::ceil(3.0 * sigma));
  std::vector<float> kernel(2 * radius + 1);
  double total = 0.0;
  for (int k = -radius; k <= radius; ++k) {
    const double w = std::exp(-0.5 * k * k / (sigma * sigma));
    kernel[k + radius] = static_cast<float>(w);
    total += w;
  }
  for (float& w : kernel) w = static_cast<float>(w / total);
  const int w = image.width(), h = image.height();
  ImageF tmp(w, h), out(w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float s = 0.0f;
      for (int k = -radius; k <= radius; ++k) {
        const int xx = std::min(std::max(x + k, 0), w - 1);
        s += kernel[k + radius] * image(xx, y);
      }
      tmp(x, y) = s;
    }
  }
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float s = 0.0f;
      for (int k = -radius; k <= radius; ++k) {
        const int yy = std::min(std::max(y + k, 0), h - 1);
        s += kernel[k + radius] * tmp(x, yy);
      }
      out(x, y) = s;
    }
  }
  return out;
}

ImageF DownsampleHalf(const ImageF& image) {
  if (image.width() < 2 || image.height() < 2) {
    std::ostringstream msg;
    msg << "cannot halve a " << image.width() << "x" << image.height()
        << " image: 2x2 averaging needs at least 2x2 pixels";
    throw InputError(msg.str());
  }
  const int width = image.width() / 2;
  const int height = image.height() / 2;
  const int channels = image.channels();
  ImageF out(width, height, channels);
  for (int y = 0; y < height; ++y) {
    const float* row0 = image.Row(2 * y);
    const float* row1 = image.Row(2 * y + 1);
    float* dst = out.Row(y);
    for (int x = 0; x < width; ++x) {
      const int i0 = 2 * x * channels;
      const int i1 = i0 + channels;
      for (int c = 0; c < channels; ++c) {
        dst[x * channels + c] =
            0.25f * ((row0[i0 + c] + row0[i1 + c]) + (row1[i0 + c] + row1[i1 + c]));
      }
    }
  }
  return out;
}

ImageGradients ComputeGradients(const ImageF& image) {
  const int w = image.width(), h = image.height(), ch = image.channels();
  ImageGradients g{ImageF(w, h, ch), ImageF(w, h, ch)};
  const int row_len = w * ch;
  for (int y = 0; y < h; ++y) {
    // Neighbour rows (clamped) and the divisor: 2 for central, 1 for one-sided, none for h == 1.
    const int y_minus = y > 0 ? y - 1 : y;
    const int y_plus = y + 1 < h ? y + 1 : y;
    const float y_scale = y_plus > y_minus ? 1.0f / static_cast<float>(y_plus - y_minus) : 0.0f;
    const float* row = image.Row(y);
    const float* row_up = image.Row(y_minus);
    const float* row_down = image.Row(y_plus);
    float* gx = g.gx.Row(y);
    float* gy = g.gy.Row(y);
    for (int i = 0; i < row_len; ++i) gy[i] = (row_down[i] - row_up[i]) * y_scale;
    if (w == 1) {
      for (int c = 0; c < ch; ++c) gx[c] = 0.0f;
      continue;
    }
    // Interior: central differences, no branches (vectorisable).
    for (int i = ch; i < row_len - ch; ++i) gx[i] = 0.5f * (row[i + ch] - row[i - ch]);
    // Borders: one-sided differences.
    for (int c = 0; c < ch; ++c) {
      gx[c] = row[ch + c] - row[c];
      gx[row_len - ch + c] = row[row_len - ch + c] - row[row_len - 2 * ch + c];
    }
  }
  return g;
}

int ImagePyramid::MaxLevels(int width, int height, int min_level_size, int max_levels) {
  int levels = 0;
  while (levels < max_levels && width >= min_level_size && height >= min_level_size && width > 0 &&
         height > 0) {
    ++levels;
    width /= 2;
    height /= 2;
  }
  return levels;
}

ImagePyramid::ImagePyramid(const ImageF& image, const PinholeCamera& camera,
                           const ImagePyramidOptions& options) {
  options.Check();
  if (image.empty()) throw InputError("image pyramid: the input image is empty");
  if (image.width() != camera.width || image.height() != camera.height) {
    std::ostringstream msg;
    msg << "image pyramid: image is " << image.width() << "x" << image.height()
        << " but the camera is " << camera.width << "x" << camera.height
        << "; they must be the same size";
    throw InputError(msg.str());
  }
  const int fit =
      MaxLevels(image.width(), image.height(), options.min_level_size, options.num_levels);
  if (fit < options.num_levels) {
    std::ostringstream msg;
    msg << "image pyramid: a " << image.width() << "x" << image.height()
        << " image is too small for " << options.num_levels << " levels: level "
        << options.num_levels - 1 << " would be " << (image.width() >> (options.num_levels - 1))
        << "x" << (image.height() >> (options.num_levels - 1)) << ", below min_level_size "
        << options.min_level_size << " (at most " << fit << " levels fit)";
    throw InputError(msg.str());
  }
  levels_.reserve(options.num_levels);
  cameras_.reserve(options.num_levels);
  levels_.push_back(image);
  cameras_.push_back(camera);
  for (int l = 1; l < options.num_levels; ++l) {
    levels_.push_back(DownsampleHalf(levels_.back()));
    cameras_.push_back(camera.PyramidLevel(l));
    DFO_CHECK(cameras_.back().width == levels_.back().width() &&
              cameras_.back().height == levels_.back().height())
        << "level " << l << " camera and image sizes disagree";
  }
}

const ImageF& ImagePyramid::level(int l) const {
  DFO_CHECK(l >= 0 && l < num_levels()) << "level " << l << " of " << num_levels();
  return levels_[l];
}

const PinholeCamera& ImagePyramid::camera(int l) const {
  DFO_CHECK(l >= 0 && l < num_levels()) << "level " << l << " of " << num_levels();
  return cameras_[l];
}

ImageGradients ImagePyramid::Gradients(int l) const { return ComputeGradients(level(l)); }

ImageF DownsampleDepthHalf(const ImageF& depth_m) {
  DFO_CHECK(depth_m.channels() == 1 && depth_m.width() >= 2 && depth_m.height() >= 2)
      << depth_m.width() << "x" << depth_m.height() << "x" << depth_m.channels();
  const int w = depth_m.width() / 2, h = depth_m.height() / 2;
  ImageF out(w, h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      float sum = 0.0f;
      int n = 0;
      for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
          const float d = depth_m(2 * x + dx, 2 * y + dy);
          if (std::isfinite(d) && d > 0.0f) {
            sum += d;
            ++n;
          }
        }
      }
      out(x, y) = n > 0 ? sum / static_cast<float>(n) : 0.0f;
    }
  }
  return out;
}

}  // namespace dfo
