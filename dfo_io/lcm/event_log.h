// Reading LCM event logs (as written by dfo_run's lcm.log_path, lcm-logger or
// file://...?mode=w) without trusting their bytes.
//
// The format (LCM's eventlog.c): a sequence of events, each
//   sync word 0xEDA1DA01 (uint32) | event number (int64) | timestamp (int64, µs) |
//   channel length (int32) | data length (int32) | channel bytes | data bytes,
// every integer big-endian. There is no index and no checksum: after a damaged stretch the only
// way back in is the next sync word.
//
//   LcmLogReadResult r = ReadLcmLog(path, [&](const std::string& channel, const void* data,
//                                              size_t size) { ...; return true; });
//   if (r.skipped_bytes > 0) std::cerr << r.Summary() << "\n";
//
// An event's header is possible when it begins with the sync word, its channel length is in
// 1..999 (LCM's own limit), its data length is >= 0 and the event ends inside the file; lengths
// are checked against the bytes left in the file before anything is read, so a length field of
// 2^31 - 1 allocates nothing. An event is taken when its header is possible and either the next
// sync word (or the end of the file) follows it, as LCM's reader checks, or no well-framed event
// (possible header, followed by a sync word or the end of the file) begins inside it: then the
// damage lies behind it. A well-framed event inside it means its length field is corrupted.
// Anything not taken (a bad sync word, an absurd length, a cut-off last event, garbage between
// events) is damage: it is skipped, counted and located instead of ending the read, and the reader
// resumes at the next sync word that begins an event it takes, as LCM's reader resynchronises on
// the next sync word. So every byte of the file is either in an event handed to the caller or
// counted as skipped. Memory: a 64 KiB window, or the largest event when that is larger (never
// more than the file).

#ifndef DFO_IO_LCM_EVENT_LOG_H_
#define DFO_IO_LCM_EVENT_LOG_H_

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>

namespace dfo::io {

// The sync word that starts every event of an LCM event log.
inline constexpr uint32_t kLcmLogSyncWord = 0xEDA1DA01u;

// What ReadLcmLog found in a log.
struct LcmLogReadResult {
  std::string path;
  int64_t file_bytes = 0;             // size of the file
  int64_t events = 0;                 // valid events handed to the handler
  int64_t skipped_bytes = 0;          // bytes that belong to no valid event
  int64_t skipped_places = 0;         // separate stretches of such bytes
  int64_t first_skipped_offset = -1;  // byte offset of the first stretch; -1 when none
  // The last stretch begins with a sync word and runs to the end of the file: the last event
  // was cut off (an interrupted writer) or its length field is corrupted.
  bool cut_off_at_end = false;
  bool stopped_early = false;  // the handler returned false; the rest of the file was not read

  // One line: "PATH: skipped N corrupted bytes in K places (first at byte offset X); read M
  // events" (plus "; the last event is cut off at the end of the file" when it is), or
  // "PATH: read M events" when nothing was skipped.
  std::string Summary() const;
};

// Reads the LCM event log `path` and hands each valid event to `handle` in file order (channel,
// data, data size; the data pointer is valid during the call only), until the end of the file or
// until `handle` returns false. Damaged stretches are skipped and counted (see the file comment).
// Throws InputError when the file cannot be opened or read, is a folder, is empty, or holds no
// valid event at all (not an LCM event log); the messages say "no LCM events in PATH" for the
// last two. Exceptions thrown by `handle` pass through.
LcmLogReadResult ReadLcmLog(
    const std::string& path,
    const std::function<bool(const std::string& channel, const void* data, size_t size)>& handle);

}  // namespace dfo::io

#endif  // DFO_IO_LCM_EVENT_LOG_H_
