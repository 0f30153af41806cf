#include <cstdlib>
#include <filesystem>
#include <string>

#include "dfo_frontend/learned/learned_sources.h"

// Set by dfo_frontend/CMakeLists.txt for this file alone.
#ifndef DFO_SOURCE_MODEL_DIR
#error "DFO_SOURCE_MODEL_DIR is not defined"
#endif
#ifndef DFO_INSTALLED_MODEL_DIR
#error "DFO_INSTALLED_MODEL_DIR is not defined"
#endif

namespace dfo {

std::string DefaultModelPath() {
  const char* dir = std::getenv("DFO_MODEL_DIR");
  if (dir != nullptr && *dir != '\0') return std::string(dir) + "/default.dfo";
  const std::string source = std::string(DFO_SOURCE_MODEL_DIR) + "/default.dfo";
  std::error_code ec;
  if (std::filesystem::is_regular_file(source, ec)) return source;
  return std::string(DFO_INSTALLED_MODEL_DIR) + "/default.dfo";
}

}  // namespace dfo
