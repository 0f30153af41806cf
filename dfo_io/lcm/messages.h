// dfo's LCM messages: channel names, conversions between dfo's types and the generated message
// types (package dfo, dfo_io/lcm/types/*.lcm, C++ made by lcm-gen at build time), and decoding
// that never trusts the bytes it is given.
//
//   dfo::pose_t message = MakePoseMessage(frame_index, timestamp_ns, world_from_cam, ...);
//   std::vector<uint8_t> bytes = EncodeLcmMessage(message);
//   dfo::pose_t back;
//   std::string error;
//   if (!DecodeLcmMessage(bytes.data(), bytes.size(), &back, &error)) { /* report, skip */ }
//
// Conventions of every dfo message: poses are camera-to-world in the KITTI camera frame (x right,
// y down, z forward), positions in metres (monocular: up to the run's arbitrary scale),
// orientations unit quaternions in the order w, x, y, z; utime is the frame's timestamp in
// microseconds (LCM's convention), timestamp_ns the exact nanoseconds dfo uses inside.
#ifndef DFO_IO_LCM_MESSAGES_H_
#define DFO_IO_LCM_MESSAGES_H_

#include <cstdint>
#include <string>
#include <vector>

#include "dfo/keyframe_batch_t.hpp"
#include "dfo/keyframe_pose_t.hpp"
#include "dfo/pose_t.hpp"
#include "dfo/run_status_t.hpp"
#include "dfo/stop_t.hpp"
#include "dfo_core/frame.h"
#include "dfo_core/lie.h"

namespace dfo::io {

// The URL dfo_run publishes on by default: UDP multicast with ttl 0, so packets never leave the
// host. On Linux it needs a route for multicast (normally the default route; in a bare network
// namespace `ip route add 224.0.0.0/4 dev lo`).
inline constexpr const char* kDefaultLcmUrl = "udpm://239.255.76.67:7667?ttl=0";

// The channel of each message type. Defaults are those of the `lcm` configuration section.
struct LcmChannels {
  std::string pose = "DFO_POSE";            // pose_t, one per frame and estimate
  std::string keyframes = "DFO_KEYFRAMES";  // keyframe_batch_t, after each bundle adjustment
  std::string status = "DFO_STATUS";        // run_status_t, after each frame
  std::string stop = "DFO_STOP";            // stop_t, once at the end of the run

  // Throws ConfigError when a name is empty or two types share a channel (listeners tell the
  // types apart by channel). `what` names the keys in the message, e.g. "lcm".
  void Check(const std::string& what = "lcm") const;
};

// TrackingStatus as pose_t::STATUS_* and back (unknown codes: false).
int8_t ToLcmStatus(TrackingStatus status);
bool FromLcmStatus(int8_t code, TrackingStatus* status);

// Nanoseconds to LCM's microseconds (rounded toward minus infinity).
int64_t NsToUtime(int64_t ns);

// Writes `pose` into a message's position[3] and orientation[4] (w, x, y, z) arrays.
void PoseToArrays(const SE3d& pose, double position[3], double orientation[4]);
// Reads them back; false (and *error says why) when a value is not finite or the quaternion's
// norm differs from 1 by more than 1e-6. The quaternion is re-normalised.
bool PoseFromArrays(const double position[3], const double orientation[4], SE3d* pose,
                    std::string* error);

// A pose_t for frame `frame_index`: world_from_cam, and what it is composed of (keyframe_index
// and kf_from_cam; keyframe_index = -1 when the pose is absolute; a keyframe gives its own index
// and the identity).
dfo::pose_t MakePoseMessage(int frame_index, int64_t timestamp_ns, const SE3d& world_from_cam,
                            TrackingStatus status, bool is_keyframe, int8_t source,
                            int keyframe_index, const SE3d& kf_from_cam);

// One keyframe_pose_t.
dfo::keyframe_pose_t MakeKeyframePose(int frame_index, int64_t timestamp_ns,
                                      const SE3d& world_from_kf, bool in_window);

// Encodes any generated dfo message (fingerprint included), ready for lcm::LCM::publish.
template <typename Message>
std::vector<uint8_t> EncodeLcmMessage(const Message& message) {
  std::vector<uint8_t> bytes(static_cast<size_t>(message.getEncodedSize()));
  const int n = message.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  bytes.resize(n < 0 ? 0 : static_cast<size_t>(n));
  return bytes;
}

// Decodes `size` bytes as a dfo message of type Message. Never throws and never trusts the
// bytes: returns false with a one-line reason in *error for a buffer shorter than a
// fingerprint, a fingerprint of another type (naming it when it is one of dfo's), a truncated
// message, an array or string length that does not fit the buffer, trailing bytes.
// Defined for dfo::pose_t, keyframe_pose_t, keyframe_batch_t, run_status_t, stop_t.
template <typename Message>
bool DecodeLcmMessage(const void* data, size_t size, Message* out, std::string* error);

// "dfo.pose_t" etc. for a fingerprint of one of dfo's types, else "".
std::string DfoTypeNameOfFingerprint(int64_t fingerprint);

}  // namespace dfo::io

#endif  // DFO_IO_LCM_MESSAGES_H_
