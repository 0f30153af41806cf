#include "dfo_core/error.h"

namespace dfo::internal {

void ThrowCheckFailure(const char* file, int line, const char* condition,
                       const std::string& message) {
  std::ostringstream out;
  out << file << ":" << line << ": check failed: " << condition;
  if (!message.empty()) out << " (" << message << ")";
  throw InternalError(out.str());
}

}  // namespace dfo::internal
