// Options' Check() messages, one form for every module ("tracker.patch_size = 4 violates odd").
#ifndef DFO_CORE_CHECK_OPTION_H_
#define DFO_CORE_CHECK_OPTION_H_

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

#endif  // DFO_CORE_CHECK_OPTION_H_
