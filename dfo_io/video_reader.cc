#include "dfo_io/video_reader.h"

#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <opencv2/videoio/registry.hpp>
#include <utility>

#include "dfo_core/error.h"
#include "dfo_io/image_io.h"

namespace dfo::io {
namespace fs = std::filesystem;

struct VideoReader::Capture {
  cv::VideoCapture capture;
  cv::Mat last;  // the last frame read (BGR, 8-bit), a copy of the decoder's buffer
  int last_index = -1;
};

VideoReader::VideoReader(std::string path)
    : path_(std::move(path)), capture_(std::make_unique<Capture>()) {
  std::error_code ec;
  if (fs::is_directory(path_, ec)) {
    throw InputError("video file " + path_ + " is a folder, expected a video file (mp4, mkv, avi)");
  }
  if (!fs::is_regular_file(path_, ec)) throw InputError("video file not found: " + path_);
  if (!cv::videoio_registry::hasBackend(cv::CAP_FFMPEG)) {
    throw InputError("cannot read video file " + path_ +
                     ": this OpenCV has no FFmpeg backend (install Debian's libopencv-videoio, "
                     "built with FFmpeg: tools/install_deps.sh)");
  }
  Reopen();
  reopen_count_ = 0;
}

VideoReader::~VideoReader() = default;

void VideoReader::Reopen() {
  capture_->capture.release();
  bool opened = false;
  try {
    opened = capture_->capture.open(path_, cv::CAP_FFMPEG);
  } catch (const cv::Exception& e) {
    throw InputError("cannot open video file " + path_ + ": " + e.what());
  }
  if (!opened || !capture_->capture.isOpened()) {
    throw InputError("cannot open video file " + path_ +
                     " with OpenCV's FFmpeg backend: not a video file, or a container or codec "
                     "this FFmpeg lacks");
  }
  position_ = 0;
  ++reopen_count_;
}

VideoIndex VideoReader::Scan(int max_frames) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (position_ != 0) Reopen();
  VideoIndex index;
  cv::VideoCapture& cap = capture_->capture;
  bool ended = false;
  try {
    // The size the container declares is checked before the first frame is decoded.
    const double declared_width = cap.get(cv::CAP_PROP_FRAME_WIDTH);
    const double declared_height = cap.get(cv::CAP_PROP_FRAME_HEIGHT);
    if (declared_width > kMaxImageSide || declared_height > kMaxImageSide ||
        declared_width * declared_height > static_cast<double>(kMaxImagePixels)) {
      throw InputError("video file " + path_ + ": its frames are " +
                       std::to_string(static_cast<long long>(declared_width)) + " x " +
                       std::to_string(static_cast<long long>(declared_height)) +
                       " pixels; at most " + std::to_string(kMaxImagePixels / 1000000) +
                       " megapixels and " + std::to_string(kMaxImageSide) + " a side");
    }
    while (max_frames < 0 || static_cast<int>(index.stamps_ms.size()) < max_frames) {
      if (!cap.grab()) {
        ended = true;
        break;
      }
      ++position_;
      ++decoded_frames_;
      index.stamps_ms.push_back(cap.get(cv::CAP_PROP_POS_MSEC));
    }
    index.width = static_cast<int>(cap.get(cv::CAP_PROP_FRAME_WIDTH));
    index.height = static_cast<int>(cap.get(cv::CAP_PROP_FRAME_HEIGHT));
    const double fps = cap.get(cv::CAP_PROP_FPS);
    index.container_fps = fps > 0 && fps < 1e6 ? fps : 0.0;
  } catch (const cv::Exception& e) {
    throw InputError("cannot decode video file " + path_ + ", frame " +
                     std::to_string(index.stamps_ms.size()) + ": " + e.what());
  }
  index.complete = ended;
  if (index.stamps_ms.empty()) {
    throw InputError("cannot decode video file " + path_ + ": no frame could be decoded");
  }
  if (index.width <= 0 || index.height <= 0) {
    throw InputError("video file " + path_ + ": the container gives no frame size");
  }
  return index;
}

ImageU8 VideoReader::ReadFrame(int k, bool color) {
  DFO_CHECK(k >= 0) << k;
  std::lock_guard<std::mutex> lock(mutex_);
  Capture& c = *capture_;
  const std::string where = "video file " + path_ + ", frame " + std::to_string(k);
  if (c.last_index != k) {
    try {
      if (k < position_) Reopen();
      // Decode (without converting) up to frame k, then decode and convert frame k.
      while (position_ <= k) {
        if (!c.capture.grab()) {
          throw InputError(where + ": cannot decode the frame (the video ends after " +
                           std::to_string(position_) + " frames, or the frame is corrupt)");
        }
        ++position_;
        ++decoded_frames_;
      }
      cv::Mat frame;
      if (!c.capture.retrieve(frame) || frame.empty()) {
        throw InputError(where + ": cannot decode the frame (corrupt)");
      }
      if (frame.depth() != CV_8U || (frame.channels() != 3 && frame.channels() != 1)) {
        throw InputError(where + ": unexpected decoded pixel format (" +
                         std::to_string(frame.channels()) + " channels, depth " +
                         std::to_string(frame.depth()) + "), expected 8-bit BGR");
      }
      if (frame.channels() == 1) {
        cv::cvtColor(frame, c.last, cv::COLOR_GRAY2BGR);
      } else {
        c.last = frame.clone();
      }
      c.last_index = k;
    } catch (const cv::Exception& e) {
      c.last_index = -1;
      throw InputError(where + ": cannot decode the frame: " + e.what());
    } catch (const InputError&) {
      c.last_index = -1;
      throw;
    }
  }
  ImageU8 out(c.last.cols, c.last.rows, color ? 3 : 1);
  cv::Mat dst(out.height(), out.width(), CV_8UC(out.channels()), out.data());
  cv::cvtColor(c.last, dst, color ? cv::COLOR_BGR2RGB : cv::COLOR_BGR2GRAY);
  DFO_CHECK(dst.ptr<void>() == static_cast<void*>(out.data())) << "cvtColor reallocated its output";
  return out;
}

int64_t VideoReader::decoded_frames() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return decoded_frames_;
}

int VideoReader::reopen_count() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return reopen_count_;
}

}  // namespace dfo::io
