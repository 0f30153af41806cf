#include "dfo_io/video_reader.h"

#include <cstdarg>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/avutil.h>
#include <libavutil/log.h>
#include <libavutil/pixdesc.h>
#include <libswscale/swscale.h>
}

#include "dfo_core/error.h"
#include "dfo_io/image_io.h"

namespace dfo::io {
namespace fs = std::filesystem;
namespace {

// Error lines FFmpeg emits on this thread while a reader works (nullptr: none is working).
thread_local std::vector<std::string>* t_ffmpeg_lines = nullptr;
constexpr size_t kMaxKeptLines = 8;

// "mpeg4: ac-tex damaged at 3 4", without FFmpeg's "[mpeg4 @ 0x...]" prefix and newline. Lines
// above AV_LOG_ERROR (warnings, information) and lines outside a reader are dropped.
void FfmpegLogCallback(void* object, int level, const char* format, va_list args) {
  if (t_ffmpeg_lines == nullptr || level > AV_LOG_ERROR) return;
  if (t_ffmpeg_lines->size() >= kMaxKeptLines) return;
  char text[512];
  std::vsnprintf(text, sizeof(text), format, args);
  std::string line(text);
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' ')) {
    line.pop_back();
  }
  if (line.empty()) return;
  const AVClass* cls = object != nullptr ? *static_cast<AVClass* const*>(object) : nullptr;
  if (cls != nullptr && cls->item_name != nullptr) {
    line = std::string(cls->item_name(object)) + ": " + line;
  }
  t_ffmpeg_lines->push_back(std::move(line));
}

// Routes FFmpeg's lines to `lines` for the scope's lifetime (the callback is installed once per
// process, before the first file is opened).
class FfmpegLines {
 public:
  explicit FfmpegLines(std::vector<std::string>* lines) : previous_(t_ffmpeg_lines) {
    static std::once_flag once;
    std::call_once(once, [] { av_log_set_callback(FfmpegLogCallback); });
    t_ffmpeg_lines = lines;
  }
  ~FfmpegLines() { t_ffmpeg_lines = previous_; }
  FfmpegLines(const FfmpegLines&) = delete;
  FfmpegLines& operator=(const FfmpegLines&) = delete;

 private:
  std::vector<std::string>* previous_;
};

std::string AvError(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof(text));
  return text;
}

// The kept lines joined ("a; b"), at most three, then cleared.
std::string TakeLines(std::vector<std::string>* lines) {
  std::string out;
  for (size_t i = 0; i < lines->size() && i < 3; ++i) out += (i > 0 ? "; " : "") + (*lines)[i];
  if (lines->size() > 3) out += "; ...";
  lines->clear();
  return out;
}

}  // namespace

struct VideoReader::Capture {
  AVFormatContext* format = nullptr;
  AVCodecContext* codec = nullptr;
  AVPacket* packet = nullptr;
  AVFrame* frame = nullptr;
  SwsContext* sws = nullptr;
  int stream = -1;
  double time_base_ms = 0.0;   // one tick of the stream's time base in ms
  int64_t start_time = 0;      // the stream's first time, in ticks
  bool flushing = false;       // the demuxer is done: the decoder gives its last frames
  int packets = 0;             // video packets sent to the decoder
  double packet_time_ms = -1;  // presentation time of the last packet sent
  int width = -1;              // frame 0's size (-1: no frame decoded yet)
  int height = -1;
  std::vector<std::string> lines;  // FFmpeg's error lines not yet attributed
  cv::Mat last;                    // the last frame read (BGR, 8-bit)
  int last_index = -1;

  ~Capture() { Close(); }

  void Close() {
    if (sws != nullptr) sws_freeContext(sws);
    sws = nullptr;
    av_frame_free(&frame);
    av_packet_free(&packet);
    avcodec_free_context(&codec);
    if (format != nullptr) avformat_close_input(&format);
    format = nullptr;
    stream = -1;
    flushing = false;
    packets = 0;
    packet_time_ms = -1;
  }

  double TimeMs(int64_t ticks) const {
    return ticks == AV_NOPTS_VALUE ? 0.0 : static_cast<double>(ticks - start_time) * time_base_ms;
  }

  // Decodes the next frame into `frame`: true, or false when the video has no more frames.
  // Packets that give no frame and frames decoded with concealed errors are added to `damage`
  // (nullptr: not recorded) with `index` = the index the next frame will have.
  bool Next(std::vector<VideoDamage>* damage, int index, int* undecodable) {
    const auto packet_failed = [&](const std::string& error) {
      if (damage != nullptr) {
        VideoDamage d;
        d.next_frame = index;
        d.packet = packets - 1;
        d.time_ms = packet_time_ms;
        const std::string lines_text = TakeLines(&lines);
        d.cause = lines_text.empty() ? error : lines_text + " (" + error + ")";
        damage->push_back(std::move(d));
        ++*undecodable;
      }
      lines.clear();
    };
    // Each pass either gets a frame, ends, or consumes a packet: the bound is never reached on a
    // file of fewer packets than this.
    for (int64_t guard = 0; guard < (int64_t{1} << 40); ++guard) {
      const int received = avcodec_receive_frame(codec, frame);
      if (received == 0) {
        const bool flagged =
            frame->decode_error_flags != 0 || (frame->flags & AV_FRAME_FLAG_CORRUPT) != 0;
        if (damage != nullptr && (flagged || !lines.empty())) {
          VideoDamage d;
          d.frame = index;
          d.packet = packets - 1;
          d.time_ms = TimeMs(frame->best_effort_timestamp);
          d.cause = TakeLines(&lines);
          if (d.cause.empty()) {
            d.cause = "the decoder concealed errors in it (decode_error_flags " +
                      std::to_string(frame->decode_error_flags) + ")";
          }
          damage->push_back(std::move(d));
        }
        lines.clear();
        return true;
      }
      if (received == AVERROR_EOF) return false;
      if (received != AVERROR(EAGAIN)) {
        packet_failed(AvError(received));
        continue;
      }
      if (flushing) return false;
      const int read = av_read_frame(format, packet);
      if (read < 0) {
        if (read != AVERROR_EOF && damage != nullptr) {
          VideoDamage d;
          d.next_frame = index;
          d.time_ms = packet_time_ms;
          const std::string lines_text = TakeLines(&lines);
          d.cause = "the container cannot be read further: " + AvError(read) +
                    (lines_text.empty() ? "" : " (" + lines_text + ")");
          damage->push_back(std::move(d));
        }
        lines.clear();
        avcodec_send_packet(codec, nullptr);
        flushing = true;
        continue;
      }
      if (packet->stream_index != stream) {
        av_packet_unref(packet);
        continue;
      }
      ++packets;
      packet_time_ms = packet->pts != AV_NOPTS_VALUE   ? TimeMs(packet->pts)
                       : packet->dts != AV_NOPTS_VALUE ? TimeMs(packet->dts)
                                                       : -1.0;
      const int sent = avcodec_send_packet(codec, packet);
      av_packet_unref(packet);
      if (sent < 0 && sent != AVERROR(EAGAIN) && sent != AVERROR_EOF) packet_failed(AvError(sent));
    }
    return false;
  }
};

VideoReader::VideoReader(std::string path)
    : path_(std::move(path)), capture_(std::make_unique<Capture>()) {
  std::error_code ec;
  if (fs::is_directory(path_, ec)) {
    throw InputError("video file " + path_ + " is a folder, expected a video file (mp4, mkv, avi)");
  }
  if (!fs::is_regular_file(path_, ec)) throw InputError("video file not found: " + path_);
  Reopen();
  reopen_count_ = 0;
}

VideoReader::~VideoReader() = default;

void VideoReader::Reopen() {
  Capture& c = *capture_;
  c.Close();
  FfmpegLines lines(&c.lines);
  c.lines.clear();
  const auto fail = [&](const std::string& what) {
    const std::string said = TakeLines(&c.lines);
    c.Close();
    throw InputError("cannot open video file " + path_ + ": " + what +
                     (said.empty() ? "" : " (FFmpeg: " + said + ")"));
  };
  int r = avformat_open_input(&c.format, path_.c_str(), nullptr, nullptr);
  if (r < 0) {
    c.format = nullptr;
    fail(AvError(r) + ": not a video file, or a container this FFmpeg lacks");
  }
  r = avformat_find_stream_info(c.format, nullptr);
  if (r < 0) fail("cannot read its streams: " + AvError(r));
  const AVCodec* decoder = nullptr;
  r = av_find_best_stream(c.format, AVMEDIA_TYPE_VIDEO, -1, -1, &decoder, 0);
  if (r == AVERROR_STREAM_NOT_FOUND) fail("it has no video stream");
  if (r < 0 || decoder == nullptr) {
    fail("its video codec is one this FFmpeg cannot decode (" + AvError(r) + ")");
  }
  c.stream = r;
  AVStream* stream = c.format->streams[c.stream];
  c.codec = avcodec_alloc_context3(decoder);
  c.packet = av_packet_alloc();
  c.frame = av_frame_alloc();
  if (c.codec == nullptr || c.packet == nullptr || c.frame == nullptr) fail("out of memory");
  r = avcodec_parameters_to_context(c.codec, stream->codecpar);
  if (r < 0) fail("cannot set up its decoder: " + AvError(r));
  c.codec->thread_count = 1;  // frames and log lines in order, on this thread
  c.codec->pkt_timebase = stream->time_base;
  r = avcodec_open2(c.codec, decoder, nullptr);
  if (r < 0) fail("cannot open the " + std::string(decoder->name) + " decoder: " + AvError(r));
  c.time_base_ms = av_q2d(stream->time_base) * 1000.0;
  c.start_time = stream->start_time != AV_NOPTS_VALUE ? stream->start_time : 0;
  c.lines.clear();
  position_ = 0;
  ++reopen_count_;
}

VideoIndex VideoReader::Scan(int max_frames) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (position_ != 0) Reopen();
  Capture& c = *capture_;
  FfmpegLines lines(&c.lines);
  VideoIndex index;
  const AVStream* stream = c.format->streams[c.stream];
  // The size the container declares is checked before the first frame is decoded.
  const int64_t declared_width = stream->codecpar->width;
  const int64_t declared_height = stream->codecpar->height;
  if (declared_width > kMaxImageSide || declared_height > kMaxImageSide ||
      declared_width * declared_height > static_cast<int64_t>(kMaxImagePixels)) {
    throw InputError("video file " + path_ + ": its frames are " + std::to_string(declared_width) +
                     " x " + std::to_string(declared_height) + " pixels; at most " +
                     std::to_string(kMaxImagePixels / 1000000) + " megapixels and " +
                     std::to_string(kMaxImageSide) + " a side");
  }
  const AVRational rate = av_guess_frame_rate(c.format, const_cast<AVStream*>(stream), nullptr);
  const double fps = rate.num > 0 && rate.den > 0 ? av_q2d(rate) : 0.0;
  index.container_fps = fps > 0 && fps < 1e6 ? fps : 0.0;
  if (stream->nb_frames > 0) {
    index.declared_frames = stream->nb_frames;
  } else if (index.container_fps > 0) {
    double duration_s = -1.0;
    if (stream->duration != AV_NOPTS_VALUE && stream->duration > 0) {
      duration_s = static_cast<double>(stream->duration) * av_q2d(stream->time_base);
    } else if (c.format->duration != AV_NOPTS_VALUE && c.format->duration > 0) {
      duration_s = static_cast<double>(c.format->duration) / AV_TIME_BASE;
    }
    if (duration_s > 0) {
      index.declared_frames = std::llround(duration_s * index.container_fps);
      index.declared_estimated = true;
    }
  }
  bool ended = false;
  while (max_frames < 0 || static_cast<int>(index.stamps_ms.size()) < max_frames) {
    const int k = static_cast<int>(index.stamps_ms.size());
    if (!c.Next(&index.damage, k, &index.undecodable_packets)) {
      ended = true;
      break;
    }
    ++position_;
    ++decoded_frames_;
    if (c.width < 0) {
      c.width = c.frame->width;
      c.height = c.frame->height;
    } else if (c.frame->width != c.width || c.frame->height != c.height) {
      throw InputError("video file " + path_ + ", frame " + std::to_string(k) + ": it is " +
                       std::to_string(c.frame->width) + " x " + std::to_string(c.frame->height) +
                       " pixels, the frames before it " + std::to_string(c.width) + " x " +
                       std::to_string(c.height) +
                       "; dfo reads one frame size per video (dataset.last: " +
                       std::to_string(k - 1) + " processes the frames before it)");
    }
    index.stamps_ms.push_back(c.TimeMs(c.frame->best_effort_timestamp));
  }
  index.complete = ended;
  if (index.stamps_ms.empty()) {
    std::string why;
    for (const VideoDamage& d : index.damage) why += (why.empty() ? "" : "; ") + d.cause;
    throw InputError("cannot decode video file " + path_ + ": no frame could be decoded" +
                     (why.empty() ? "" : " (" + why.substr(0, 300) + ")"));
  }
  index.width = c.width;
  index.height = c.height;
  return index;
}

ImageU8 VideoReader::ReadFrame(int k, bool color) {
  DFO_CHECK(k >= 0) << k;
  std::lock_guard<std::mutex> lock(mutex_);
  Capture& c = *capture_;
  const std::string where = "video file " + path_ + ", frame " + std::to_string(k);
  if (c.last_index != k) {
    c.last_index = -1;
    if (k < position_) Reopen();
    FfmpegLines lines(&c.lines);
    int unused = 0;
    while (position_ <= k) {
      if (!c.Next(nullptr, position_, &unused)) {
        throw InputError(where + ": cannot decode the frame (the video ends after " +
                         std::to_string(position_) + " frames, or the frame is corrupt)");
      }
      ++position_;
      ++decoded_frames_;
    }
    const AVFrame& f = *c.frame;
    if (c.width < 0) {
      c.width = f.width;
      c.height = f.height;
    }
    if (f.width != c.width || f.height != c.height) {
      throw InputError(where + ": it is " + std::to_string(f.width) + " x " +
                       std::to_string(f.height) + " pixels, the frames before it " +
                       std::to_string(c.width) + " x " + std::to_string(c.height) +
                       "; dfo reads one frame size per video");
    }
    if (f.format == AV_PIX_FMT_GRAY8) {
      const cv::Mat grey(f.height, f.width, CV_8UC1, f.data[0], static_cast<size_t>(f.linesize[0]));
      cv::cvtColor(grey, c.last, cv::COLOR_GRAY2BGR);
    } else {
      c.sws = sws_getCachedContext(c.sws, f.width, f.height, static_cast<AVPixelFormat>(f.format),
                                   f.width, f.height, AV_PIX_FMT_BGR24, SWS_BICUBIC, nullptr,
                                   nullptr, nullptr);
      if (c.sws == nullptr) {
        throw InputError(where + ": cannot convert its pixel format (" +
                         std::string(av_get_pix_fmt_name(static_cast<AVPixelFormat>(f.format))
                                         ? av_get_pix_fmt_name(static_cast<AVPixelFormat>(f.format))
                                         : "unknown") +
                         ") to 8-bit RGB");
      }
      c.last.create(f.height, f.width, CV_8UC3);
      uint8_t* planes[4] = {c.last.data, nullptr, nullptr, nullptr};
      int strides[4] = {static_cast<int>(c.last.step), 0, 0, 0};
      sws_scale(c.sws, f.data, f.linesize, 0, f.height, planes, strides);
    }
    c.last_index = k;
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
