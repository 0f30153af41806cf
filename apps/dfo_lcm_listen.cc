// dfo_lcm_listen: receives a dfo run's LCM messages (live from dfo_run, from lcm-logplayer, or
// straight from an event log), prints the poses as they arrive and writes the trajectory in TUM
// format when the run's stop message arrives, on Ctrl-C, or at the end of the log.
//
//   dfo_lcm_listen [--url URL] [--channel NAME] [--tum out.txt] [--log FILE] [...]
//
// Run `dfo_lcm_listen --help` for the details. Malformed or foreign messages on dfo's channels
// are reported on stderr and skipped. Errors print one line on stderr and exit with status 1
// (2 for command-line mistakes).
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <string>

#include "apps/common/cli.h"
#include "dfo_core/error.h"
#include "dfo_io/file_writer.h"
#include "dfo_io/lcm/publisher.h"
#include "dfo_io/lcm/trajectory_collector.h"
#include "dfo_io/trajectory_io.h"

namespace dfo {
namespace {

constexpr const char* kUsage =
    R"(usage: dfo_lcm_listen [--url URL] [--channel NAME] [--tum out.txt] [--log FILE] [options]

Receives the LCM messages of a dfo run (dfo_run with lcm.enable: true, or a log replayed with
lcm-logplayer), prints every pose as it arrives, keeps the windowed poses up to date with the
keyframe batches sent after each bundle adjustment, and ends on the run's stop message or on
Ctrl-C; --tum then writes the whole trajectory (one pose per frame, TUM format, camera-to-world).
With --log it reads an LCM event log (dfo_run's lcm.log_path) directly instead of listening.

options:
  --url URL                LCM URL to listen on (default udpm://239.255.76.67:7667?ttl=0, the
                           URL dfo_run publishes on by default)
  --channel NAME           channel of the poses (default DFO_POSE, lcm.pose_channel)
  --keyframes-channel NAME default DFO_KEYFRAMES (lcm.keyframes_channel)
  --status-channel NAME    default DFO_STATUS (lcm.status_channel)
  --stop-channel NAME      default DFO_STOP (lcm.stop_channel)
  --tum FILE               write the trajectory to FILE (TUM: timestamp tx ty tz qx qy qz qw)
  --source WHICH           which estimate goes to --tum: auto (windowed when the run sent it,
                           else frontend-only; default), windowed, frontend
  --log FILE               read this LCM event log instead of listening; damaged stretches
                           (bad sync words, absurd lengths, a cut-off end) are skipped and
                           one line on stderr says how many bytes, where, and how many events
                           were read; a file without any valid event is an error
  --timeout SECONDS        live: give up after this many seconds without any dfo message
                           (exit status 3, the file is still written); 0 = wait (default)
  --quiet                  no line per message; malformed messages and the summary only
  --help                   this text
Flags also take their value after '=' (--tum=out.txt).

Printed lines: `pose FRAME TIME SOURCE STATUS [kf] p X Y Z q W X Y Z` (camera-to-world,
quaternion w x y z), `keyframes after frame N: K poses`, `status ...` every 50 frames, `stop ...`.
Messages that are not what their channel carries (another type's fingerprint, truncated, invalid
values) are reported on stderr (the first 20) and skipped; the summary counts them by channel.
)";

using apps::UsageError;

struct Args {
  std::string url = io::kDefaultLcmUrl;
  io::LcmChannels channels;
  std::string tum_path;
  std::string source = "auto";
  std::string log_path;
  double timeout_s = 0.0;
  bool quiet = false;
  bool help = false;
};

Args ParseArgs(int argc, char** argv) {
  Args args;
  apps::ArgParser parser;
  parser.Flag("--help", &args.help, "-h")
      .Flag("--quiet", &args.quiet)
      .Value("--url", &args.url)
      .Value("--channel", &args.channels.pose)
      .Value("--keyframes-channel", &args.channels.keyframes)
      .Value("--status-channel", &args.channels.status)
      .Value("--stop-channel", &args.channels.stop)
      .Value("--tum", &args.tum_path)
      .Value("--source", &args.source)
      .Value("--log", &args.log_path)
      .Number("--timeout", &args.timeout_s, 0.0, 1e9);
  parser.Parse(argc, argv);
  if (args.source != "auto" && args.source != "windowed" && args.source != "frontend") {
    throw UsageError("--source must be auto, windowed or frontend, got '" + args.source + "'");
  }
  try {
    args.channels.Check("channel");
  } catch (const ConfigError& e) {
    throw UsageError(std::string("the four channels must differ: ") + e.what());
  }
  return args;
}

volatile std::sig_atomic_t g_interrupted = 0;
void OnSignal(int) { g_interrupted = 1; }

// Text received over the network, safe to print on one line.
std::string Printable(const std::string& s) {
  std::string out;
  for (char c : s.substr(0, 200)) out.push_back(c >= 32 && c < 127 ? c : '?');
  return out;
}

// LCM subscribes by regular expression: match the channel name literally.
std::string LiteralRegex(const std::string& name) {
  std::string out;
  for (char c : name) {
    if (std::string("\\^$.|?*+()[]{}").find(c) != std::string::npos) out.push_back('\\');
    out.push_back(c);
  }
  return out;
}

class Listener {
 public:
  explicit Listener(const Args& args) : args_(args), collector_(args.channels) {}

  // lcm::LCM raw subscription handler.
  void OnLcm(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    Handle(channel, buffer->data, buffer->data_size);
  }

  void Handle(const std::string& channel, const void* data, size_t size) {
    using Kind = io::LcmCollectorEvent::Kind;
    const io::LcmCollectorEvent e = collector_.Handle(channel, data, size);
    switch (e.kind) {
      case Kind::kMalformed:
        // Reported, never fatal; a flood is cut short.
        if (collector_.counts().malformed <= 20) {
          std::fprintf(stderr, "dfo_lcm_listen: skipped a message: %s\n",
                       Printable(e.message).c_str());
        } else if (collector_.counts().malformed == 21) {
          std::fprintf(stderr, "dfo_lcm_listen: more malformed messages; counting them only\n");
        }
        break;
      case Kind::kPose:
        if (!args_.quiet) PrintPose(e.pose);
        break;
      case Kind::kKeyframes:
        if (!args_.quiet) {
          const char* note = e.keyframes.optimized           ? ""
                             : e.keyframes.num_keyframes < 2 ? " (no solve yet)"
                                                             : " (solve not kept: previous poses)";
          std::printf("keyframes after frame %d: %d pose%s%s\n", e.keyframes.frame_index,
                      e.keyframes.num_keyframes, e.keyframes.num_keyframes == 1 ? "" : "s", note);
        }
        break;
      case Kind::kStatus:
        if (!args_.quiet &&
            (e.status.frames_done % 50 == 0 || e.status.frames_done == e.status.frames_total)) {
          std::printf("status %d/%d frames, %.1f frames/s, %d keyframes, %d lost (%s)\n",
                      e.status.frames_done, e.status.frames_total, e.status.fps, e.status.keyframes,
                      e.status.lost, Printable(e.status.sequence).c_str());
        }
        break;
      case Kind::kStop:
        if (!args_.quiet) {
          std::printf("stop after %d frames: %s%s\n", e.stop.frames_done,
                      e.stop.error ? "error: " : "", Printable(e.stop.reason).c_str());
        }
        break;
      case Kind::kIgnored:
        break;
    }
    if (e.kind != Kind::kIgnored) std::fflush(stdout);
  }

  const io::LcmTrajectoryCollector& collector() const { return collector_; }

 private:
  void PrintPose(const dfo::pose_t& m) const {
    TrackingStatus status = TrackingStatus::kLost;
    io::FromLcmStatus(m.status, &status);
    std::printf("pose %6d %s %-8s %-9s %2s p %.4f %.4f %.4f q %.6f %.6f %.6f %.6f\n", m.frame_index,
                io::FormatNsAsSeconds(m.timestamp_ns).c_str(),
                m.source == dfo::pose_t::SOURCE_WINDOWED ? "windowed" : "frontend",
                TrackingStatusName(status), m.is_keyframe ? "kf" : "", m.position[0], m.position[1],
                m.position[2], m.orientation[0], m.orientation[1], m.orientation[2],
                m.orientation[3]);
  }

  const Args& args_;
  io::LcmTrajectoryCollector collector_;
};

// Listens until the stop message, a signal or the timeout. Returns 3 on timeout, else 0.
int ListenLive(const Args& args, Listener* listener) {
  lcm::LCM lcm(args.url);
  if (!lcm.good()) throw InputError(io::LcmUrlOpenError(args.url));
  const io::LcmChannels& c = args.channels;
  for (const std::string* channel : {&c.pose, &c.keyframes, &c.status, &c.stop}) {
    lcm.subscribe(LiteralRegex(*channel), &Listener::OnLcm, listener);
  }
  struct sigaction action {};
  action.sa_handler = OnSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  std::printf("dfo_lcm_listen: listening on %s, channels %s %s %s %s (Ctrl-C to stop)\n",
              args.url.c_str(), c.pose.c_str(), c.keyframes.c_str(), c.status.c_str(),
              c.stop.c_str());
  std::fflush(stdout);
  constexpr int kWaitMs = 100;
  double idle_s = 0.0;
  while (!g_interrupted && !listener->collector().stopped()) {
    const int handled = lcm.handleTimeout(kWaitMs);
    if (handled < 0) {
      if (g_interrupted) break;
      throw InputError("receiving from LCM URL " + args.url + " failed");
    }
    idle_s = handled > 0 ? 0.0 : idle_s + kWaitMs / 1000.0;
    if (args.timeout_s > 0.0 && idle_s >= args.timeout_s) {
      std::fprintf(stderr, "dfo_lcm_listen: no message for %.1f s on %s; giving up\n",
                   args.timeout_s, args.url.c_str());
      return 3;
    }
  }
  if (g_interrupted) std::printf("dfo_lcm_listen: interrupted\n");
  return 0;
}

int Run(const Args& args) {
  // Before listening: a trajectory that could not be written would lose what was received.
  if (!args.tum_path.empty()) io::CheckFileWritable(args.tum_path, "--tum trajectory");
  Listener listener(args);
  int status = 0;
  if (!args.log_path.empty()) {
    // Damaged stretches are skipped and counted by the reader; a file without a single valid
    // event is an error there.
    const io::LcmLogReadResult read = io::ReadLcmLog(
        args.log_path, [&](const std::string& channel, const void* data, size_t size) {
          listener.Handle(channel, data, size);
          return true;  // read on after a stop: a log may hold several runs' ends
        });
    if (read.skipped_bytes > 0) {
      std::fprintf(stderr, "dfo_lcm_listen: warning: %s\n", read.Summary().c_str());
    }
  } else {
    status = ListenLive(args, &listener);
  }

  const io::LcmTrajectoryCollector& c = listener.collector();
  const io::LcmCollectorCounts& n = c.counts();
  // "3 malformed skipped (DFO_POSE: 2, DFO_KEYFRAMES: 1)": past the first 20 only counted.
  std::string malformed = std::to_string(n.malformed) + " malformed skipped";
  if (n.malformed > 0) {
    std::string by_channel;
    for (const auto& [channel, count] : n.malformed_by_channel) {
      by_channel +=
          (by_channel.empty() ? "" : ", ") + Printable(channel) + ": " + std::to_string(count);
    }
    malformed += " (" + by_channel + ")";
  }
  std::printf(
      "dfo_lcm_listen: %zu frames (%lld frontend, %lld windowed poses), %lld keyframe batches, "
      "%lld status, %s, %s, %lld on other channels\n",
      std::max(c.num_frontend_frames(), c.num_windowed_frames()),
      static_cast<long long>(n.frontend_poses), static_cast<long long>(n.windowed_poses),
      static_cast<long long>(n.keyframe_batches), static_cast<long long>(n.status),
      c.stopped() ? "stop received" : "no stop message", malformed.c_str(),
      static_cast<long long>(n.ignored));
  if (!args.tum_path.empty()) {
    const bool windowed =
        args.source == "windowed" || (args.source == "auto" && c.num_windowed_frames() > 0);
    const Trajectory trajectory = windowed ? c.WindowedTrajectory() : c.FrontendTrajectory();
    io::WriteTumTrajectory(args.tum_path, trajectory);
    std::printf("dfo_lcm_listen: wrote %s (%zu poses, %s)\n", args.tum_path.c_str(),
                trajectory.size(), windowed ? "windowed" : "frontend-only");
    if (trajectory.empty()) {
      std::fprintf(stderr, "dfo_lcm_listen: warning: no %s pose was received\n",
                   windowed ? "windowed" : "frontend");
    }
  }
  std::fflush(stdout);
  return status;
}

}  // namespace
}  // namespace dfo

int main(int argc, char** argv) {
  return dfo::apps::RunMain("dfo_lcm_listen", [&] {
    const dfo::Args args = dfo::ParseArgs(argc, argv);
    if (args.help) {
      std::cout << dfo::kUsage;
      return 0;
    }
    return dfo::Run(args);
  });
}
