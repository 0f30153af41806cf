#include "tests/support/test_support.h"

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <unistd.h>

namespace dfo::test {

std::string SharedDataDir() {
  const char* env = std::getenv("DFO_SHARED_DATA");
  const std::string dir = env != nullptr ? env : DFO_SHARED_DATA_DIR;
  std::error_code ec;
  if (!dir.empty() && std::filesystem::is_directory(dir, ec)) return dir;
  return "";
}

std::string MakeTempDir(const std::string& tag) {
  static std::atomic<int> counter{0};
  const auto base = std::filesystem::temp_directory_path() /
                    ("dfo_test_" + tag + "_" + std::to_string(::getpid()) + "_" +
                     std::to_string(counter++));
  std::filesystem::remove_all(base);
  std::filesystem::create_directories(base);
  return base.string();
}

std::string SourceDir() { return DFO_SOURCE_DIR; }

}  // namespace dfo::test
