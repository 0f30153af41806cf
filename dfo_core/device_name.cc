#include "dfo_core/device_name.h"

namespace dfo {

bool IsDeviceName(const std::string& name) {
  if (name == "cpu" || name == "cuda") return true;
  return name.rfind("cuda:", 0) == 0 && name.size() > 5 && name.size() <= 8 &&
         name.find_first_not_of("0123456789", 5) == std::string::npos;
}

}  // namespace dfo
