#include "dfo_io/image_file_writer.h"

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_io/file_writer.h"

namespace dfo::io {

void WriteImageFile(const cv::Mat& image, const std::string& path, const std::string& what) {
  const std::filesystem::path p(path);
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
  WriteFileAtomically(path, std::string(bytes.begin(), bytes.end()), what);
}

}  // namespace dfo::io
