#include "dfo_io/image_file_writer.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "dfo_core/error.h"

namespace dfo::io {

void WriteImageFile(const cv::Mat& image, const std::string& path, const std::string& what) {
  const std::filesystem::path p(path);
  std::error_code ec;
  if (!p.parent_path().empty()) std::filesystem::create_directories(p.parent_path(), ec);
  const std::string extension = p.has_extension() ? p.extension().string() : ".png";
  std::vector<uchar> bytes;
  bool encoded = false;
  try {
    encoded = cv::imencode(extension, image, bytes);
  } catch (const cv::Exception& e) {
    throw InputError(what + " " + path + ": cannot be encoded as " + extension + " (" + e.what() +
                     ")");
  }
  if (!encoded) throw InputError(what + " " + path + ": cannot be encoded as " + extension);
  const std::string tmp = path + ".tmp";
  std::FILE* file = std::fopen(tmp.c_str(), "wb");
  if (file == nullptr) {
    throw InputError(what + " " + path + ": cannot be written (" + std::strerror(errno) + ")");
  }
  const bool written = std::fwrite(bytes.data(), 1, bytes.size(), file) == bytes.size();
  const int write_error = errno;
  const bool closed = std::fclose(file) == 0;
  if (!written || !closed) {
    const int error = !written ? write_error : errno;
    std::remove(tmp.c_str());
    throw InputError(what + " " + path + ": cannot be written (" + std::strerror(error) + ")");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(tmp.c_str());
    throw InputError(what + " " + path + ": cannot be written (renaming " + tmp +
                     " onto it: " + std::strerror(error) + ")");
  }
}

}  // namespace dfo::io
