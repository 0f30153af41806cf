// Small helpers for options' Check() messages ("tracker.patch_size = 4 violates odd").
#ifndef DFO_FRONTEND_INTERNAL_CHECK_UTIL_H_
#define DFO_FRONTEND_INTERNAL_CHECK_UTIL_H_

#include <sstream>
#include <string>

#include "dfo_core/error.h"

namespace dfo::internal {

// Throws ConfigError "<field> = <value> violates <rule>" unless ok.
template <typename T>
void CheckOption(bool ok, const std::string& field, const T& value, const std::string& rule) {
  if (ok) return;
  std::ostringstream msg;
  msg << field << " = " << value << " violates " << rule;
  throw ConfigError(msg.str());
}

}  // namespace dfo::internal

#endif  // DFO_FRONTEND_INTERNAL_CHECK_UTIL_H_
