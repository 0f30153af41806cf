// A minimal owned image: width x height pixels of `channels` interleaved values of type T,
// row-major. dfo_core stays free of OpenCV; dfo_io converts at the file boundary.
#ifndef DFO_CORE_IMAGE_H_
#define DFO_CORE_IMAGE_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "dfo_core/error.h"

namespace dfo {

template <typename T>
class Image {
 public:
  using Scalar = T;

  Image() = default;
  Image(int width, int height, int channels = 1, T fill = T(0))
      : width_(width), height_(height), channels_(channels) {
    DFO_CHECK(width >= 0 && height >= 0 && channels >= 1)
        << width << "x" << height << "x" << channels;
    data_.assign(static_cast<size_t>(width) * height * channels, fill);
  }

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  size_t size() const { return data_.size(); }
  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  std::vector<T>& vector() { return data_; }
  const std::vector<T>& vector() const { return data_; }

  T& operator()(int x, int y, int c = 0) { return data_[Index(x, y, c)]; }
  const T& operator()(int x, int y, int c = 0) const { return data_[Index(x, y, c)]; }
  T* Row(int y) { return data_.data() + static_cast<size_t>(y) * width_ * channels_; }
  const T* Row(int y) const { return data_.data() + static_cast<size_t>(y) * width_ * channels_; }

  bool InBounds(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_; }

  // Bilinear interpolation of channel c at continuous (x, y) (pixel centres at integers).
  // The caller keeps (x, y) within [0, width-1] x [0, height-1].
  template <typename S>
  S Bilinear(S x, S y, int c = 0) const {
    const int x0 = static_cast<int>(std::floor(x));
    const int y0 = static_cast<int>(std::floor(y));
    const int x1 = x0 + 1 < width_ ? x0 + 1 : x0;
    const int y1 = y0 + 1 < height_ ? y0 + 1 : y0;
    const S ax = x - S(x0);
    const S ay = y - S(y0);
    const S v00 = S((*this)(x0, y0, c)), v10 = S((*this)(x1, y0, c));
    const S v01 = S((*this)(x0, y1, c)), v11 = S((*this)(x1, y1, c));
    return (S(1) - ay) * ((S(1) - ax) * v00 + ax * v10) + ay * ((S(1) - ax) * v01 + ax * v11);
  }

  // Element-wise conversion to another type.
  template <typename U>
  Image<U> Cast() const {
    Image<U> out(width_, height_, channels_);
    for (size_t i = 0; i < data_.size(); ++i) out.vector()[i] = static_cast<U>(data_[i]);
    return out;
  }

 private:
  size_t Index(int x, int y, int c) const {
    return (static_cast<size_t>(y) * width_ + x) * channels_ + c;
  }
  int width_ = 0;
  int height_ = 0;
  int channels_ = 1;
  std::vector<T> data_;
};

using ImageU8 = Image<uint8_t>;
using ImageU16 = Image<uint16_t>;
using ImageF = Image<float>;

// Grey levels of a 1- or 3-channel 8-bit image times `scale` (1: 0-255; 1 / 255: 0-1); an RGB
// image by the ITU-R BT.601 weights, as the synthetic renderer's grey. The caller checks the
// channel count.
inline ImageF GreyLevels(const ImageU8& image, float scale) {
  ImageF grey(image.width(), image.height(), 1);
  const size_t n = static_cast<size_t>(image.width()) * image.height();
  const uint8_t* src = image.data();
  float* dst = grey.data();
  if (image.channels() == 3) {
    for (size_t i = 0; i < n; ++i) {
      dst[i] = (0.299f * src[3 * i] + 0.587f * src[3 * i + 1] + 0.114f * src[3 * i + 2]) * scale;
    }
  } else {
    for (size_t i = 0; i < n; ++i) dst[i] = src[i] * scale;
  }
  return grey;
}

// Largest over smallest value of a one-channel depth map in the (2 radius + 1)^2 square around
// (x, y), which must lie inside the image; +infinity when a value there is not finite and
// positive (a hole). 1 on a surface facing the camera; large at depth edges.
inline float DepthSpread(const ImageF& depth, int x, int y, int radius) {
  float lo = std::numeric_limits<float>::infinity(), hi = 0.0f;
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const float d = depth(x + dx, y + dy);
      if (!(std::isfinite(d) && d > 0.0f)) return std::numeric_limits<float>::infinity();
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
  }
  return hi / lo;
}

}  // namespace dfo

#endif  // DFO_CORE_IMAGE_H_
