#include "dfo_io/image_io.h"

#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "dfo_core/error.h"
#include "dfo_io/file_reader.h"
#include "dfo_io/image_file_writer.h"

namespace dfo::io {
namespace {

// What the file's header says, read before anything is decoded.
struct ImageHeader {
  std::string format;  // "PNG", "JPEG", ...; empty when not recognised
  int64_t width = 0;
  int64_t height = 0;
};

uint32_t Be32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}
uint32_t Be16(const unsigned char* p) { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t Le32(const unsigned char* p) {
  return (uint32_t{p[3]} << 24) | (uint32_t{p[2]} << 16) | (uint32_t{p[1]} << 8) | p[0];
}

uint32_t Crc32(const unsigned char* data, size_t n) {
  static const std::array<uint32_t, 256> table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < n; ++i) c = table[(c ^ data[i]) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

// PNG: every chunk complete with a matching CRC, IHDR first and IEND present. Returns what is
// wrong, or "" (then `h` holds the size).
std::string CheckPng(const std::string& bytes, ImageHeader* h) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  size_t pos = 8;
  bool first = true;
  while (true) {
    if (pos + 8 > n) return "truncated PNG (ends at byte " + std::to_string(n) + " before its IEND chunk)";
    const uint32_t length = Be32(b + pos);
    const std::string type(bytes, pos + 4, 4);
    if (length > n || pos + 12 + length > n) {
      return "truncated PNG (chunk " + type + " at byte " + std::to_string(pos) + " needs " +
             std::to_string(length) + " bytes, the file ends at byte " + std::to_string(n) + ")";
    }
    if (Crc32(b + pos + 4, length + 4) != Be32(b + pos + 8 + length)) {
      return "corrupt PNG (CRC mismatch in chunk " + type + " at byte " + std::to_string(pos) + ")";
    }
    if (first) {
      if (type != "IHDR" || length < 8) return "corrupt PNG (the first chunk is not IHDR)";
      h->width = Be32(b + pos + 8);
      h->height = Be32(b + pos + 12);
      first = false;
    }
    if (type == "IEND") return "";
    pos += 12 + length;
  }
}

// JPEG: walks the segments to the frame header (size) and the first scan; a complete file has
// its end-of-image marker after the scan data (a truncated one has not: libjpeg would fill the
// rest with grey and only warn).
std::string CheckJpeg(const std::string& bytes, ImageHeader* h) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  size_t pos = 2;
  while (true) {
    while (pos < n && b[pos] == 0xFF && pos + 1 < n && b[pos + 1] == 0xFF) ++pos;  // fill bytes
    if (pos + 4 > n) return "truncated JPEG (ends at byte " + std::to_string(n) + " in its header)";
    if (b[pos] != 0xFF) {
      return "corrupt JPEG (no segment marker at byte " + std::to_string(pos) + ")";
    }
    const unsigned marker = b[pos + 1];
    if (marker == 0xD8 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) {
      pos += 2;  // markers without a length
      continue;
    }
    if (marker == 0xD9) return "corrupt JPEG (end-of-image marker before any image data)";
    const size_t length = Be16(b + pos + 2);
    if (length < 2 || pos + 2 + length > n) {
      return "truncated JPEG (segment at byte " + std::to_string(pos) + " needs " +
             std::to_string(length) + " bytes, the file ends at byte " + std::to_string(n) + ")";
    }
    const bool frame_header = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 &&
                              marker != 0xC8 && marker != 0xCC;
    if (frame_header && length >= 7) {
      h->height = Be16(b + pos + 5);
      h->width = Be16(b + pos + 7);
    }
    if (marker == 0xDA) {  // start of scan: entropy-coded data follows
      if (h->width == 0) return "corrupt JPEG (scan data before a frame header)";
      const size_t end = bytes.rfind("\xFF\xD9");
      if (end == std::string::npos || end < pos) {
        return "truncated JPEG (no end-of-image marker after its image data; " +
               std::to_string(n) + " bytes)";
      }
      return "";
    }
    pos += 2 + length;
  }
}

// Binary or ASCII PGM/PPM: "P5 <w> <h> <max>" with comments.
std::string CheckPnm(const std::string& bytes, ImageHeader* h) {
  size_t pos = 2;
  int64_t values[2] = {0, 0};
  for (int64_t& v : values) {
    while (pos < bytes.size() && (std::isspace(static_cast<unsigned char>(bytes[pos])) ||
                                  bytes[pos] == '#')) {
      if (bytes[pos] == '#') {
        while (pos < bytes.size() && bytes[pos] != '\n') ++pos;
      } else {
        ++pos;
      }
    }
    if (pos >= bytes.size() || !std::isdigit(static_cast<unsigned char>(bytes[pos]))) {
      return "corrupt PNM header (no image size)";
    }
    while (pos < bytes.size() && std::isdigit(static_cast<unsigned char>(bytes[pos])) &&
           v < (int64_t{1} << 40)) {
      v = v * 10 + (bytes[pos++] - '0');
    }
  }
  h->width = values[0];
  h->height = values[1];
  return "";
}

// TIFF: ImageWidth (256) and ImageLength (257) of the first image file directory.
std::string CheckTiff(const std::string& bytes, ImageHeader* h) {
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const size_t n = bytes.size();
  const bool big = bytes[0] == 'M';
  auto u16 = [&](size_t p) { return big ? Be16(b + p) : (uint32_t{b[p + 1]} << 8) | b[p]; };
  auto u32 = [&](size_t p) { return big ? Be32(b + p) : Le32(b + p); };
  if (n < 8) return "truncated TIFF";
  const size_t ifd = u32(4);
  if (ifd + 2 > n) return "corrupt TIFF (directory beyond the end of the file)";
  const size_t count = u16(ifd);
  if (ifd + 2 + 12 * count > n) return "truncated TIFF (directory beyond the end of the file)";
  for (size_t i = 0; i < count; ++i) {
    const size_t e = ifd + 2 + 12 * i;
    const uint32_t tag = u16(e);
    const uint32_t type = u16(e + 2);
    const uint32_t value = type == 3 ? u16(e + 8) : u32(e + 8);
    if (tag == 256) h->width = value;
    if (tag == 257) h->height = value;
  }
  if (h->width == 0 || h->height == 0) return "corrupt TIFF (no image size)";
  return "";
}

// Reads the header of `bytes`; returns what is wrong with the file or "".
std::string CheckHeader(const std::string& bytes, ImageHeader* h) {
  auto starts = [&](const char* magic, size_t len) {
    return bytes.size() >= len && std::memcmp(bytes.data(), magic, len) == 0;
  };
  if (starts("\x89PNG\r\n\x1a\n", 8)) {
    h->format = "PNG";
    return CheckPng(bytes, h);
  }
  if (starts("\xFF\xD8", 2)) {
    h->format = "JPEG";
    return CheckJpeg(bytes, h);
  }
  if (bytes.size() >= 3 && bytes[0] == 'P' && bytes[1] >= '1' && bytes[1] <= '6') {
    h->format = "PNM";
    return CheckPnm(bytes, h);
  }
  if (starts("BM", 2) && bytes.size() >= 26) {
    h->format = "BMP";
    const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
    h->width = std::abs(static_cast<int32_t>(Le32(b + 18)));
    h->height = std::abs(static_cast<int32_t>(Le32(b + 22)));
    return "";
  }
  if (starts("II*\0", 4) || starts("MM\0*", 4)) {
    h->format = "TIFF";
    return CheckTiff(bytes, h);
  }
  return "";  // not recognised: OpenCV decides
}

// The bytes of image file `path` once its header passed (`header` says what it declares; its
// format is empty when not recognised, and only decoding can tell the size).
std::string ReadCheckedImageFile(const std::string& path, ImageHeader* header) {
  std::string bytes = ReadWholeFile(path, "image file", kMaxImageFileBytes);
  if (bytes.empty()) throw InputError("cannot decode image " + path + ": the file is empty");
  // The header is checked before decoding: a truncated or corrupt file is named (libpng and
  // libjpeg would print their own lines, or fill a truncated JPEG with grey), and the size is
  // capped before the decoder allocates it.
  const std::string problem = CheckHeader(bytes, header);
  if (!problem.empty()) throw InputError("cannot decode image " + path + ": " + problem);
  if (!header->format.empty() &&
      (header->width <= 0 || header->height <= 0 || header->width > kMaxImageSide ||
       header->height > kMaxImageSide || header->width * header->height > kMaxImagePixels)) {
    throw InputError("image " + path + ": its " + header->format + " header declares " +
                     std::to_string(header->width) + " x " + std::to_string(header->height) +
                     " pixels; images must be 1-" + std::to_string(kMaxImageSide) +
                     " pixels a side and at most " + std::to_string(kMaxImagePixels / 1000000) +
                     " megapixels");
  }
  return bytes;
}

cv::Mat Load(const std::string& path, int flags) {
  ImageHeader header;
  const std::string bytes = ReadCheckedImageFile(path, &header);
  cv::Mat m;
  try {
    const cv::Mat raw(1, static_cast<int>(bytes.size()), CV_8UC1,
                      const_cast<char*>(bytes.data()));
    m = cv::imdecode(raw, flags);
  } catch (const cv::Exception& e) {
    throw InputError("cannot decode image " + path + ": " + e.what());
  }
  if (m.empty()) {
    throw InputError("cannot decode image " + path + " (corrupt or not an image)");
  }
  if (int64_t{m.cols} * m.rows > kMaxImagePixels) {
    throw InputError("image " + path + " is " + std::to_string(m.cols) + " x " +
                     std::to_string(m.rows) + " pixels; at most " +
                     std::to_string(kMaxImagePixels / 1000000) + " megapixels");
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
  ImageHeader header;
  const std::string bytes = ReadCheckedImageFile(path, &header);
  if (!header.format.empty()) {
    *width = static_cast<int>(header.width);
    *height = static_cast<int>(header.height);
    return;
  }
  const cv::Mat m = Load(path, cv::IMREAD_UNCHANGED);  // a format only OpenCV knows
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
