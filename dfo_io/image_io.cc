#include "dfo_io/image_io.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dfo_core/error.h"
#include "dfo_io/image_file_writer.h"

namespace dfo::io {
namespace {

cv::Mat Load(const std::string& path, int flags) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw InputError("image file not found: " + path);
  }
  cv::Mat m;
  try {
    m = cv::imread(path, flags);
  } catch (const cv::Exception& e) {
    throw InputError("cannot decode image " + path + ": " + e.what());
  }
  if (m.empty()) {
    throw InputError("cannot decode image " + path + " (corrupt or not an image)");
  }
  return m;
}

template <typename T>
Image<T> FromMat(const cv::Mat& m) {
  Image<T> out(m.cols, m.rows, m.channels());
  const size_t row_bytes = static_cast<size_t>(m.cols) * m.channels() * sizeof(T);
  for (int y = 0; y < m.rows; ++y) std::memcpy(out.Row(y), m.ptr(y), row_bytes);
  return out;
}

template <typename T>
cv::Mat ToMat(const Image<T>& image, int depth) {
  cv::Mat m(image.height(), image.width(), CV_MAKETYPE(depth, image.channels()));
  const size_t row_bytes = static_cast<size_t>(image.width()) * image.channels() * sizeof(T);
  for (int y = 0; y < image.height(); ++y) std::memcpy(m.ptr(y), image.Row(y), row_bytes);
  return m;
}

void Save(const std::string& path, const cv::Mat& m) { WriteImageFile(m, path, "image"); }

}  // namespace

ImageU8 ReadGray(const std::string& path) {
  cv::Mat m = Load(path, cv::IMREAD_GRAYSCALE);
  return FromMat<uint8_t>(m);
}

ImageU8 ReadRgb(const std::string& path) {
  cv::Mat m = Load(path, cv::IMREAD_COLOR);
  cv::Mat rgb;
  cv::cvtColor(m, rgb, cv::COLOR_BGR2RGB);
  return FromMat<uint8_t>(rgb);
}

ImageU16 ReadU16(const std::string& path) {
  cv::Mat m = Load(path, cv::IMREAD_UNCHANGED);
  if (m.depth() != CV_16U || m.channels() != 1) {
    throw InputError("expected a 16-bit single-channel PNG in " + path + ", found " +
                     std::to_string(m.channels()) + " channel(s) of " +
                     (m.depth() == CV_8U ? std::string("8-bit") : std::string("non-16-bit")) +
                     " data");
  }
  return FromMat<uint16_t>(m);
}

ImageF ReadDepthPng(const std::string& path, double scale) {
  DFO_CHECK(scale > 0) << scale;
  const ImageU16 raw = ReadU16(path);
  ImageF depth(raw.width(), raw.height(), 1);
  for (size_t i = 0; i < raw.size(); ++i) {
    depth.vector()[i] = static_cast<float>(raw.vector()[i] / scale);
  }
  return depth;
}

void WriteImage(const std::string& path, const ImageU8& image) {
  DFO_CHECK(image.channels() == 1 || image.channels() == 3) << image.channels();
  cv::Mat m = ToMat(image, CV_8U);
  if (image.channels() == 3) cv::cvtColor(m, m, cv::COLOR_RGB2BGR);
  Save(path, m);
}

void WriteU16(const std::string& path, const ImageU16& image) {
  DFO_CHECK(image.channels() == 1) << image.channels();
  Save(path, ToMat(image, CV_16U));
}

void WriteDepthPng(const std::string& path, const ImageF& depth_m, double scale) {
  DFO_CHECK(depth_m.channels() == 1) << depth_m.channels();
  ImageU16 raw(depth_m.width(), depth_m.height(), 1);
  for (size_t i = 0; i < depth_m.size(); ++i) {
    const double v = std::round(static_cast<double>(depth_m.vector()[i]) * scale);
    raw.vector()[i] = (std::isfinite(v) && v > 0 && v <= 65535.0) ? static_cast<uint16_t>(v) : 0;
  }
  WriteU16(path, raw);
}

void ReadImageSize(const std::string& path, int* width, int* height) {
  const cv::Mat m = Load(path, cv::IMREAD_UNCHANGED);
  *width = m.cols;
  *height = m.rows;
}

ImageU8 Resize(const ImageU8& image, int width, int height) {
  if (image.width() == width && image.height() == height) return image;
  const cv::Mat src = ToMat(image, CV_8U);
  cv::Mat dst;
  const bool shrink = width <= image.width() && height <= image.height();
  cv::resize(src, dst, cv::Size(width, height), 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
  return FromMat<uint8_t>(dst);
}

ImageF Resize(const ImageF& image, int width, int height) {
  if (image.width() == width && image.height() == height) return image;
  const cv::Mat src = ToMat(image, CV_32F);
  cv::Mat dst;
  cv::resize(src, dst, cv::Size(width, height), 0, 0, cv::INTER_LINEAR);
  return FromMat<float>(dst);
}

}  // namespace dfo::io
