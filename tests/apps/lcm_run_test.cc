// LCM streaming end to end: the `lcm` configuration section, dfo_run's event log read back (it
// must give exactly the trajectory files' poses), start-up errors for URLs that cannot be opened,
// dfo_lcm_listen on logs with malformed messages, and two real processes over udpm: dfo_run
// publishing, dfo_lcm_listen receiving every frame; lcm-logplayer replaying a log to it.
//
// The udpm tests prefer a private network namespace (`unshare -n`, then
// `ip link set lo up && ip route add 224.0.0.0/4 dev lo`): every packet stays inside it and
// parallel runs cannot hear each other. Without the permission for that (not root, no user
// namespaces) they use the host's multicast route with a port of their own, and skip with the
// reason when udpm cannot be opened at all.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "apps/common/lcm_streaming.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"
#include "dfo_io/json.h"
#include "dfo_io/lcm/trajectory_collector.h"
#include "dfo_io/trajectory_io.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;

constexpr int kFrames = 24;

using test::CommandResult;
using test::RunCommand;

std::string Slurp(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream ss;
  ss << file.rdbuf();
  return ss.str();
}

// A kFrames-frame synthetic sequence, rendered once per test process.
std::string Sequence() { return test::SyntheticSequence(DFO_SYNTH_EXE, kFrames); }

// dfo_run's arguments for the sequence, mode both, no pictures.
std::string RunArgs(const std::string& out) {
  return "--config " + test::SourceDir() + "/configs/demo.yaml --set dataset.path=" + Sequence() +
         " --output " + out + " --set run.progress=none --set run.plot=false";
}

// True when this process may make a network namespace with loopback multicast (`unshare -n`).
// DFO_LCM_TEST_NO_UNSHARE=1 pretends it may not, to try the fallbacks where it may.
bool CanUnshareNetwork() {
  static const bool ok =
      std::getenv("DFO_LCM_TEST_NO_UNSHARE") == nullptr &&
      RunCommand("unshare", "-n sh -c 'ip link set lo up && ip route add 224.0.0.0/4 dev lo'")
              .status == 0;
  return ok;
}

// How the two processes reach each other over udpm.
struct UdpmSetup {
  bool usable = false;
  std::string wrap;     // command prefix: "unshare -n " or ""
  std::string prepare;  // shell lines run first
  std::string url;
  std::string reason;  // why not usable
};

const UdpmSetup& FindUdpmSetup() {
  static UdpmSetup s = [] {
    UdpmSetup setup;
    if (CanUnshareNetwork()) {
      setup.usable = true;
      setup.wrap = "unshare -n ";
      setup.prepare = "ip link set lo up && ip route add 224.0.0.0/4 dev lo || exit 95\n";
      setup.url = io::kDefaultLcmUrl;
      return setup;
    }
    // The host's route, on a port of this process so that parallel test runs stay apart.
    setup.url = "udpm://239.255.76.67:" + std::to_string(7700 + getpid() % 250) + "?ttl=0";
    lcm::LCM probe(setup.url);
    setup.usable = probe.good();
    if (!setup.usable) {
      setup.reason = "LCM udpm cannot be opened here (" + setup.url +
                     "): no multicast route and `unshare -n` not permitted; see README, "
                     "\"Streaming poses over LCM\"";
    }
    return setup;
  }();
  return s;
}

// Writes `body` to a script in `dir` and runs it with sh as the setup says.
CommandResult RunScript(const UdpmSetup& setup, const std::string& dir, const std::string& body) {
  const std::string path = dir + "/script.sh";
  std::ofstream(path) << "set -u\n" << setup.prepare << body;
  return RunCommand(setup.wrap + "sh", path);
}

// Shell lines starting dfo_lcm_listen in the background (`$pid`) with `args`, waiting until it
// listens.
std::string StartListener(const std::string& dir, const std::string& args) {
  return std::string("\"") + DFO_LCM_LISTEN_EXE + "\" " + args + " --timeout 60 > " + dir +
         "/listen.out 2> " + dir +
         "/listen.err &\n"
         "pid=$!\n"
         "n=0\n"
         "until grep -q listening " +
         dir +
         "/listen.out 2>/dev/null; do\n"
         "  n=$((n+1)); if [ $n -gt 600 ]; then echo 'listener did not start' >&2; kill $pid; "
         "exit 90; fi\n"
         "  if ! kill -0 $pid 2>/dev/null; then cat " +
         dir +
         "/listen.err >&2; exit 91; fi\n"
         "  sleep 0.05\n"
         "done\n";
}

TEST(LcmConfig, SchemaDefaultsMatchTheStructs) {
  const io::Config config(io::DfoSchema());
  const apps::LcmStreamOptions o = apps::LcmStreamOptionsFromConfig(config);
  const apps::LcmStreamOptions d;
  const io::LcmChannels c;
  EXPECT_EQ(o.enable, d.enable);
  EXPECT_EQ(o.url, d.url);
  EXPECT_EQ(o.url, io::kDefaultLcmUrl);
  EXPECT_EQ(o.log_path, d.log_path);
  EXPECT_EQ(o.channels.pose, c.pose);
  EXPECT_EQ(o.channels.keyframes, c.keyframes);
  EXPECT_EQ(o.channels.status, c.status);
  EXPECT_EQ(o.channels.stop, c.stop);
  EXPECT_FALSE(o.active());
}

TEST(LcmConfig, SharedChannelOrEmptyUrlIsAnError) {
  io::Config config(io::DfoSchema());
  config.ApplyOverride("lcm.status_channel=DFO_POSE");
  EXPECT_THROW(apps::LcmStreamOptionsFromConfig(config), ConfigError);
  io::Config empty_url(io::DfoSchema());
  empty_url.ApplyOverride("lcm.enable=true");
  empty_url.ApplyOverride("lcm.url=");
  EXPECT_THROW(apps::LcmStreamOptionsFromConfig(empty_url), ConfigError);

  const std::string out = test::MakeTempDir("lcm_shared_channel");
  const CommandResult r =
      RunCommand(DFO_RUN_EXE, RunArgs(out) + " --set lcm.stop_channel=DFO_POSE");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("lcm.stop_channel and lcm.pose_channel are both 'DFO_POSE'"),
            std::string::npos)
      << r.err;
}

// The log dfo_run writes holds, per frame, the poses of both estimates; read back (in-process
// and by dfo_lcm_listen --log) it gives the trajectory files byte for byte.
// The window on its own thread: its solves are published when applied (the last one after the
// last frame), frames whose steps a late solve rescaled are published again, and the log still
// gives back the windowed trajectory file. With the demo's tracker.depth source the thread runs
// under run.deterministic too, and the trajectory files are the sequential run's.
TEST(LcmRun, BackendThreadLogReadBackEqualsTheTrajectoryFile) {
  const std::string dir = test::MakeTempDir("lcm_log_run_thread");
  const std::string out = dir + "/run";
  const std::string log = dir + "/run.lcmlog";
  const CommandResult r = RunCommand(
      DFO_RUN_EXE, RunArgs(out) + " --set run.backend_thread=true --set lcm.log_path=" + log);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const CommandResult sequential = RunCommand(DFO_RUN_EXE, RunArgs(dir + "/sequential"));
  ASSERT_EQ(sequential.status, 0) << sequential.out << sequential.err;
  for (const char* file : {"/windowed_tum.txt", "/frontend_tum.txt", "/keyframes_tum.txt"}) {
    EXPECT_EQ(Slurp(out + file), Slurp(dir + "/sequential" + file)) << file;
  }
  io::LcmTrajectoryCollector collector;
  const io::LcmLogReadResult read =
      io::ReadLcmLog(log, [&](const std::string& channel, const void* data, size_t size) {
        collector.Handle(channel, data, size);
        return true;
      });
  EXPECT_EQ(read.skipped_bytes, 0) << read.Summary();
  const io::JsonValue summary = io::ParseJson(Slurp(out + "/summary.json"), "summary.json");
  EXPECT_EQ(collector.counts().keyframe_batches, summary["keyframes"]["count"].AsInt());
  EXPECT_EQ(summary["keyframes"]["ba_runs"].AsInt() + 1, summary["keyframes"]["count"].AsInt());
  io::WriteTumTrajectory(dir + "/windowed_from_log.txt", collector.WindowedTrajectory());
  EXPECT_EQ(Slurp(dir + "/windowed_from_log.txt"), Slurp(out + "/windowed_tum.txt"));
}

TEST(LcmRun, LogReadBackEqualsTheTrajectoryFiles) {
  const std::string dir = test::MakeTempDir("lcm_log_run");
  const std::string out = dir + "/run";
  const std::string log = dir + "/run.lcmlog";
  // Live publishing too, with nobody listening: over udpm where it can be opened (else memq://).
  UdpmSetup setup = FindUdpmSetup();
  if (!setup.usable) {
    setup = UdpmSetup();
    setup.url = "memq://";
  }
  const CommandResult r = RunScript(setup, dir,
                                    std::string("\"") + DFO_RUN_EXE + "\" " + RunArgs(out) +
                                        " --set lcm.enable=true --set 'lcm.url=" + setup.url +
                                        "' --set lcm.log_path=" + log + "\n");
  ASSERT_EQ(r.status, 0) << r.out << r.err;

  EXPECT_NE(r.out.find("lcm:         "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("publishing per frame: median"), std::string::npos) << r.out;

  io::LcmTrajectoryCollector collector;
  int malformed = 0;
  const int64_t events =
      io::ReadLcmLog(log, [&](const std::string& channel, const void* data, size_t size) {
        const io::LcmCollectorEvent e = collector.Handle(channel, data, size);
        malformed += e.kind == io::LcmCollectorEvent::Kind::kMalformed ? 1 : 0;
        return true;
      }).events;
  EXPECT_EQ(malformed, 0);
  // Every message went live and into the log, none failed.
  EXPECT_NE(r.out.find("lcm:         " + std::to_string(events) + " messages"), std::string::npos)
      << r.out;
  EXPECT_EQ(r.err.find("LCM publications failed"), std::string::npos) << r.err;
  EXPECT_EQ(collector.counts().frontend_poses, kFrames);
  EXPECT_EQ(collector.counts().windowed_poses, kFrames);
  EXPECT_EQ(collector.counts().status, kFrames + 1);
  ASSERT_TRUE(collector.stopped());
  EXPECT_EQ(collector.stop_message()->reason, "finished");
  EXPECT_EQ(collector.stop_message()->frames_done, kFrames);
  const io::JsonValue summary = io::ParseJson(Slurp(out + "/summary.json"), "summary.json");
  EXPECT_EQ(collector.counts().keyframe_batches, summary["keyframes"]["count"].AsInt());
  EXPECT_GE(collector.counts().keyframe_batches, 3);
  EXPECT_EQ(collector.last_status()->frames_done, kFrames);

  io::WriteTumTrajectory(dir + "/frontend_from_log.txt", collector.FrontendTrajectory());
  io::WriteTumTrajectory(dir + "/windowed_from_log.txt", collector.WindowedTrajectory());
  EXPECT_EQ(Slurp(dir + "/frontend_from_log.txt"), Slurp(out + "/frontend_tum.txt"));
  EXPECT_EQ(Slurp(dir + "/windowed_from_log.txt"), Slurp(out + "/windowed_tum.txt"));
  // The windowed trajectory moved after publication: the batches mattered.
  EXPECT_NE(Slurp(out + "/frontend_tum.txt"), Slurp(out + "/windowed_tum.txt"));

  const CommandResult listen =
      RunCommand(DFO_LCM_LISTEN_EXE, "--log " + log + " --tum " + dir + "/listen_windowed.txt");
  ASSERT_EQ(listen.status, 0) << listen.out << listen.err;
  EXPECT_TRUE(listen.err.empty()) << listen.err;
  EXPECT_EQ(Slurp(dir + "/listen_windowed.txt"), Slurp(out + "/windowed_tum.txt"));
  EXPECT_NE(listen.out.find("stop after " + std::to_string(kFrames) + " frames: finished"),
            std::string::npos)
      << listen.out;
  const CommandResult frontend = RunCommand(
      DFO_LCM_LISTEN_EXE, "--log " + log + " --quiet --source frontend --tum " + dir + "/f.txt");
  ASSERT_EQ(frontend.status, 0) << frontend.err;
  EXPECT_EQ(Slurp(dir + "/f.txt"), Slurp(out + "/frontend_tum.txt"));
  EXPECT_EQ(frontend.out.find("pose "), std::string::npos) << "--quiet printed poses";
}

TEST(LcmRun, UnopenableUrlStopsAtStartUp) {
  const std::string out = test::MakeTempDir("lcm_bad_url") + "/run";
  const CommandResult r =
      RunCommand(DFO_RUN_EXE, RunArgs(out) + " --set lcm.enable=true --set lcm.url=nosuch://host");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("cannot open LCM URL 'nosuch://host': unknown LCM provider 'nosuch'"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(out + "/frontend_tum.txt")) << "the run started anyway";
}

TEST(LcmRun, UdpmWithoutMulticastRouteNamesTheFix) {
  if (!CanUnshareNetwork()) {
    GTEST_SKIP() << "`unshare -n` is not permitted here (needs root or user namespaces), so a "
                    "network without a multicast route cannot be made";
  }
  const std::string out = test::MakeTempDir("lcm_no_route") + "/run";
  // A bare namespace: loopback down, no routes at all.
  const CommandResult r = RunCommand(
      "unshare", std::string("-n ") + DFO_RUN_EXE + " " + RunArgs(out) + " --set lcm.enable=true");
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find(std::string("cannot open LCM URL '") + io::kDefaultLcmUrl + "'"),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("sudo ip route add 224.0.0.0/4 dev lo"), std::string::npos) << r.err;
}

TEST(LcmTwoProcesses, ListenerReceivesEveryFrameOverUdpm) {
  const UdpmSetup& setup = FindUdpmSetup();
  if (!setup.usable) GTEST_SKIP() << setup.reason;
  const std::string dir = test::MakeTempDir("lcm_two_processes");
  const std::string body =
      StartListener(dir, "--url '" + setup.url + "' --tum " + dir + "/listen_tum.txt") + "\"" +
      DFO_RUN_EXE + "\" " + RunArgs(dir + "/run") +
      " --set lcm.enable=true --set 'lcm.url=" + setup.url + "' > " + dir + "/run.out 2> " + dir +
      "/run.err || { cat " + dir +
      "/run.err >&2; kill $pid; exit 92; }\n"
      "wait $pid\n";
  const CommandResult r = RunScript(setup, dir, body);
  const std::string listened = Slurp(dir + "/listen.out");
  ASSERT_EQ(r.status, 0) << r.err << "\nlistener: " << listened << Slurp(dir + "/listen.err")
                         << "\ndfo_run: " << Slurp(dir + "/run.out");
  // Every frame arrived, both estimates, then the stop message; the windowed poses, corrected by
  // the keyframe batches, are exactly dfo_run's file.
  EXPECT_NE(listened.find("dfo_lcm_listen: " + std::to_string(kFrames) + " frames (" +
                          std::to_string(kFrames) + " frontend, " + std::to_string(kFrames) +
                          " windowed poses)"),
            std::string::npos)
      << listened;
  EXPECT_NE(listened.find("stop received, 0 malformed"), std::string::npos) << listened;
  EXPECT_EQ(Slurp(dir + "/listen_tum.txt"), Slurp(dir + "/run/windowed_tum.txt"));
  EXPECT_TRUE(Slurp(dir + "/listen.err").empty()) << Slurp(dir + "/listen.err");
}

TEST(LcmTwoProcesses, LogplayerReplayReachesTheListener) {
  if (RunCommand("sh", "-c 'command -v lcm-logplayer'").status != 0) {
    GTEST_SKIP() << "lcm-logplayer not installed (Debian package liblcm-bin)";
  }
  const UdpmSetup& setup = FindUdpmSetup();
  if (!setup.usable) GTEST_SKIP() << setup.reason;
  const std::string dir = test::MakeTempDir("lcm_logplayer");
  const std::string log = dir + "/run.lcmlog";
  const CommandResult run = RunCommand(DFO_RUN_EXE, RunArgs(dir + "/run") +
                                                        " --set run.mode=frontend "
                                                        "--set lcm.log_path=" +
                                                        log);
  ASSERT_EQ(run.status, 0) << run.err;
  const std::string body =
      StartListener(dir, "--quiet --url '" + setup.url + "' --tum " + dir + "/replayed.txt") +
      "lcm-logplayer --speed=20 --lcm-url='" + setup.url + "' " + log +
      " > /dev/null 2>&1 || { kill $pid; exit 93; }\n"
      "wait $pid\n";
  const CommandResult r = RunScript(setup, dir, body);
  ASSERT_EQ(r.status, 0) << r.err << Slurp(dir + "/listen.out") << Slurp(dir + "/listen.err");
  EXPECT_EQ(Slurp(dir + "/replayed.txt"), Slurp(dir + "/run/frontend_tum.txt"));
}

// A log with foreign, truncated and corrupt messages between good ones: dfo_lcm_listen reports
// each bad one on stderr, skips it and writes the good poses.
TEST(LcmListen, MalformedMessagesAreReportedAndSkipped) {
  const std::string dir = test::MakeTempDir("lcm_malformed");
  const std::string log = dir + "/bad.lcmlog";
  const io::LcmChannels ch;
  {
    lcm::LogFile file(log, "w");
    ASSERT_TRUE(file.good());
    int64_t t = 0;
    const auto write = [&](const std::string& channel, std::vector<uint8_t> bytes) {
      lcm::LogEvent e;
      e.eventnum = 0;
      e.timestamp = ++t;
      e.channel = channel;
      e.datalen = static_cast<int32_t>(bytes.size());
      e.data = bytes.data();
      ASSERT_EQ(file.writeEvent(&e), 0);
    };
    const auto pose = [](int i) {
      return io::EncodeLcmMessage(io::MakePoseMessage(
          i, 100000000LL * i, SE3d(SO3d(), Eigen::Vector3d(i, 0, 0)), TrackingStatus::kOk, i == 0,
          dfo::pose_t::SOURCE_FRONTEND, 0, SE3d()));
    };
    write(ch.pose, pose(0));
    std::vector<uint8_t> truncated = pose(1);
    truncated.resize(30);
    write(ch.pose, truncated);                                         // truncated
    write(ch.pose, io::EncodeLcmMessage(dfo::run_status_t{}));         // another dfo type
    write(ch.pose, {0xde, 0xad, 0xbe, 0xef, 1, 2, 3, 4, 5, 6, 7, 8});  // foreign fingerprint
    std::vector<uint8_t> batch = io::EncodeLcmMessage(dfo::keyframe_batch_t{});
    batch[batch.size() - 1] = 0x7f;  // num_keyframes far beyond the buffer
    write(ch.keyframes, batch);
    write(ch.pose, pose(1));
    write(ch.pose, pose(2));
    write("OTHER_PROGRAM", {1, 2, 3});
    dfo::stop_t stop{};
    stop.frames_done = 3;
    stop.reason = "finished";
    write(ch.stop, io::EncodeLcmMessage(stop));
  }
  const CommandResult r =
      RunCommand(DFO_LCM_LISTEN_EXE, "--log " + log + " --tum " + dir + "/t.txt");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  for (const std::string fragment :
       {"skipped a message: DFO_POSE: truncated or malformed dfo.pose_t: 30 bytes",
        "skipped a message: DFO_POSE: a dfo.run_status_t where dfo.pose_t was expected",
        "skipped a message: DFO_POSE: fingerprint 0xdeadbeef01020304 is not dfo.pose_t's",
        "skipped a message: DFO_KEYFRAMES: malformed dfo.keyframe_batch_t: num_keyframes"}) {
    EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err << "\n  missing: " << fragment;
  }
  EXPECT_NE(r.out.find("3 frames (3 frontend, 0 windowed poses), 0 keyframe batches, 0 status, "
                       "stop received, 4 malformed skipped (DFO_KEYFRAMES: 1, DFO_POSE: 3), 1 on "
                       "other channels"),
            std::string::npos)
      << r.out;
  const Trajectory t = io::ReadTumTrajectory(dir + "/t.txt");
  ASSERT_EQ(t.size(), 3u);
  EXPECT_EQ(t[2].world_from_cam.translation().x(), 2.0);
}

// A damaged event log (a corrupted event in the middle, garbage, a cut-off last event):
// dfo_lcm_listen reads every event around the damage and says in one line how much it skipped.
TEST(LcmListen, DamagedLogIsResynchronisedAndCounted) {
  const std::string dir = test::MakeTempDir("lcm_damaged");
  const std::string log = dir + "/damaged.lcmlog";
  const io::LcmChannels ch;
  {
    lcm::LogFile file(log, "w");
    ASSERT_TRUE(file.good());
    for (int i = 0; i < 6; ++i) {
      std::vector<uint8_t> bytes = io::EncodeLcmMessage(io::MakePoseMessage(
          i, 100000000LL * i, SE3d(SO3d(), Eigen::Vector3d(i, 0, 0)), TrackingStatus::kOk, i == 0,
          dfo::pose_t::SOURCE_FRONTEND, 0, SE3d()));
      lcm::LogEvent e;
      e.eventnum = i;
      e.timestamp = i;
      e.channel = ch.pose;
      e.datalen = static_cast<int32_t>(bytes.size());
      e.data = bytes.data();
      ASSERT_EQ(file.writeEvent(&e), 0);
    }
  }
  std::string bytes = Slurp(log);
  const std::string sync = "\xED\xA1\xDA\x01";
  std::vector<size_t> starts;
  for (size_t at = bytes.find(sync); at != std::string::npos; at = bytes.find(sync, at + 1)) {
    starts.push_back(at);
  }
  ASSERT_EQ(starts.size(), 6u);
  const size_t event_size = starts[1] - starts[0];
  // Event 2: its sync word and event number overwritten. Before event 4: 13 bytes of garbage.
  // At the end: the first 20 bytes of another event.
  bytes.replace(starts[2], 12, std::string(12, 'x'));
  bytes.insert(starts[4], std::string(13, '\0'));
  bytes += bytes.substr(starts[0], 20);
  std::ofstream(log, std::ios::binary) << bytes;

  const CommandResult r =
      RunCommand(DFO_LCM_LISTEN_EXE, "--quiet --log " + log + " --tum " + dir + "/t.txt");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const std::string line =
      "dfo_lcm_listen: warning: " + log + ": skipped " + std::to_string(event_size + 13 + 20) +
      " corrupted bytes in 3 places (first at byte offset " + std::to_string(starts[2]) +
      "); read 5 events; the last event is cut off at the end of the file";
  EXPECT_NE(r.err.find(line), std::string::npos) << r.err << "\n  expected: " << line;
  EXPECT_NE(r.out.find("5 frames (5 frontend, 0 windowed poses)"), std::string::npos) << r.out;
  const Trajectory t = io::ReadTumTrajectory(dir + "/t.txt");
  ASSERT_EQ(t.size(), 5u);
  EXPECT_EQ(t[2].world_from_cam.translation().x(), 3.0);
  EXPECT_EQ(t[4].world_from_cam.translation().x(), 5.0);

  // Nothing valid at all: an error, exit status 1.
  std::ofstream(dir + "/cut.lcmlog", std::ios::binary) << bytes.substr(starts[0], 20);
  const CommandResult cut = RunCommand(DFO_LCM_LISTEN_EXE, "--log " + dir + "/cut.lcmlog");
  EXPECT_EQ(cut.status, 1);
  EXPECT_NE(cut.err.find("no LCM events in " + dir + "/cut.lcmlog: none of its 20 bytes"),
            std::string::npos)
      << cut.err;
}

// Ctrl-C (SIGINT) ends a live listener normally, with the trajectory file written.
TEST(LcmListen, InterruptEndsWithTheFileWritten) {
  const std::string dir = test::MakeTempDir("lcm_interrupt");
  const CommandResult r = RunScript(UdpmSetup(), dir,
                                    StartListener(dir, "--url memq:// --tum " + dir + "/t.txt") +
                                        "kill -INT $pid\n"
                                        "wait $pid\n");
  ASSERT_EQ(r.status, 0) << r.err << Slurp(dir + "/listen.err");
  EXPECT_NE(Slurp(dir + "/listen.out").find("dfo_lcm_listen: interrupted"), std::string::npos);
  EXPECT_EQ(Slurp(dir + "/t.txt"), "# timestamp tx ty tz qx qy qz qw\n");
}

TEST(LcmListen, CommandLineAndStartUpErrors) {
  EXPECT_EQ(RunCommand(DFO_LCM_LISTEN_EXE, "--help").status, 0);
  const CommandResult unknown = RunCommand(DFO_LCM_LISTEN_EXE, "--nonsense");
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.err.find("unknown argument '--nonsense'"), std::string::npos) << unknown.err;
  EXPECT_EQ(RunCommand(DFO_LCM_LISTEN_EXE, "--source sideways").status, 2);
  EXPECT_EQ(RunCommand(DFO_LCM_LISTEN_EXE, "--channel A --stop-channel A").status, 2);
  const CommandResult missing = RunCommand(DFO_LCM_LISTEN_EXE, "--log /nonexistent/x.lcmlog");
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.err.find("cannot open the LCM event log /nonexistent/x.lcmlog"),
            std::string::npos)
      << missing.err;
  const std::string not_a_log = test::MakeTempDir("lcm_not_a_log") + "/x.txt";
  std::ofstream(not_a_log) << "hello\n";
  const CommandResult empty = RunCommand(DFO_LCM_LISTEN_EXE, "--log " + not_a_log);
  EXPECT_EQ(empty.status, 1);
  EXPECT_NE(empty.err.find("no LCM events in"), std::string::npos) << empty.err;
  const CommandResult bad_url = RunCommand(DFO_LCM_LISTEN_EXE, "--url nosuch://x");
  EXPECT_EQ(bad_url.status, 1);
  EXPECT_NE(bad_url.err.find("cannot open LCM URL 'nosuch://x'"), std::string::npos) << bad_url.err;
  // A --tum file that cannot be written stops the listener before it receives anything (the
  // missing log would otherwise be the first error).
  const std::string folder = test::MakeTempDir("lcm_tum_folder");
  const CommandResult unwritable =
      RunCommand(DFO_LCM_LISTEN_EXE, "--tum " + folder + " --log /nonexistent/x.lcmlog");
  EXPECT_EQ(unwritable.status, 1);
  EXPECT_NE(
      unwritable.err.find("--tum trajectory " + folder + ": cannot be written (it is a folder)"),
      std::string::npos)
      << unwritable.err;
}

}  // namespace
}  // namespace dfo
