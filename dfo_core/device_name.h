// The syntax of a Torch device option (learned.device, train.device): cpu, cuda or cuda:N. One
// definition for the configuration schemas (dfo_io) and the networks (dfo_frontend/learned, which
// also checks that this LibTorch can use the device).
#ifndef DFO_CORE_DEVICE_NAME_H_
#define DFO_CORE_DEVICE_NAME_H_

#include <string>

namespace dfo {

// The rule in words, for messages and ConfigKey::Matches.
inline constexpr const char* kDeviceNameRule = "one of cpu, cuda, cuda:N";

// True for "cpu", "cuda" and "cuda:N" with N of 1 to 3 digits.
bool IsDeviceName(const std::string& name);

}  // namespace dfo

#endif  // DFO_CORE_DEVICE_NAME_H_
