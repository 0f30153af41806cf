#include "dfo_io/lcm/event_log.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

#include "dfo_core/error.h"

namespace dfo::io {
namespace {

// Sync word, event number, timestamp, channel length, data length.
constexpr int64_t kHeaderBytes = 4 + 8 + 8 + 4 + 4;
// LCM's eventlog.c refuses channel lengths outside 1..999.
constexpr int32_t kChannelLengthLimit = 1000;
// Bytes read at a time (and so the least memory the reader holds).
constexpr int64_t kChunkBytes = 1 << 16;

uint32_t BigEndian32(const uint8_t* p) {
  return (static_cast<uint32_t>(p[0]) << 24) | (static_cast<uint32_t>(p[1]) << 16) |
         (static_cast<uint32_t>(p[2]) << 8) | static_cast<uint32_t>(p[3]);
}

// The bytes of a log file, read through a window that moves along the file (pread, so the
// position never matters). A request is never larger than what is left of the file, so the
// window never holds more than the file's size.
class FileBytes {
 public:
  explicit FileBytes(const std::string& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) {
      throw InputError("cannot open the LCM event log " + path +
                       " (does it exist, is it readable?)");
    }
    struct stat st {};
    if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
      const bool folder = S_ISDIR(st.st_mode);
      ::close(fd_);
      throw InputError("the LCM event log " + path + " is " +
                       (folder ? "a folder" : "not a regular file") + ", expected a log file");
    }
    size_ = static_cast<int64_t>(st.st_size);
  }
  ~FileBytes() { ::close(fd_); }
  FileBytes(const FileBytes&) = delete;
  FileBytes& operator=(const FileBytes&) = delete;

  int64_t size() const { return size_; }

  // Bytes [offset, offset + n) with offset + n <= size(); valid until the next call.
  const uint8_t* Get(int64_t offset, int64_t n) {
    static const uint8_t kNothing = 0;
    if (n == 0) return &kNothing;
    if (offset >= begin_ && offset + n <= begin_ + length_)
      return buffer_.data() + (offset - begin_);
    const int64_t want = std::min(std::max(n, kChunkBytes), size_ - offset);
    if (static_cast<int64_t>(buffer_.size()) < want) buffer_.resize(static_cast<size_t>(want));
    int64_t done = 0;
    while (done < want) {
      const ssize_t got = ::pread(fd_, buffer_.data() + done, static_cast<size_t>(want - done),
                                  static_cast<off_t>(offset + done));
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) {
        length_ = 0;
        throw InputError("reading the LCM event log " + path_ + " failed at byte offset " +
                         std::to_string(offset + done) + ": " +
                         (got < 0 ? std::strerror(errno) : "the file became shorter"));
      }
      done += got;
    }
    begin_ = offset;
    length_ = want;
    return buffer_.data();
  }

 private:
  std::string path_;
  int fd_ = -1;
  int64_t size_ = 0;
  std::vector<uint8_t> buffer_;
  int64_t begin_ = 0;   // file offset of buffer_[0]
  int64_t length_ = 0;  // valid bytes in buffer_
};

bool SyncWordAt(FileBytes* file, int64_t offset) {
  return file->size() - offset >= 4 && BigEndian32(file->Get(offset, 4)) == kLcmLogSyncWord;
}

// True when the bytes from `offset` to the end of the file are the first 0..3 bytes of a sync
// word: an event cut off inside its sync word (or nothing at all).
bool SyncWordPrefixAtEnd(FileBytes* file, int64_t offset) {
  const int64_t left = file->size() - offset;
  if (left >= 4) return false;
  static const uint8_t kSync[4] = {0xED, 0xA1, 0xDA, 0x01};
  return std::memcmp(file->Get(offset, left), kSync, static_cast<size_t>(left)) == 0;
}

// The end offset of the event whose header is at `offset`, or -1 when its header is impossible:
// no sync word, a channel length outside 1..999, a data length < 0, or an end beyond the file
// (int64 arithmetic: a length field of 2^31 - 1 is simply too large, nothing is allocated).
int64_t EventEnd(FileBytes* file, int64_t offset) {
  if (file->size() - offset < kHeaderBytes) return -1;
  const uint8_t* header = file->Get(offset, kHeaderBytes);
  if (BigEndian32(header) != kLcmLogSyncWord) return -1;
  const auto channel_length = static_cast<int32_t>(BigEndian32(header + 20));
  const auto data_length = static_cast<int32_t>(BigEndian32(header + 24));
  if (channel_length <= 0 || channel_length >= kChannelLengthLimit || data_length < 0) return -1;
  const int64_t end = offset + kHeaderBytes + channel_length + data_length;
  return end <= file->size() ? end : -1;
}

// True when the event ending at `end` is followed by the next sync word or by the end of the
// file (LCM's reader checks the same).
bool FollowedByEventOrEnd(FileBytes* file, int64_t end) {
  return SyncWordAt(file, end) || SyncWordPrefixAtEnd(file, end);
}

// Offset of the first sync word at or after `from`, or -1.
int64_t FindSyncWord(FileBytes* file, int64_t from) {
  int64_t offset = from;
  while (file->size() - offset >= 4) {
    const int64_t n = std::min(kChunkBytes, file->size() - offset);
    const uint8_t* bytes = file->Get(offset, n);
    for (int64_t i = 0; i + 4 <= n; ++i) {
      if (BigEndian32(bytes + i) == kLcmLogSyncWord) return offset + i;
    }
    offset += n - 3;  // a word may straddle the chunk boundary
  }
  return -1;
}

// True when an event with a possible header that is followed by another event (or the end of the
// file) begins in [from, to).
bool WellFramedEventWithin(FileBytes* file, int64_t from, int64_t to) {
  for (int64_t at = FindSyncWord(file, from); at >= 0 && at < to; at = FindSyncWord(file, at + 1)) {
    const int64_t end = EventEnd(file, at);
    if (end >= 0 && FollowedByEventOrEnd(file, end)) return true;
  }
  return false;
}

// The end offset of the event at `offset`, or -1 when it is not taken: its header must be
// possible, and either the next event (or the end of the file) follows it, or no well-framed
// event begins inside it (the damage lies behind it: garbage, the next event's sync word
// corrupted). A well-framed event inside it means its length field is corrupted.
int64_t TakenEventEnd(FileBytes* file, int64_t offset) {
  const int64_t end = EventEnd(file, offset);
  if (end < 0) return -1;
  if (FollowedByEventOrEnd(file, end)) return end;
  return WellFramedEventWithin(file, offset + 1, end) ? -1 : end;
}

// Offset of the first event at or after `from` that is taken, or -1.
int64_t NextTakenEvent(FileBytes* file, int64_t from) {
  for (int64_t at = FindSyncWord(file, from); at >= 0; at = FindSyncWord(file, at + 1)) {
    if (TakenEventEnd(file, at) >= 0) return at;
  }
  return -1;
}

std::string Plural(int64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

}  // namespace

std::string LcmLogReadResult::Summary() const {
  std::string s = path + ": ";
  if (skipped_bytes > 0) {
    s += "skipped " + Plural(skipped_bytes, "corrupted byte", "corrupted bytes") + " in " +
         Plural(skipped_places, "place", "places") + " (first at byte offset " +
         std::to_string(first_skipped_offset) + "); ";
  }
  s += "read " + Plural(events, "event", "events");
  if (cut_off_at_end) s += "; the last event is cut off at the end of the file";
  return s;
}

LcmLogReadResult ReadLcmLog(
    const std::string& path,
    const std::function<bool(const std::string& channel, const void* data, size_t size)>& handle) {
  FileBytes file(path);
  LcmLogReadResult result;
  result.path = path;
  result.file_bytes = file.size();
  if (file.size() == 0) throw InputError("no LCM events in " + path + ": the file is empty");
  std::string channel;
  int64_t offset = 0;
  while (offset < file.size()) {
    const int64_t end = TakenEventEnd(&file, offset);
    if (end < 0) {
      // Damaged from here: resume at the next event that is taken, as LCM's reader
      // resynchronises on the next sync word.
      const bool starts_like_an_event =
          SyncWordAt(&file, offset) || SyncWordPrefixAtEnd(&file, offset);
      const int64_t next = NextTakenEvent(&file, offset + 1);
      const int64_t resume = next >= 0 ? next : file.size();
      if (result.skipped_places == 0) result.first_skipped_offset = offset;
      ++result.skipped_places;
      result.skipped_bytes += resume - offset;
      result.cut_off_at_end = next < 0 && starts_like_an_event;
      offset = resume;
      continue;
    }
    const uint8_t* header = file.Get(offset, kHeaderBytes);
    const auto channel_length = static_cast<int32_t>(BigEndian32(header + 20));
    const auto data_length = static_cast<int32_t>(BigEndian32(header + 24));
    channel.assign(reinterpret_cast<const char*>(file.Get(offset + kHeaderBytes, channel_length)),
                   static_cast<size_t>(channel_length));
    const uint8_t* data = file.Get(offset + kHeaderBytes + channel_length, data_length);
    ++result.events;
    offset = end;
    if (!handle(channel, data, static_cast<size_t>(data_length))) {
      result.stopped_early = offset < file.size();
      break;
    }
  }
  if (result.events == 0) {
    throw InputError("no LCM events in " + path + ": none of its " +
                     Plural(file.size(), "byte", "bytes") +
                     " forms a valid event (events begin with the sync word 0xEDA1DA01); not "
                     "an LCM event log?");
  }
  return result;
}

}  // namespace dfo::io
