// The device option of the networks (learned.device for inference, train.device for training):
// its syntax and the torch device it names. Shared so that both keys accept the same names and
// give the same start-up error when this LibTorch cannot use the device.
//
// Internal header (includes c10's Device, not <torch/torch.h>).
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_DEVICE_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_DEVICE_H_

#include <c10/core/Device.h>

#include <string>

namespace dfo::learned {

// Throws ConfigError `<key> = "<name>" violates one of cpu, cuda, cuda:N` unless IsDeviceName
// (dfo_core/device_name.h).
void CheckDeviceName(const std::string& key, const std::string& name);

// The torch device `name` names (checked as CheckDeviceName). ConfigError naming `key` and the
// value when it names a CUDA device this LibTorch cannot use: no CUDA build or no device (e.g.
// Debian's CPU-only libtorch), or an index beyond the devices present.
c10::Device ResolveDevice(const std::string& key, const std::string& name);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_DEVICE_H_
