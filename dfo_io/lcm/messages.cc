#include "dfo_io/lcm/messages.h"

#include <climits>
#include <cmath>
#include <cstdio>
#include <exception>
#include <utility>

#include "dfo_core/error.h"

namespace dfo::io {
namespace {

constexpr double kQuaternionNormTolerance = 1e-6;
// |q|^2 of a quaternion normalised in double precision is 1 within a few ulp.
constexpr double kUnitSquaredNormTolerance = 1e-14;

// LCM encodes every integer big-endian; the fingerprint is the first 8 bytes.
int64_t ReadBigEndianInt64(const uint8_t* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<int64_t>(v);
}

int32_t ReadBigEndianInt32(const uint8_t* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v = (v << 8) | p[i];
  return static_cast<int32_t>(v);
}

std::string Hex(int64_t v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "0x%016llx", static_cast<unsigned long long>(v));
  return buf;
}

template <typename Message>
std::string TypeName() {
  return std::string("dfo.") + Message::getTypeName();
}

// Checks done before the generated decoder runs, for what it does not check itself.
template <typename Message>
bool PreCheck(const uint8_t* /*data*/, size_t /*size*/, std::string* /*error*/) {
  return true;
}

// The generated decoder resizes keyframes[] to num_keyframes before it looks at the buffer: a
// corrupt count would allocate gigabytes. The count is the last field before the array.
template <>
bool PreCheck<dfo::keyframe_batch_t>(const uint8_t* data, size_t size, std::string* error) {
  const size_t header = static_cast<size_t>(dfo::keyframe_batch_t{}.getEncodedSize());
  if (size < header) {
    *error = "truncated dfo.keyframe_batch_t: " + std::to_string(size) + " bytes, at least " +
             std::to_string(header) + " expected";
    return false;
  }
  const int32_t count = ReadBigEndianInt32(data + header - 4);
  const size_t element = static_cast<size_t>(dfo::keyframe_pose_t{}._getEncodedSizeNoHash());
  if (count < 0 || static_cast<size_t>(count) > (size - header) / element) {
    *error = "malformed dfo.keyframe_batch_t: num_keyframes = " + std::to_string(count) +
             " does not fit its " + std::to_string(size) + " bytes (" + std::to_string(element) +
             " bytes per keyframe after a " + std::to_string(header) + "-byte header)";
    return false;
  }
  return true;
}

}  // namespace

void LcmChannels::Check(const std::string& what) const {
  const std::pair<const char*, const std::string*> named[] = {{"pose_channel", &pose},
                                                              {"keyframes_channel", &keyframes},
                                                              {"status_channel", &status},
                                                              {"stop_channel", &stop}};
  for (size_t i = 0; i < 4; ++i) {
    if (named[i].second->empty()) {
      throw ConfigError(what + "." + named[i].first +
                        " is empty; every message type needs a channel");
    }
    for (size_t j = 0; j < i; ++j) {
      if (*named[i].second == *named[j].second) {
        throw ConfigError(what + "." + named[i].first + " and " + what + "." + named[j].first +
                          " are both '" + *named[i].second +
                          "'; each message type needs its own channel");
      }
    }
  }
}

int8_t ToLcmStatus(TrackingStatus status) {
  switch (status) {
    case TrackingStatus::kOk:
      return dfo::pose_t::STATUS_OK;
    case TrackingStatus::kDegraded:
      return dfo::pose_t::STATUS_DEGRADED;
    case TrackingStatus::kLost:
      return dfo::pose_t::STATUS_LOST;
    case TrackingStatus::kReference:
      return dfo::pose_t::STATUS_REFERENCE;
  }
  return dfo::pose_t::STATUS_LOST;
}

bool FromLcmStatus(int8_t code, TrackingStatus* status) {
  switch (code) {
    case dfo::pose_t::STATUS_OK:
      *status = TrackingStatus::kOk;
      return true;
    case dfo::pose_t::STATUS_DEGRADED:
      *status = TrackingStatus::kDegraded;
      return true;
    case dfo::pose_t::STATUS_LOST:
      *status = TrackingStatus::kLost;
      return true;
    case dfo::pose_t::STATUS_REFERENCE:
      *status = TrackingStatus::kReference;
      return true;
    default:
      return false;
  }
}

int64_t NsToUtime(int64_t ns) {
  int64_t us = ns / 1000;
  if (ns % 1000 < 0) --us;
  return us;
}

void PoseToArrays(const SE3d& pose, double position[3], double orientation[4]) {
  const Eigen::Vector3d& t = pose.translation();
  const Eigen::Quaterniond& q = pose.quaternion();
  position[0] = t.x();
  position[1] = t.y();
  position[2] = t.z();
  orientation[0] = q.w();
  orientation[1] = q.x();
  orientation[2] = q.y();
  orientation[3] = q.z();
}

bool PoseFromArrays(const double position[3], const double orientation[4], SE3d* pose,
                    std::string* error) {
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(position[i])) {
      *error = "non-finite position";
      return false;
    }
  }
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(orientation[i])) {
      *error = "non-finite orientation";
      return false;
    }
  }
  const Eigen::Quaterniond q(orientation[0], orientation[1], orientation[2], orientation[3]);
  if (std::abs(q.norm() - 1.0) > kQuaternionNormTolerance) {
    *error =
        "orientation quaternion has norm " + std::to_string(q.norm()) + ", expected 1 (w, x, y, z)";
    return false;
  }
  // A quaternion that was unit when sent is kept bit for bit, so that a pose read back equals
  // the pose published exactly; anything else within the tolerance is re-normalised.
  const bool unit = std::abs(q.squaredNorm() - 1.0) <= kUnitSquaredNormTolerance;
  *pose = SE3d(unit ? SO3d::FromUnitQuaternion(q) : SO3d(q),
               Eigen::Vector3d(position[0], position[1], position[2]));
  return true;
}

dfo::pose_t MakePoseMessage(int frame_index, int64_t timestamp_ns, const SE3d& world_from_cam,
                            TrackingStatus status, bool is_keyframe, int8_t source,
                            int keyframe_index, const SE3d& kf_from_cam) {
  dfo::pose_t m{};
  m.utime = NsToUtime(timestamp_ns);
  m.timestamp_ns = timestamp_ns;
  m.frame_index = frame_index;
  PoseToArrays(world_from_cam, m.position, m.orientation);
  m.status = ToLcmStatus(status);
  m.is_keyframe = is_keyframe ? 1 : 0;
  m.source = source;
  m.keyframe_index = keyframe_index;
  PoseToArrays(kf_from_cam, m.kf_position, m.kf_orientation);
  return m;
}

dfo::keyframe_pose_t MakeKeyframePose(int frame_index, int64_t timestamp_ns,
                                      const SE3d& world_from_kf, bool in_window) {
  dfo::keyframe_pose_t k{};
  k.utime = NsToUtime(timestamp_ns);
  k.timestamp_ns = timestamp_ns;
  k.frame_index = frame_index;
  PoseToArrays(world_from_kf, k.position, k.orientation);
  k.in_window = in_window ? 1 : 0;
  return k;
}

std::string DfoTypeNameOfFingerprint(int64_t fingerprint) {
  if (fingerprint == dfo::pose_t::getHash()) return TypeName<dfo::pose_t>();
  if (fingerprint == dfo::keyframe_pose_t::getHash()) return TypeName<dfo::keyframe_pose_t>();
  if (fingerprint == dfo::keyframe_batch_t::getHash()) return TypeName<dfo::keyframe_batch_t>();
  if (fingerprint == dfo::run_status_t::getHash()) return TypeName<dfo::run_status_t>();
  if (fingerprint == dfo::stop_t::getHash()) return TypeName<dfo::stop_t>();
  return "";
}

template <typename Message>
bool DecodeLcmMessage(const void* data, size_t size, Message* out, std::string* error) {
  const std::string name = TypeName<Message>();
  const auto* bytes = static_cast<const uint8_t*>(data);
  if (data == nullptr || size < 8) {
    *error = "message of " + std::to_string(size) + " bytes is too short for an LCM fingerprint (" +
             name + " expected)";
    return false;
  }
  if (size > static_cast<size_t>(INT_MAX)) {
    *error = "message of " + std::to_string(size) + " bytes is too large for " + name;
    return false;
  }
  const int64_t fingerprint = ReadBigEndianInt64(bytes);
  if (fingerprint != Message::getHash()) {
    const std::string other = DfoTypeNameOfFingerprint(fingerprint);
    *error = other.empty()
                 ? "fingerprint " + Hex(fingerprint) + " is not " + name + "'s (" +
                       Hex(Message::getHash()) + "): a message of another type or another version"
                 : "a " + other + " where " + name + " was expected";
    return false;
  }
  if (!PreCheck<Message>(bytes, size, error)) return false;
  Message decoded{};
  int used = -1;
  try {
    used = decoded.decode(data, 0, static_cast<int>(size));
  } catch (const std::exception& e) {
    *error = "malformed " + name + " of " + std::to_string(size) + " bytes (" + e.what() + ")";
    return false;
  }
  if (used < 0) {
    *error = "truncated or malformed " + name + ": " + std::to_string(size) +
             " bytes do not hold the whole message (at least " +
             std::to_string(Message{}.getEncodedSize()) + " expected)";
    return false;
  }
  if (static_cast<size_t>(used) != size) {
    *error = "malformed " + name + ": " + std::to_string(size - static_cast<size_t>(used)) +
             " bytes left over after the message's " + std::to_string(used);
    return false;
  }
  *out = std::move(decoded);
  return true;
}

template bool DecodeLcmMessage(const void*, size_t, dfo::pose_t*, std::string*);
template bool DecodeLcmMessage(const void*, size_t, dfo::keyframe_pose_t*, std::string*);
template bool DecodeLcmMessage(const void*, size_t, dfo::keyframe_batch_t*, std::string*);
template bool DecodeLcmMessage(const void*, size_t, dfo::run_status_t*, std::string*);
template bool DecodeLcmMessage(const void*, size_t, dfo::stop_t*, std::string*);

}  // namespace dfo::io
