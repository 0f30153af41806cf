// Publishing dfo's LCM messages: live on an LCM URL and/or into an LCM event log that the
// publisher writes itself (readable with lcm::LogFile, lcm-logplayer, dfo_lcm_listen --log).
//
//   LcmPublisherOptions options;
//   options.url = kDefaultLcmUrl;              // "" = no live publishing
//   options.log_path = "out/run/dfo.lcmlog";   // "" = no log
//   LcmPublisher publisher(options);           // throws InputError: URL or log cannot be opened
//   publisher.Publish(options.channels.pose, pose_message);
//
// Publishing never throws and never blocks on listeners: with nobody listening, a udpm packet
// simply goes unread. A failed send or log write is counted (stats().failures, first_error) and
// the run goes on; the caller reports it at the end.
#ifndef DFO_IO_LCM_PUBLISHER_H_
#define DFO_IO_LCM_PUBLISHER_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "dfo_io/lcm/messages.h"

namespace dfo::io {

struct LcmPublisherOptions {
  std::string url;       // LCM URL for live publishing (udpm://, memq://, file://...); "" = none
  std::string log_path;  // LCM event log written by the publisher itself; "" = none
  LcmChannels channels;  // not used by the publisher itself; carried for its users
};

// What was published so far.
struct LcmPublisherStats {
  int64_t messages = 0;     // messages handed to Publish
  int64_t bytes = 0;        // their encoded size, fingerprints included
  int64_t failures = 0;     // sends or log writes that failed
  std::string first_error;  // the first failure's message ("" when none)
};

class LcmPublisher {
 public:
  // Opens the URL (when not empty) and creates the log (when log_path is not empty; its folder
  // must exist). Throws InputError naming the URL or file and the likely cause: for udpm on
  // Linux a missing multicast route (the message gives the command that adds one), an unknown
  // provider, a log that cannot be created.
  explicit LcmPublisher(const LcmPublisherOptions& options);
  ~LcmPublisher();
  LcmPublisher(const LcmPublisher&) = delete;
  LcmPublisher& operator=(const LcmPublisher&) = delete;

  // Publishes encoded bytes (EncodeLcmMessage) on `channel` to the URL and the log.
  void PublishBytes(const std::string& channel, const std::vector<uint8_t>& bytes);
  // Encodes and publishes one of dfo's messages.
  template <typename Message>
  void Publish(const std::string& channel, const Message& message) {
    PublishBytes(channel, EncodeLcmMessage(message));
  }

  const LcmPublisherOptions& options() const { return options_; }
  const LcmPublisherStats& stats() const { return stats_; }
  // True when publishing live / writing a log.
  bool live() const;
  bool logging() const;

 private:
  struct Impl;
  LcmPublisherOptions options_;
  LcmPublisherStats stats_;
  std::unique_ptr<Impl> impl_;
};

// The message for an LCM URL that lcm could not open: names the URL and the likely cause by
// provider (udpm: the multicast route and the command that adds it; file: the path; unknown
// providers: the ones that exist). Used by LcmPublisher and dfo_lcm_listen.
std::string LcmUrlOpenError(const std::string& url);

}  // namespace dfo::io

#endif  // DFO_IO_LCM_PUBLISHER_H_
