// The backend's option checks: one message form for every YAML key.
#ifndef DFO_BACKEND_CHECK_KEY_H_
#define DFO_BACKEND_CHECK_KEY_H_

#include <sstream>
#include <string>

#include "dfo_core/error.h"

namespace dfo::internal {

// Throws ConfigError "<key> = <value> violates <rule>" unless ok.
template <typename T>
void CheckKey(bool ok, const std::string& key, const T& value, const std::string& rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << key << " = " << value << " violates " << rule;
  throw ConfigError(msg.str());
}

}  // namespace dfo::internal

#endif  // DFO_BACKEND_CHECK_KEY_H_
