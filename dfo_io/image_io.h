// Image files (PNG, JPEG, ...) <-> dfo::Image, and resizing. Every failure names the file.
#ifndef DFO_IO_IMAGE_IO_H_
#define DFO_IO_IMAGE_IO_H_

#include <cstdint>
#include <string>

#include "dfo_core/image.h"

namespace dfo::io {

// Every reader checks the file's header (PNG, JPEG, PGM/PPM, BMP, TIFF) before decoding: a
// truncated or corrupt file (a PNG chunk's CRC, a JPEG without its end-of-image marker) is an
// InputError naming the file and the fault, and a declared size above these caps is refused
// before anything is allocated (8K UHD video is 33 megapixels).
inline constexpr int64_t kMaxImageSide = 32768;
inline constexpr int64_t kMaxImagePixels = 50000000;

// 8-bit grayscale (colour files are converted). Throws dfo::InputError when missing or unreadable.
ImageU8 ReadGray(const std::string& path);
// 8-bit colour, 3 channels in RGB order (grayscale files are replicated).
ImageU8 ReadRgb(const std::string& path);
// 16-bit single-channel PNG as stored (depth maps). Throws when the file is not 16-bit 1-channel.
ImageU16 ReadU16(const std::string& path);
// Depth map in metres from a 16-bit PNG: metres = value / scale (256 KITTI/dfo, 5000 TUM);
// 0 (no depth) stays 0.
ImageF ReadDepthPng(const std::string& path, double scale);

// Writes 1- (gray) or 3-channel (RGB) 8-bit images; the format follows the extension.
void WriteImage(const std::string& path, const ImageU8& image);
// Writes a 16-bit single-channel PNG.
void WriteU16(const std::string& path, const ImageU16& image);
// Writes depth in metres as a 16-bit PNG, value = round(metres * scale); 0, non-finite and values
// beyond the 16-bit range are written as 0 (no depth).
void WriteDepthPng(const std::string& path, const ImageF& depth_m, double scale);

// Width and height of an image file from its header (decoded only when the format is not one
// of those above).
void ReadImageSize(const std::string& path, int* width, int* height);

// Area-averaging resize (for shrinking) / bilinear (for enlarging) of 8-bit images.
ImageU8 Resize(const ImageU8& image, int width, int height);
// Float resize, bilinear, channel-preserving.
ImageF Resize(const ImageF& image, int width, int height);

}  // namespace dfo::io

#endif  // DFO_IO_IMAGE_IO_H_
