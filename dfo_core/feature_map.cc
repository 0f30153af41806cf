#include "dfo_core/feature_map.h"

#include <algorithm>
#include <cmath>

#include "dfo_core/error.h"
#include "dfo_core/image_pyramid.h"

namespace dfo {

FeatureLevel::FeatureLevel(int width_, int height_, int channels_, const PinholeCamera& camera_)
    : width(width_), height(height_), channels(channels_), camera(camera_) {
  DFO_CHECK(width >= 0 && height >= 0 && channels >= 1)
      << width << "x" << height << "x" << channels;
  data.assign(static_cast<size_t>(width) * height * channels, 0.0f);
}

void FeatureLevel::ZScore() {
  const size_t n = static_cast<size_t>(width) * height;
  if (n == 0) return;
  for (int c = 0; c < channels; ++c) {
    float* v = Channel(c);
    // Two passes in double: the mean first, then the variance about it (no cancellation).
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i) sum += v[i];
    const double mean = sum / static_cast<double>(n);
    double sq = 0.0;
    for (size_t i = 0; i < n; ++i) sq += (v[i] - mean) * (v[i] - mean);
    const double stddev = std::sqrt(sq / static_cast<double>(n));
    const float m = static_cast<float>(mean);
    const float inv = stddev > 1e-12 ? static_cast<float>(1.0 / stddev) : 0.0f;
    for (size_t i = 0; i < n; ++i) v[i] = (v[i] - m) * inv;
  }
}

double DepthPyramid::MeanDepth(int l) const {
  DFO_CHECK(l >= 0 && l < num_levels()) << l;
  double sum = 0.0;
  size_t n = 0;
  for (float d : levels[l].vector()) {
    if (d > 0.0f) {
      sum += d;
      ++n;
    }
  }
  return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

void DepthPyramid::Scale(double factor) {
  for (ImageF& level : levels) {
    for (float& d : level.vector()) d = static_cast<float>(d * factor);
  }
}

int DepthPyramid::NumValid(int l) const {
  DFO_CHECK(l >= 0 && l < num_levels()) << l;
  int n = 0;
  for (float d : levels[l].vector()) n += d > 0.0f ? 1 : 0;
  return n;
}

FeatureLevel GaussianBlur(const FeatureLevel& level, double sigma) {
  FeatureLevel out = level;
  const size_t n = static_cast<size_t>(level.width) * level.height;
  ImageF channel(level.width, level.height);
  for (int c = 0; c < level.channels; ++c) {
    std::copy(level.Channel(c), level.Channel(c) + n, channel.vector().begin());
    const ImageF blurred = GaussianBlur(channel, sigma);
    std::copy(blurred.vector().begin(), blurred.vector().end(), out.Channel(c));
  }
  return out;
}

}  // namespace dfo
