// The syntax of a Torch device key (learned.device, train.device): cpu, cuda or cuda:N. Whether
// this LibTorch can use the device is checked where the networks are built
// (dfo_frontend/learned/internal/device.h, which dfo_io cannot include).
#ifndef DFO_IO_DEVICE_NAME_H_
#define DFO_IO_DEVICE_NAME_H_

#include <string>

namespace dfo::io {

// The rule in words, as ConfigKey::Matches states it.
inline constexpr const char* kDeviceNameRule = "one of cpu, cuda, cuda:N";

// True for "cpu", "cuda" and "cuda:N" with N of 1 to 3 digits.
bool IsDeviceName(const std::string& name);

}  // namespace dfo::io

#endif  // DFO_IO_DEVICE_NAME_H_
