// Frame-exact access to the frames of a video file (mp4, mkv, avi, ... whatever the installed
// FFmpeg demuxes and decodes), read through FFmpeg's own libraries (libavformat, libavcodec,
// libswscale), so that the decoder's errors are seen rather than hidden.
//
// Frames are decoded in order from the start of the file and counted; nothing relies on the
// container's seeking, which lands on key frames and is not frame-exact in every container. The
// reader keeps its decoding position: frame k after frame j < k decodes the frames in between
// without converting them, so reading a video front to back costs one decode per frame; frame k
// before the position reopens the file and decodes from its start. The last frame read is kept,
// so reading it again costs nothing. Frame k is therefore the same image whatever order the frames
// are read in. "Frame k" is the k-th frame the decoder gives: a packet it cannot decode gives no
// frame (Scan reports it in VideoIndex::damage).
//
// FFmpeg's own log lines never reach stderr: the reader installs a process-wide av_log callback
// that keeps the error lines emitted while one of its files is opened or decoded (they become the
// `cause` of a VideoDamage, or part of an InputError's message) and drops every other line.
#ifndef DFO_IO_VIDEO_READER_H_
#define DFO_IO_VIDEO_READER_H_

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "dfo_core/image.h"

namespace dfo::io {

// Damage met while decoding: a frame the decoder gave but concealed errors in (frame >= 0), a
// packet it could not decode at all (frame = -1: that frame of the video is missing), or a
// container that cannot be read past some point (frame = -1, packet = -1).
struct VideoDamage {
  int frame = -1;       // index of the decoded frame showing the damage; -1 = no frame came of it
  int next_frame = -1;  // frame = -1: the index of the first frame decoded after the damage
  int packet = -1;      // index of the packet among the video stream's packets; -1 = none
  double time_ms = -1;  // presentation time of the frame or packet in ms; -1 = unknown
  std::string cause;    // FFmpeg's own words (its first error lines), or the decoder's flags
};

// What a scan of a video found.
struct VideoIndex {
  int width = 0;                  // frame size in pixels
  int height = 0;                 //
  double container_fps = 0.0;     // the container's frame rate (FFmpeg's guess); 0 = none
  std::vector<double> stamps_ms;  // presentation time of each decoded frame in ms from the
                                  // stream's start (0 when the container gives none)
  bool complete = false;          // true: stamps_ms has every frame of the video
  // Frames the container announces: its frame count, or (declared_estimated) its duration times
  // its frame rate; -1 when it states neither.
  int64_t declared_frames = -1;
  bool declared_estimated = false;
  int undecodable_packets = 0;      // video packets that gave no frame (also in damage)
  std::vector<VideoDamage> damage;  // in decoding order
};

class VideoReader {
 public:
  // Opens `path`. Throws InputError naming the file when it is missing, is a folder, or FFmpeg
  // cannot open it as a video (with FFmpeg's reason: "moov atom not found", ...).
  explicit VideoReader(std::string path);
  ~VideoReader();
  VideoReader(const VideoReader&) = delete;
  VideoReader& operator=(const VideoReader&) = delete;

  const std::string& path() const { return path_; }

  // Decodes frames from the start to count them, read their times and find damage: all of them,
  // or only the first `max_frames` when max_frames >= 0. Throws InputError naming the file when
  // the video has no decodable frame, and naming the frame when a frame's size differs from
  // frame 0's (dfo reads one frame size per video).
  VideoIndex Scan(int max_frames = -1);

  // Frame k (0-based) as 8-bit RGB (3 channels) or grey (1 channel, OpenCV's BGR-to-grey
  // weights). Thread-safe. Throws InputError naming the file and the frame index when the video
  // ends before frame k or the frame's size differs from frame 0's.
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
  int position_ = 0;  // index of the next frame decoding gives
  int64_t decoded_frames_ = 0;
  int reopen_count_ = 0;
};

}  // namespace dfo::io

#endif  // DFO_IO_VIDEO_READER_H_
