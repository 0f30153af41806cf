// dfo's LCM messages (dfo_io/lcm/): every type through encode/decode, decoding that survives
// foreign, truncated and corrupted bytes, in-process publish/subscribe over memq://, the event log
// written by LcmPublisher read back, and the trajectory collector behind dfo_lcm_listen
// (windowed history corrected by keyframe batches, bad messages skipped).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <limits>
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
  const int64_t events =
      ReadLcmLog(options.log_path, [&](const std::string& channel, const void* data, size_t size) {
        channels.push_back(channel);
        EXPECT_NE(collector.Handle(channel, data, size).kind, LcmCollectorEvent::Kind::kMalformed);
        return true;
      });
  EXPECT_EQ(events, 6);
  ASSERT_EQ(channels.size(), 6u);
  EXPECT_EQ(channels[4], ch.keyframes);
  EXPECT_EQ(collector.num_windowed_frames(), 4u);
  EXPECT_TRUE(collector.stopped());
  // Stopping early.
  int seen = 0;
  EXPECT_EQ(ReadLcmLog(options.log_path,
                       [&](const std::string&, const void*, size_t) { return ++seen < 2; }),
            2);
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
