// dfo's LCM messages (dfo_io/lcm/): every type through encode/decode, decoding that survives
// foreign, truncated and corrupted bytes, in-process publish/subscribe over memq://, the event log
// written by LcmPublisher read back, and the trajectory collector behind dfo_lcm_listen
// (windowed history corrected by keyframe batches, bad messages skipped).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <lcm/lcm-cpp.hpp>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_io/lcm/messages.h"
#include "dfo_io/lcm/publisher.h"
#include "dfo_io/lcm/trajectory_collector.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

SE3d SomePose(double a) {
  return SE3d(SO3d::Exp(Eigen::Vector3d(0.1 * a, -0.2, 0.3 * a)),
              Eigen::Vector3d(1.5 * a, -0.25, 10.0 + a));
}

void ExpectSamePose(const SE3d& a, const SE3d& b) {
  // Bit for bit: the collector keeps unit quaternions as sent.
  EXPECT_EQ(a.translation(), b.translation());
  EXPECT_EQ(a.quaternion().coeffs(), b.quaternion().coeffs());
}

dfo::pose_t SomePoseMessage(int frame, int8_t source = dfo::pose_t::SOURCE_WINDOWED) {
  return MakePoseMessage(frame, 1000000123LL * frame, SomePose(frame), TrackingStatus::kDegraded,
                         frame % 3 == 0, source, frame > 0 ? frame - 1 : -1, SomePose(0.5));
}

dfo::keyframe_batch_t SomeBatch() {
  dfo::keyframe_batch_t b{};
  b.utime = 42;
  b.frame_index = 9;
  b.optimized = 1;
  for (int i = 0; i < 3; ++i) {
    b.keyframes.push_back(MakeKeyframePose(3 * i, 1000 * i, SomePose(i), i != 0));
  }
  b.num_keyframes = 3;
  return b;
}

dfo::run_status_t SomeStatus() {
  dfo::run_status_t s{};
  s.utime = 7;
  s.frames_done = 12;
  s.frames_total = 500;
  s.fps = 163.5;
  s.keyframes = 4;
  s.lost = 1;
  s.sequence = "KITTI 00 (image_0)";
  return s;
}

dfo::stop_t SomeStop() {
  dfo::stop_t s{};
  s.utime = 8;
  s.frames_done = 500;
  s.error = 1;
  s.reason = "cannot read frame 7";
  return s;
}

template <typename M>
M RoundTrip(const M& m) {
  const std::vector<uint8_t> bytes = EncodeLcmMessage(m);
  EXPECT_EQ(static_cast<int>(bytes.size()), m.getEncodedSize());
  M back{};
  std::string error;
  EXPECT_TRUE(DecodeLcmMessage(bytes.data(), bytes.size(), &back, &error)) << error;
  return back;
}

TEST(LcmMessages, PoseRoundTrip) {
  const dfo::pose_t m = SomePoseMessage(6);
  const dfo::pose_t b = RoundTrip(m);
  EXPECT_EQ(b.utime, m.utime);
  EXPECT_EQ(b.timestamp_ns, 6000000738LL);
  EXPECT_EQ(b.utime, 6000000);
  EXPECT_EQ(b.frame_index, 6);
  EXPECT_EQ(b.status,
            +dfo::pose_t::STATUS_DEGRADED);  // + : the generated constants have no definition
  EXPECT_EQ(b.is_keyframe, 1);
  EXPECT_EQ(b.source, +dfo::pose_t::SOURCE_WINDOWED);
  EXPECT_EQ(b.keyframe_index, 5);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(b.position[i], m.position[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(b.orientation[i], m.orientation[i]);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(b.kf_position[i], m.kf_position[i]);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(b.kf_orientation[i], m.kf_orientation[i]);
  // The arrays give the pose back exactly, quaternion as w, x, y, z.
  SE3d pose;
  std::string error;
  ASSERT_TRUE(PoseFromArrays(b.position, b.orientation, &pose, &error)) << error;
  ExpectSamePose(pose, SomePose(6));
  EXPECT_EQ(b.orientation[0], SomePose(6).quaternion().w());
}

TEST(LcmMessages, KeyframeBatchRoundTrip) {
  const dfo::keyframe_batch_t m = SomeBatch();
  const dfo::keyframe_batch_t b = RoundTrip(m);
  EXPECT_EQ(b.utime, 42);
  EXPECT_EQ(b.frame_index, 9);
  EXPECT_EQ(b.optimized, 1);
  ASSERT_EQ(b.num_keyframes, 3);
  ASSERT_EQ(b.keyframes.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(b.keyframes[i].frame_index, 3 * i);
    EXPECT_EQ(b.keyframes[i].timestamp_ns, 1000 * i);
    EXPECT_EQ(b.keyframes[i].in_window, i != 0 ? 1 : 0);
    for (int k = 0; k < 4; ++k)
      EXPECT_EQ(b.keyframes[i].orientation[k], m.keyframes[i].orientation[k]);
    for (int k = 0; k < 3; ++k) EXPECT_EQ(b.keyframes[i].position[k], m.keyframes[i].position[k]);
  }
  // An empty batch too.
  dfo::keyframe_batch_t empty{};
  EXPECT_EQ(RoundTrip(empty).keyframes.size(), 0u);
}

TEST(LcmMessages, KeyframePoseRoundTrip) {
  const dfo::keyframe_pose_t m = MakeKeyframePose(17, -1500, SomePose(2), true);
  const dfo::keyframe_pose_t b = RoundTrip(m);
  EXPECT_EQ(b.frame_index, 17);
  EXPECT_EQ(b.timestamp_ns, -1500);
  EXPECT_EQ(b.utime, -2);  // rounded toward minus infinity
  EXPECT_EQ(b.in_window, 1);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(b.position[k], m.position[k]);
}

TEST(LcmMessages, RunStatusRoundTrip) {
  const dfo::run_status_t b = RoundTrip(SomeStatus());
  EXPECT_EQ(b.utime, 7);
  EXPECT_EQ(b.frames_done, 12);
  EXPECT_EQ(b.frames_total, 500);
  EXPECT_EQ(b.fps, 163.5);
  EXPECT_EQ(b.keyframes, 4);
  EXPECT_EQ(b.lost, 1);
  EXPECT_EQ(b.sequence, "KITTI 00 (image_0)");
}

TEST(LcmMessages, StopRoundTrip) {
  const dfo::stop_t b = RoundTrip(SomeStop());
  EXPECT_EQ(b.utime, 8);
  EXPECT_EQ(b.frames_done, 500);
  EXPECT_EQ(b.error, 1);
  EXPECT_EQ(b.reason, "cannot read frame 7");
}

TEST(LcmMessages, StatusCodesRoundTrip) {
  for (TrackingStatus s : {TrackingStatus::kOk, TrackingStatus::kDegraded, TrackingStatus::kLost,
                           TrackingStatus::kReference}) {
    TrackingStatus back = TrackingStatus::kOk;
    ASSERT_TRUE(FromLcmStatus(ToLcmStatus(s), &back));
    EXPECT_EQ(back, s);
  }
  TrackingStatus unused;
  EXPECT_FALSE(FromLcmStatus(17, &unused));
}

TEST(LcmDecode, ForeignFingerprintIsNamed) {
  const std::vector<uint8_t> status = EncodeLcmMessage(SomeStatus());
  dfo::pose_t pose;
  std::string error;
  EXPECT_FALSE(DecodeLcmMessage(status.data(), status.size(), &pose, &error));
  EXPECT_NE(error.find("a dfo.run_status_t where dfo.pose_t was expected"), std::string::npos)
      << error;
  std::vector<uint8_t> foreign = status;
  foreign[0] ^= 0x55;
  EXPECT_FALSE(DecodeLcmMessage(foreign.data(), foreign.size(), &pose, &error));
  EXPECT_NE(error.find("is not dfo.pose_t's"), std::string::npos) << error;
  EXPECT_FALSE(DecodeLcmMessage(foreign.data(), 5, &pose, &error));
  EXPECT_NE(error.find("too short"), std::string::npos) << error;
  EXPECT_FALSE(DecodeLcmMessage(nullptr, 0, &pose, &error));
}

// Every prefix of a valid message is refused with a message, never a crash.
template <typename M>
void ExpectEveryTruncationRefused(const M& m) {
  const std::vector<uint8_t> bytes = EncodeLcmMessage(m);
  for (size_t n = 0; n < bytes.size(); ++n) {
    const std::vector<uint8_t> prefix(bytes.begin(), bytes.begin() + n);
    M out{};
    std::string error;
    EXPECT_FALSE(DecodeLcmMessage(prefix.data(), prefix.size(), &out, &error)) << n << " bytes";
    EXPECT_FALSE(error.empty());
  }
  // Trailing bytes are refused too.
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  M out{};
  std::string error;
  EXPECT_FALSE(DecodeLcmMessage(longer.data(), longer.size(), &out, &error));
  EXPECT_NE(error.find("left over"), std::string::npos) << error;
}

TEST(LcmDecode, TruncatedMessagesAreRefused) {
  ExpectEveryTruncationRefused(SomePoseMessage(4));
  ExpectEveryTruncationRefused(SomeBatch());
  ExpectEveryTruncationRefused(SomeStatus());
  ExpectEveryTruncationRefused(SomeStop());
  ExpectEveryTruncationRefused(MakeKeyframePose(1, 2, SomePose(3), false));
}

// The count field of keyframe_batch_t sits just before the array.
void SetBatchCount(std::vector<uint8_t>* bytes, int32_t count) {
  const size_t at = static_cast<size_t>(dfo::keyframe_batch_t{}.getEncodedSize()) - 4;
  const uint32_t u = static_cast<uint32_t>(count);
  for (int i = 0; i < 4; ++i) (*bytes)[at + i] = static_cast<uint8_t>(u >> (24 - 8 * i));
}

TEST(LcmDecode, ImpossibleArrayCountIsRefusedBeforeAllocating) {
  for (int32_t count : {std::numeric_limits<int32_t>::max(), -1, 4, 1000000}) {
    std::vector<uint8_t> bytes = EncodeLcmMessage(SomeBatch());
    SetBatchCount(&bytes, count);
    dfo::keyframe_batch_t out{};
    std::string error;
    EXPECT_FALSE(DecodeLcmMessage(bytes.data(), bytes.size(), &out, &error)) << count;
    EXPECT_NE(error.find("num_keyframes"), std::string::npos) << error;
  }
}

// The string length field of stop_t is the last field before the text.
TEST(LcmDecode, BadStringLengthIsRefused) {
  const dfo::stop_t stop = SomeStop();
  const std::vector<uint8_t> good = EncodeLcmMessage(stop);
  const size_t at = good.size() - stop.reason.size() - 1 - 4;
  for (int32_t length : {0, -1, -100, std::numeric_limits<int32_t>::max(), 1000}) {
    std::vector<uint8_t> bytes = good;
    const uint32_t u = static_cast<uint32_t>(length);
    for (int i = 0; i < 4; ++i) bytes[at + i] = static_cast<uint8_t>(u >> (24 - 8 * i));
    dfo::stop_t out{};
    std::string error;
    EXPECT_FALSE(DecodeLcmMessage(bytes.data(), bytes.size(), &out, &error)) << length;
    EXPECT_FALSE(error.empty());
  }
}

// Random corruption of valid messages (fixed seed): decoding and collecting never crash, and a
// message either decodes or says why.
TEST(LcmDecode, CorruptedBytesNeverCrashTheCollector) {
  std::mt19937 rng(5);
  LcmTrajectoryCollector collector;
  const LcmChannels channels;
  const std::vector<std::pair<std::string, std::vector<uint8_t>>> valid = {
      {channels.pose, EncodeLcmMessage(SomePoseMessage(3))},
      {channels.keyframes, EncodeLcmMessage(SomeBatch())},
      {channels.status, EncodeLcmMessage(SomeStatus())},
      {channels.stop, EncodeLcmMessage(SomeStop())}};
  int refused = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const auto& [channel, original] = valid[trial % valid.size()];
    std::vector<uint8_t> bytes = original;
    const int flips = 1 + static_cast<int>(rng() % 4);
    for (int f = 0; f < flips; ++f) {
      // Mostly after the fingerprint, where the decoder has to cope with what it finds.
      const size_t at = 8 + rng() % (bytes.size() - 8);
      bytes[at] = static_cast<uint8_t>(rng());
    }
    if (rng() % 4 == 0) bytes.resize(rng() % bytes.size());
    const LcmCollectorEvent e = collector.Handle(channel, bytes.data(), bytes.size());
    if (e.kind == LcmCollectorEvent::Kind::kMalformed) {
      ++refused;
      EXPECT_EQ(e.message.rfind(channel + ": ", 0), 0u) << e.message;
    }
  }
  EXPECT_GT(refused, 100);
  EXPECT_EQ(collector.counts().malformed, refused);
}

TEST(LcmCollector, WindowedHistoryFollowsKeyframeBatches) {
  LcmTrajectoryCollector c;
  const LcmChannels& ch = c.channels();
  const auto send = [&](const std::string& channel, const auto& message) {
    const std::vector<uint8_t> bytes = EncodeLcmMessage(message);
    return c.Handle(channel, bytes.data(), bytes.size());
  };
  const SE3d kf0 = SomePose(0), kf2 = SomePose(2);
  const SE3d rel1 = SomePose(0.1), rel3 = SomePose(0.3);
  // Frame 0 keyframe, frame 1 tracked against it, frame 2 keyframe, frame 3 tracked against 2.
  const int8_t w = dfo::pose_t::SOURCE_WINDOWED;
  EXPECT_EQ(
      send(ch.pose, MakePoseMessage(0, 0, kf0, TrackingStatus::kReference, true, w, 0, SE3d()))
          .kind,
      LcmCollectorEvent::Kind::kPose);
  send(ch.pose, MakePoseMessage(1, 10, kf0 * rel1, TrackingStatus::kOk, false, w, 0, rel1));
  send(ch.pose, MakePoseMessage(2, 20, kf2, TrackingStatus::kOk, true, w, 2, SE3d()));
  send(ch.pose, MakePoseMessage(3, 30, kf2 * rel3, TrackingStatus::kOk, false, w, 2, rel3));
  // Frontend-only poses of the same frames (never re-expressed).
  send(ch.pose, MakePoseMessage(1, 10, SomePose(9), TrackingStatus::kOk, false,
                                dfo::pose_t::SOURCE_FRONTEND, 0, rel1));
  // The window moves both keyframes.
  const SE3d kf0_new = SomePose(0.7), kf2_new = SomePose(2.5);
  dfo::keyframe_batch_t batch{};
  batch.frame_index = 2;
  batch.optimized = 1;
  batch.keyframes = {MakeKeyframePose(0, 0, kf0_new, false),
                     MakeKeyframePose(2, 20, kf2_new, true)};
  batch.num_keyframes = 2;
  EXPECT_EQ(send(ch.keyframes, batch).kind, LcmCollectorEvent::Kind::kKeyframes);

  const Trajectory t = c.WindowedTrajectory();
  ASSERT_EQ(t.size(), 4u);
  ExpectSamePose(t[0].world_from_cam, kf0_new);
  ExpectSamePose(t[1].world_from_cam, kf0_new * rel1);
  ExpectSamePose(t[2].world_from_cam, kf2_new);
  ExpectSamePose(t[3].world_from_cam, kf2_new * rel3);
  EXPECT_EQ(t[3].timestamp_ns, 30);
  const Trajectory f = c.FrontendTrajectory();
  ASSERT_EQ(f.size(), 1u);
  ExpectSamePose(f[0].world_from_cam, SomePose(9));
  EXPECT_EQ(c.counts().windowed_poses, 4);
  EXPECT_EQ(c.counts().frontend_poses, 1);
  EXPECT_EQ(c.counts().keyframe_batches, 1);
  EXPECT_FALSE(c.stopped());
  EXPECT_EQ(send(ch.stop, SomeStop()).kind, LcmCollectorEvent::Kind::kStop);
  EXPECT_TRUE(c.stopped());
  EXPECT_EQ(c.stop_message()->reason, "cannot read frame 7");
}

TEST(LcmCollector, InvalidValuesAreReportedAndSkipped) {
  LcmTrajectoryCollector c;
  const LcmChannels& ch = c.channels();
  const auto expect_malformed = [&](const std::string& channel, const auto& message,
                                    const std::string& fragment) {
    const std::vector<uint8_t> bytes = EncodeLcmMessage(message);
    const LcmCollectorEvent e = c.Handle(channel, bytes.data(), bytes.size());
    EXPECT_EQ(e.kind, LcmCollectorEvent::Kind::kMalformed) << fragment;
    EXPECT_NE(e.message.find(fragment), std::string::npos) << e.message;
  };
  dfo::pose_t nan_pose = SomePoseMessage(1);
  nan_pose.position[1] = std::numeric_limits<double>::quiet_NaN();
  expect_malformed(ch.pose, nan_pose, "non-finite position");
  dfo::pose_t long_q = SomePoseMessage(1);
  long_q.orientation[0] = 2.0;
  expect_malformed(ch.pose, long_q, "norm");
  dfo::pose_t bad_status = SomePoseMessage(1);
  bad_status.status = 9;
  expect_malformed(ch.pose, bad_status, "unknown status code 9");
  dfo::pose_t bad_source = SomePoseMessage(1);
  bad_source.source = 5;
  expect_malformed(ch.pose, bad_source, "unknown source code 5");
  dfo::keyframe_batch_t bad_batch = SomeBatch();
  bad_batch.keyframes[2].orientation[3] = std::numeric_limits<double>::infinity();
  expect_malformed(ch.keyframes, bad_batch, "keyframe 6: non-finite orientation");
  expect_malformed(ch.pose, SomeStatus(), "DFO_POSE: a dfo.run_status_t where dfo.pose_t");
  expect_malformed(ch.stop, SomePoseMessage(1), "DFO_STOP: a dfo.pose_t where dfo.stop_t");
  EXPECT_EQ(c.counts().malformed, 7);
  // Counted by channel too.
  const std::map<std::string, int64_t> by_channel = {{ch.pose, 5}, {ch.keyframes, 1}, {ch.stop, 1}};
  EXPECT_EQ(c.counts().malformed_by_channel, by_channel);
  EXPECT_EQ(c.num_windowed_frames(), 0u);
  EXPECT_EQ(c.counts().keyframe_batches, 0);
  EXPECT_FALSE(c.stopped());
  // Other channels are counted, not decoded.
  const std::vector<uint8_t> junk = {1, 2, 3};
  EXPECT_EQ(c.Handle("SOMEONE_ELSE", junk.data(), junk.size()).kind,
            LcmCollectorEvent::Kind::kIgnored);
  EXPECT_EQ(c.counts().ignored, 1);
}

TEST(LcmChannelsCheck, EmptyOrSharedChannelsAreErrors) {
  LcmChannels c;
  EXPECT_NO_THROW(c.Check());
  c.stop = c.pose;
  try {
    c.Check();
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("lcm.stop_channel and lcm.pose_channel are both "
                                         "'DFO_POSE'"),
              std::string::npos)
        << e.what();
  }
  c = LcmChannels();
  c.status.clear();
  EXPECT_THROW(c.Check(), ConfigError);
}

// The raw-subscription handler a C++ program would write (see README).
class Receiver {
 public:
  void OnMessage(const lcm::ReceiveBuffer* buffer, const std::string& channel) {
    events.push_back(collector.Handle(channel, buffer->data, buffer->data_size));
  }
  LcmTrajectoryCollector collector;
  std::vector<LcmCollectorEvent> events;
};

TEST(LcmTransport, MemqPublishSubscribe) {
  lcm::LCM lcm("memq://");
  ASSERT_TRUE(lcm.good());
  Receiver receiver;
  const LcmChannels ch;
  for (const std::string* channel : {&ch.pose, &ch.keyframes, &ch.status, &ch.stop}) {
    lcm.subscribe(*channel, &Receiver::OnMessage, &receiver);
  }
  const auto publish = [&](const std::string& channel, const auto& message) {
    const std::vector<uint8_t> bytes = EncodeLcmMessage(message);
    ASSERT_EQ(lcm.publish(channel, bytes.data(), static_cast<unsigned>(bytes.size())), 0);
  };
  for (int i = 0; i < 5; ++i) publish(ch.pose, SomePoseMessage(i, dfo::pose_t::SOURCE_FRONTEND));
  publish(ch.keyframes, SomeBatch());
  publish(ch.status, SomeStatus());
  publish(ch.pose, SomeStatus());  // foreign on the pose channel
  publish(ch.stop, SomeStop());
  while (lcm.handleTimeout(0) > 0) {
  }
  ASSERT_EQ(receiver.events.size(), 9u);
  EXPECT_EQ(receiver.events[7].kind, LcmCollectorEvent::Kind::kMalformed);
  EXPECT_EQ(receiver.collector.num_frontend_frames(), 5u);
  const Trajectory t = receiver.collector.FrontendTrajectory();
  for (int i = 0; i < 5; ++i) ExpectSamePose(t[i].world_from_cam, SomePose(i));
  EXPECT_EQ(receiver.collector.counts().keyframe_batches, 1);
  EXPECT_EQ(receiver.collector.last_status()->frames_done, 12);
  EXPECT_TRUE(receiver.collector.stopped());
}

TEST(LcmTransport, PublisherLogReadsBack) {
  const std::string dir = test::MakeTempDir("lcm_log");
  LcmPublisherOptions options;
  options.url = "memq://";  // live publishing with nobody subscribed must not fail
  options.log_path = dir + "/run.lcmlog";
  const LcmChannels ch;
  {
    LcmPublisher publisher(options);
    EXPECT_TRUE(publisher.live());
    EXPECT_TRUE(publisher.logging());
    for (int i = 0; i < 4; ++i) publisher.Publish(ch.pose, SomePoseMessage(i));
    publisher.Publish(ch.keyframes, SomeBatch());
    publisher.Publish(ch.stop, SomeStop());
    EXPECT_EQ(publisher.stats().messages, 6);
    EXPECT_EQ(publisher.stats().failures, 0);
    EXPECT_GT(publisher.stats().bytes, 6 * 8);
  }
  LcmTrajectoryCollector collector;
  std::vector<std::string> channels;
  const LcmLogReadResult read =
      ReadLcmLog(options.log_path, [&](const std::string& channel, const void* data, size_t size) {
        channels.push_back(channel);
        EXPECT_NE(collector.Handle(channel, data, size).kind, LcmCollectorEvent::Kind::kMalformed);
        return true;
      });
  EXPECT_EQ(read.events, 6);
  EXPECT_EQ(read.skipped_bytes, 0);
  EXPECT_EQ(read.skipped_places, 0);
  EXPECT_FALSE(read.stopped_early);
  EXPECT_EQ(read.Summary(), options.log_path + ": read 6 events");
  ASSERT_EQ(channels.size(), 6u);
  EXPECT_EQ(channels[4], ch.keyframes);
  EXPECT_EQ(collector.num_windowed_frames(), 4u);
  EXPECT_TRUE(collector.stopped());
  // Stopping early.
  int seen = 0;
  const LcmLogReadResult stopped = ReadLcmLog(
      options.log_path, [&](const std::string&, const void*, size_t) { return ++seen < 2; });
  EXPECT_EQ(stopped.events, 2);
  EXPECT_TRUE(stopped.stopped_early);
}

// ---------------------------------------------------------------------------------------------
// Event logs with damage: every byte is either in an event handed over or counted as skipped.

void AppendBigEndian(std::vector<uint8_t>* out, uint64_t v, int bytes) {
  for (int i = bytes - 1; i >= 0; --i) out->push_back(static_cast<uint8_t>(v >> (8 * i)));
}

// One event as LCM's eventlog.c writes it.
std::vector<uint8_t> LogEventBytes(int64_t number, const std::string& channel,
                                   const std::vector<uint8_t>& data) {
  std::vector<uint8_t> e;
  AppendBigEndian(&e, kLcmLogSyncWord, 4);
  AppendBigEndian(&e, static_cast<uint64_t>(number), 8);
  AppendBigEndian(&e, static_cast<uint64_t>(1000 * number), 8);
  AppendBigEndian(&e, channel.size(), 4);
  AppendBigEndian(&e, data.size(), 4);
  e.insert(e.end(), channel.begin(), channel.end());
  e.insert(e.end(), data.begin(), data.end());
  return e;
}

// A log of `n` events on channels E0, E1, ... with data of 40 + i bytes; offsets[i] is where
// event i begins (offsets[n] = the size).
struct TestLog {
  std::vector<uint8_t> bytes;
  std::vector<int64_t> offsets;
};
TestLog MakeTestLog(int n) {
  TestLog log;
  for (int i = 0; i < n; ++i) {
    log.offsets.push_back(static_cast<int64_t>(log.bytes.size()));
    std::vector<uint8_t> data;
    for (int k = 0; k < 40 + i; ++k) data.push_back(static_cast<uint8_t>(i * 7 + k));
    const std::vector<uint8_t> e = LogEventBytes(i, "E" + std::to_string(i), data);
    log.bytes.insert(log.bytes.end(), e.begin(), e.end());
  }
  log.offsets.push_back(static_cast<int64_t>(log.bytes.size()));
  return log;
}

std::string WriteBytes(const std::string& name, const std::vector<uint8_t>& bytes) {
  const std::string path = test::MakeTempDir("lcm_event_log") + "/" + name;
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  return path;
}

// Reads a log; the channels of the events handed over, each checked against its data.
std::vector<std::string> ReadChannels(const std::string& path, LcmLogReadResult* result) {
  std::vector<std::string> channels;
  *result = ReadLcmLog(path, [&](const std::string& channel, const void* data, size_t size) {
    channels.push_back(channel);
    const int i = std::stoi(channel.substr(1));
    EXPECT_EQ(size, static_cast<size_t>(40 + i)) << channel;
    const auto* bytes = static_cast<const uint8_t*>(data);
    for (size_t k = 0; k < size; ++k) {
      if (bytes[k] != static_cast<uint8_t>(i * 7 + k)) {
        ADD_FAILURE() << channel << " byte " << k;
        break;
      }
    }
    return true;
  });
  return channels;
}

std::vector<std::string> ChannelsExcept(int n, const std::vector<int>& missing) {
  std::vector<std::string> out;
  for (int i = 0; i < n; ++i) {
    if (std::find(missing.begin(), missing.end(), i) == missing.end()) {
      out.push_back("E" + std::to_string(i));
    }
  }
  return out;
}

TEST(LcmEventLog, IntactLogReadsEveryEvent) {
  const TestLog log = MakeTestLog(10);
  LcmLogReadResult r;
  EXPECT_EQ(ReadChannels(WriteBytes("ok.lcmlog", log.bytes), &r), ChannelsExcept(10, {}));
  EXPECT_EQ(r.events, 10);
  EXPECT_EQ(r.skipped_bytes, 0);
  EXPECT_EQ(r.skipped_places, 0);
  EXPECT_EQ(r.first_skipped_offset, -1);
  EXPECT_EQ(r.file_bytes, log.offsets[10]);
}

// Bytes overwritten over the sync word of event 4: event 4 is lost, counted, and the reader
// resynchronises on event 5; event 3 before it is read.
TEST(LcmEventLog, CorruptedBytesInTheMiddleAreSkippedAndCounted) {
  TestLog log = MakeTestLog(10);
  for (int64_t k = log.offsets[4] + 1; k < log.offsets[4] + 9; ++k) log.bytes[k] = 0x55;
  const std::string path = WriteBytes("middle.lcmlog", log.bytes);
  LcmLogReadResult r;
  EXPECT_EQ(ReadChannels(path, &r), ChannelsExcept(10, {4}));
  EXPECT_EQ(r.events, 9);
  EXPECT_EQ(r.skipped_places, 1);
  EXPECT_EQ(r.first_skipped_offset, log.offsets[4]);
  EXPECT_EQ(r.skipped_bytes, log.offsets[5] - log.offsets[4]);
  EXPECT_FALSE(r.cut_off_at_end);
  EXPECT_EQ(r.Summary(), path + ": skipped " + std::to_string(r.skipped_bytes) +
                             " corrupted bytes in 1 place (first at byte offset " +
                             std::to_string(log.offsets[4]) + "); read 9 events");
  // Damage in two places, one of them spanning the end of event 6 and the header of event 7:
  // event 6 is still handed over (its data damaged: the decoder's business), 7 is skipped.
  for (int64_t k = log.offsets[7] - 5; k < log.offsets[7] + 12; ++k) log.bytes[k] = 0;
  std::vector<std::string> channels;
  r = ReadLcmLog(WriteBytes("two.lcmlog", log.bytes),
                 [&](const std::string& channel, const void*, size_t) {
                   channels.push_back(channel);
                   return true;
                 });
  EXPECT_EQ(channels, ChannelsExcept(10, {4, 7}));
  EXPECT_EQ(r.skipped_places, 2);
  EXPECT_EQ(r.skipped_bytes, log.offsets[5] - log.offsets[4] + log.offsets[8] - log.offsets[7]);
  EXPECT_EQ(r.first_skipped_offset, log.offsets[4]);
}

TEST(LcmEventLog, GarbageBetweenEventsIsSkipped) {
  TestLog log = MakeTestLog(8);
  std::vector<uint8_t> garbage(37, 0xab);
  // A stray sync word inside the garbage: the bytes after it make no possible header.
  garbage[10] = 0xED;
  garbage[11] = 0xA1;
  garbage[12] = 0xDA;
  garbage[13] = 0x01;
  log.bytes.insert(log.bytes.begin() + log.offsets[2], garbage.begin(), garbage.end());
  // And more at the very end, and in a second place in the middle.
  log.bytes.insert(log.bytes.end(), {1, 2, 3, 4, 5, 6, 7});
  log.bytes.insert(log.bytes.begin() + log.offsets[6] + static_cast<int64_t>(garbage.size()),
                   {9, 9});
  LcmLogReadResult r;
  EXPECT_EQ(ReadChannels(WriteBytes("garbage.lcmlog", log.bytes), &r), ChannelsExcept(8, {}));
  EXPECT_EQ(r.events, 8);
  EXPECT_EQ(r.skipped_places, 3);
  EXPECT_EQ(r.skipped_bytes, static_cast<int64_t>(garbage.size()) + 2 + 7);
  EXPECT_EQ(r.first_skipped_offset, log.offsets[2]);
  EXPECT_FALSE(r.cut_off_at_end);
}

TEST(LcmEventLog, TruncatedLastEventIsCountedAsCutOff) {
  TestLog log = MakeTestLog(6);
  for (const int64_t cut : {log.offsets[5] + 2, log.offsets[5] + 20, log.offsets[6] - 1}) {
    const std::vector<uint8_t> bytes(log.bytes.begin(), log.bytes.begin() + cut);
    const std::string path = WriteBytes("cut.lcmlog", bytes);
    LcmLogReadResult r;
    EXPECT_EQ(ReadChannels(path, &r), ChannelsExcept(5, {})) << cut;
    EXPECT_EQ(r.skipped_places, 1);
    EXPECT_EQ(r.skipped_bytes, cut - log.offsets[5]);
    EXPECT_EQ(r.first_skipped_offset, log.offsets[5]);
    EXPECT_TRUE(r.cut_off_at_end) << cut;
    EXPECT_NE(r.Summary().find("; read 5 events; the last event is cut off at the end of the file"),
              std::string::npos)
        << r.Summary();
  }
}

// Length fields that cannot be right: negative, zero or too long a channel, a data length of
// 2^31 - 1 or one byte beyond the file. Each event is skipped, the others read.
TEST(LcmEventLog, AbsurdLengthsAreSkipped) {
  const TestLog log = MakeTestLog(6);
  const int64_t at = log.offsets[2];
  const auto with_field = [&](int64_t field_offset, uint32_t value) {
    std::vector<uint8_t> bytes = log.bytes;
    std::vector<uint8_t> v;
    AppendBigEndian(&v, value, 4);
    std::copy(v.begin(), v.end(), bytes.begin() + at + field_offset);
    return bytes;
  };
  const uint32_t beyond = static_cast<uint32_t>(log.offsets[6] - at - 28 - 2 + 1);
  // Fits the file, but would swallow event 3 and end inside event 4.
  const uint32_t swallowing = static_cast<uint32_t>(log.offsets[4] + 10 - at - 28 - 2);
  for (const auto& [field, value] : std::vector<std::pair<int64_t, uint32_t>>{
           {20, 0xffffffffu},  // channel length -1
           {20, 0},            // empty channel
           {20, 1000},         // beyond LCM's limit
           {24, 0x80000000u},  // data length < 0
           {24, 0x7fffffffu},  // 2^31 - 1
           {24, beyond},       // one byte beyond the end of the file
           {24, swallowing}}) {
    LcmLogReadResult r;
    EXPECT_EQ(ReadChannels(WriteBytes("lengths.lcmlog", with_field(field, value)), &r),
              ChannelsExcept(6, {2}))
        << field << " = " << value;
    EXPECT_EQ(r.skipped_places, 1);
    EXPECT_EQ(r.skipped_bytes, log.offsets[3] - log.offsets[2]);
    EXPECT_EQ(r.first_skipped_offset, at);
  }
}

// Random damage (overwritten, inserted and removed bytes, fixed seed): never a crash, and every
// byte is either in an event handed over or counted as skipped.
TEST(LcmEventLog, RandomDamageAccountsForEveryByte) {
  const TestLog log = MakeTestLog(20);
  std::mt19937 rng(5);
  for (int trial = 0; trial < 300; ++trial) {
    std::vector<uint8_t> bytes = log.bytes;
    const int damages = 1 + static_cast<int>(rng() % 4);
    for (int d = 0; d < damages; ++d) {
      const size_t at = rng() % bytes.size();
      const size_t n = 1 + rng() % 40;
      switch (rng() % 3) {
        case 0:
          for (size_t k = at; k < std::min(bytes.size(), at + n); ++k) {
            bytes[k] = static_cast<uint8_t>(rng());
          }
          break;
        case 1:
          for (size_t k = 0; k < n; ++k) {
            bytes.insert(bytes.begin() + static_cast<std::ptrdiff_t>(at),
                         static_cast<uint8_t>(rng()));
          }
          break;
        default:
          bytes.erase(bytes.begin() + static_cast<std::ptrdiff_t>(at),
                      bytes.begin() + static_cast<std::ptrdiff_t>(std::min(bytes.size(), at + n)));
          break;
      }
    }
    const std::string path = WriteBytes("random.lcmlog", bytes);
    int64_t event_bytes = 0;
    try {
      const LcmLogReadResult r =
          ReadLcmLog(path, [&](const std::string& channel, const void*, size_t size) {
            event_bytes += 28 + static_cast<int64_t>(channel.size() + size);
            return true;
          });
      EXPECT_EQ(event_bytes + r.skipped_bytes, static_cast<int64_t>(bytes.size())) << trial;
      EXPECT_GE(r.events, 1);
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("no LCM events in"), std::string::npos) << e.what();
    }
  }
}

// In a child process: limits the address space to what is mapped now plus 256 MiB, checks that a
// 2 GiB allocation fails there, then reads `path`. Exit status 0 when the read gave 5 events.
int ReadUnderAddressSpaceLimit(const std::string& path) {
  std::ifstream statm("/proc/self/statm");
  uint64_t pages = 0;
  statm >> pages;
  const rlim_t limit = pages * static_cast<uint64_t>(sysconf(_SC_PAGESIZE)) + (uint64_t{256} << 20);
  rlimit rl{};
  rl.rlim_cur = rl.rlim_max = limit;
  if (setrlimit(RLIMIT_AS, &rl) != 0) return 2;
  void* probe = std::malloc(size_t{1} << 31);
  if (probe != nullptr) return 3;  // the limit would prove nothing
  try {
    const auto ignore = [](const std::string&, const void*, size_t) { return true; };
    return ReadLcmLog(path, ignore).events == 5 ? 0 : 5;
  } catch (...) {
    return 4;
  }
}

// A data length of 2^31 - 1 in a small file allocates nothing near it: the read passes under an
// address-space limit that a 2 GiB allocation does not.
TEST(LcmEventLog, HugeLengthFieldDoesNotAllocate) {
  TestLog log = MakeTestLog(6);
  std::vector<uint8_t> v;
  AppendBigEndian(&v, 0x7fffffffu, 4);
  std::copy(v.begin(), v.end(), log.bytes.begin() + log.offsets[1] + 24);
  const std::string path = WriteBytes("huge.lcmlog", log.bytes);
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(std::exit(ReadUnderAddressSpaceLimit(path)), ::testing::ExitedWithCode(0), "");
}

TEST(LcmEventLog, EmptyFileAndNotALogAreErrors) {
  const auto expect_error = [](const std::string& path, const std::string& fragment) {
    try {
      ReadLcmLog(path, [](const std::string&, const void*, size_t) { return true; });
      ADD_FAILURE() << "no error for " << path;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    }
  };
  const std::string empty = WriteBytes("empty.lcmlog", {});
  expect_error(empty, "no LCM events in " + empty + ": the file is empty");
  const std::string text = "time,x,y\n0.1,2,3\n";
  const std::string csv = WriteBytes("x.csv", std::vector<uint8_t>(text.begin(), text.end()));
  expect_error(csv, "no LCM events in " + csv + ": none of its 17 bytes forms a valid event");
  // One event, cut off: nothing valid either.
  const TestLog log = MakeTestLog(1);
  const std::string cut =
      WriteBytes("cut.lcmlog", std::vector<uint8_t>(log.bytes.begin(), log.bytes.begin() + 30));
  expect_error(cut, "no LCM events in " + cut);
  expect_error(test::MakeTempDir("lcm_log_folder"), "is a folder");
}

TEST(LcmTransport, UnopenableUrlsAndLogsAreClearErrors) {
  LcmPublisherOptions options;
  options.url = "nosuch://x";
  try {
    LcmPublisher publisher(options);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("cannot open LCM URL 'nosuch://x'"), std::string::npos) << what;
    EXPECT_NE(what.find("unknown LCM provider 'nosuch'"), std::string::npos) << what;
  }
  options.url.clear();
  options.log_path = "/nonexistent_dfo_folder/run.lcmlog";
  try {
    LcmPublisher publisher(options);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_dfo_folder/run.lcmlog"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(ReadLcmLog("/nonexistent_dfo_folder/x.lcmlog",
                          [](const std::string&, const void*, size_t) { return true; }),
               InputError);
  // The udpm text names the multicast route and the command that adds it.
  const std::string udpm = LcmUrlOpenError(kDefaultLcmUrl);
  EXPECT_NE(udpm.find(kDefaultLcmUrl), std::string::npos);
  EXPECT_NE(udpm.find("sudo ip route add 224.0.0.0/4 dev lo"), std::string::npos) << udpm;
  EXPECT_NE(LcmUrlOpenError("garbage").find("not an LCM URL"), std::string::npos);
}

}  // namespace
}  // namespace dfo::io
