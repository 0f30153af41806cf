// Frame-exact access to the frames of a video file (mp4, mkv, avi, ... whatever the installed
// FFmpeg demuxes and decodes), through OpenCV's VideoCapture with its FFmpeg backend
// (cv::CAP_FFMPEG).
//
// Frames are decoded in order from the start of the file and counted; nothing relies on the
// container's seeking, which lands on key frames and is not frame-exact in every container. The
// reader keeps its decoding position: frame k after frame j < k decodes (grabs) the frames in
// between without converting them, so reading a video front to back costs one decode per frame;
// frame k before the position reopens the file and decodes from its start. The last frame read is
// kept, so reading it again costs nothing. Frame k is therefore the same image whatever order the
// frames are read in.
#ifndef DFO_IO_VIDEO_READER_H_
#define DFO_IO_VIDEO_READER_H_

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "dfo_core/image.h"

namespace dfo::io {

// What a scan of a video found.
struct VideoIndex {
  int width = 0;                  // frame size in pixels
  int height = 0;                 //
  double container_fps = 0.0;     // the container's nominal frame rate (CAP_PROP_FPS); 0 = none
  std::vector<double> stamps_ms;  // CAP_PROP_POS_MSEC after decoding each frame (0 when the
                                  // container gives no time for it)
  bool complete = false;          // true: stamps_ms has every frame of the video
};

class VideoReader {
 public:
  // Opens `path` with the FFmpeg backend. Throws InputError naming the file when it is missing,
  // is a folder, or FFmpeg cannot open it as a video ("not a video file or a codec FFmpeg lacks").
  explicit VideoReader(std::string path);
  ~VideoReader();
  VideoReader(const VideoReader&) = delete;
  VideoReader& operator=(const VideoReader&) = delete;

  const std::string& path() const { return path_; }

  // Decodes frames from the start to count them and read their times: all of them, or only the
  // first `max_frames` when max_frames >= 0. Throws InputError naming the file when the video has
  // no decodable frame.
  VideoIndex Scan(int max_frames = -1);

  // Frame k (0-based) as 8-bit RGB (3 channels) or grey (1 channel, OpenCV's BGR-to-grey
  // weights). Thread-safe. Throws InputError naming the file and the frame index when the video
  // ends before frame k or the frame cannot be decoded.
  ImageU8 ReadFrame(int k, bool color);

  // Frames decoded since the reader was made (scans included), and how often the file was
  // reopened to go back: for tests of the access pattern.
  int64_t decoded_frames() const;
  int reopen_count() const;

 private:
  struct Capture;
  void Reopen();

  std::string path_;
  mutable std::mutex mutex_;
  std::unique_ptr<Capture> capture_;
  int position_ = 0;  // index of the next frame a grab decodes
  int64_t decoded_frames_ = 0;
  int reopen_count_ = 0;
};

}  // namespace dfo::io

#endif  // DFO_IO_VIDEO_READER_H_
