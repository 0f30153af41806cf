#include "dfo_frontend/learned/internal/device.h"

#include <torch/cuda.h>

#include "dfo_core/check_option.h"
#include "dfo_core/device_name.h"
#include "dfo_core/error.h"

namespace dfo::learned {

void CheckDeviceName(const std::string& key, const std::string& name) {
  ::dfo::internal::CheckOption(::dfo::IsDeviceName(name), key, "\"" + name + "\"",
                               ::dfo::kDeviceNameRule);
}

c10::Device ResolveDevice(const std::string& key, const std::string& name) {
  CheckDeviceName(key, name);
  if (name == "cpu") return c10::Device(c10::kCPU);
  if (!torch::cuda::is_available()) {
    throw ConfigError(key + " = \"" + name +
                      "\": this LibTorch has no usable CUDA device (Debian's libtorch is built for "
                      "the CPU only; build dfo against a CUDA LibTorch, see README, or use cpu)");
  }
  if (name == "cuda") return c10::Device(c10::kCUDA);
  const int index = std::stoi(name.substr(5));
  const int count = static_cast<int>(torch::cuda::device_count());
  if (index >= count) {
    throw ConfigError(key + " = \"" + name + "\": only " + std::to_string(count) +
                      " CUDA device(s) present");
  }
  return c10::Device(c10::kCUDA, static_cast<c10::DeviceIndex>(index));
}

}  // namespace dfo::learned
