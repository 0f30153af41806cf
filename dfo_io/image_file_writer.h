// The one writer of image files in dfo_io (PNGs of images and depth maps, plots): encodes with
// OpenCV by the file's extension and writes with WriteFileAtomically (file_writer.h), so a failed
// write (full disk, a folder in the way) never leaves a partial file under the final name.
#ifndef DFO_IO_IMAGE_FILE_WRITER_H_
#define DFO_IO_IMAGE_FILE_WRITER_H_

#include <opencv2/core.hpp>
#include <string>

namespace dfo::io {

// Writes `image` to `path` (format from the extension, e.g. .png), creating missing parent
// folders. Throws InputError "<what> <path>: <reason>" (the system's reason for a failed write)
// when it cannot be encoded or written.
void WriteImageFile(const cv::Mat& image, const std::string& path, const std::string& what);

}  // namespace dfo::io

#endif  // DFO_IO_IMAGE_FILE_WRITER_H_
