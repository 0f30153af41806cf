#include "dfo_io/lcm/publisher.h"

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>

#include "dfo_core/error.h"

namespace dfo::io {

std::string LcmUrlOpenError(const std::string& url) {
  const std::string head = "cannot open LCM URL '" + url + "': ";
  const size_t sep = url.find("://");
  if (sep == std::string::npos || sep == 0) {
    return head +
           "not an LCM URL (expected provider://address, e.g. udpm://239.255.76.67:7667?ttl=0, "
           "memq://, file:///path/log?mode=w)";
  }
  const std::string provider = url.substr(0, sep);
  if (provider == "udpm") {
    return head +
           "UDP multicast could not be set up (the lines LCM printed above say what it tried). On "
           "Linux the usual cause is no route for multicast packets (no default route, or a "
           "bare network namespace): add one over the loopback device with "
           "`sudo ip route add 224.0.0.0/4 dev lo` (and `sudo ip link set lo up`), or check the "
           "firewall; or run without live streaming (lcm.enable: false; lcm.log_path still "
           "writes the event log)";
  }
  if (provider == "file") {
    return head +
           "the event log cannot be opened (does its folder exist, is it writable; mode=w to "
           "write, mode=r to read an existing log?)";
  }
  if (provider == "memq" || provider == "tcpq") {
    return head + "the " + provider + " provider refused the address";
  }
  return head + "unknown LCM provider '" + provider +
         "' (LCM 1.3.1 knows udpm://, memq://, file://PATH?mode=r|w, tcpq://)";
}

struct LcmPublisher::Impl {
  std::unique_ptr<lcm::LCM> lcm;
  std::unique_ptr<lcm::LogFile> log;
};

LcmPublisher::LcmPublisher(const LcmPublisherOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {
  if (!options_.url.empty()) {
    impl_->lcm = std::make_unique<lcm::LCM>(options_.url);
    if (!impl_->lcm->good()) throw InputError(LcmUrlOpenError(options_.url));
  }
  if (!options_.log_path.empty()) {
    std::error_code ec;
    if (std::filesystem::is_directory(options_.log_path, ec)) {
      throw InputError("the LCM event log " + options_.log_path +
                       " (lcm.log_path) is a folder; expected a file name");
    }
    errno = 0;
    impl_->log = std::make_unique<lcm::LogFile>(options_.log_path, "w");
    if (!impl_->log->good()) {
      // LibLCM opens the file with fopen: errno holds the system's reason.
      const int reason = errno;
      throw InputError("cannot create the LCM event log " + options_.log_path +
                       " (lcm.log_path): " +
                       (reason != 0 ? std::string(std::strerror(reason))
                                    : std::string("its folder missing or not writable?")));
    }
  }
}

LcmPublisher::~LcmPublisher() = default;

bool LcmPublisher::live() const { return impl_->lcm != nullptr; }
bool LcmPublisher::logging() const { return impl_->log != nullptr; }

void LcmPublisher::PublishBytes(const std::string& channel, const std::vector<uint8_t>& bytes) {
  ++stats_.messages;
  stats_.bytes += static_cast<int64_t>(bytes.size());
  const auto fail = [&](const std::string& what) {
    ++stats_.failures;
    if (stats_.first_error.empty()) stats_.first_error = what;
  };
  if (bytes.empty()) {
    fail("a message on " + channel + " could not be encoded");
    return;
  }
  if (impl_->lcm &&
      impl_->lcm->publish(channel, bytes.data(), static_cast<unsigned int>(bytes.size())) != 0) {
    fail("publishing on " + channel + " to " + options_.url + " failed");
  }
  if (impl_->log) {
    lcm::LogEvent event;
    event.eventnum = 0;  // numbered by the log writer
    event.timestamp = std::chrono::duration_cast<std::chrono::microseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
    event.channel = channel;
    event.datalen = static_cast<int32_t>(bytes.size());
    event.data = const_cast<uint8_t*>(bytes.data());
    if (impl_->log->writeEvent(&event) != 0) {
      fail("writing the LCM event log " + options_.log_path + " failed (disk full?)");
    }
  }
}

}  // namespace dfo::io
