#include "tests/support/test_support.h"

#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>

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
  const auto base =
      std::filesystem::temp_directory_path() /
      ("dfo_test_" + tag + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
  std::filesystem::remove_all(base);
  std::filesystem::create_directories(base);
  return base.string();
}

std::string SourceDir() { return DFO_SOURCE_DIR; }

std::string ReadFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::stringstream ss;
  ss << file.rdbuf();
  return ss.str();
}

CommandResult RunCommand(const std::string& exe, const std::string& args) {
  static std::atomic<int> counter{0};
  const std::string err_path =
      MakeTempDir("stderr") + "/stderr_" + std::to_string(counter++) + ".txt";
  const std::string command = exe + " " + args + " 2>" + err_path + " </dev/null";
  CommandResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  char buf[4096];
  size_t n = 0;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) result.out.append(buf, n);
  const int wait_status = pclose(pipe);
  result.status = WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1;
  std::ifstream err(err_path);
  std::stringstream ss;
  ss << err.rdbuf();
  result.err = ss.str();
  return result;
}

std::string SyntheticSequence(const std::string& synth_exe, int frames) {
  static std::mutex mutex;
  static std::map<int, std::string> rendered;
  std::lock_guard<std::mutex> lock(mutex);
  std::string& dir = rendered[frames];
  if (dir.empty()) {
    const std::string target = MakeTempDir("synthetic_" + std::to_string(frames));
    const CommandResult r = RunCommand(
        synth_exe, "--output " + target + " --frames " + std::to_string(frames) + " --seed 1");
    if (r.status != 0) throw std::runtime_error("dfo_synth failed: " + r.err);
    dir = target;
  }
  return dir;
}

std::string CopyOfSyntheticSequence(const std::string& synth_exe, int frames,
                                    const std::string& tag) {
  const std::string base = SyntheticSequence(synth_exe, frames);
  const std::string copy = MakeTempDir(tag);
  std::filesystem::copy(base, copy,
                        std::filesystem::copy_options::recursive |
                            std::filesystem::copy_options::overwrite_existing);
  return copy;
}

}  // namespace dfo::test
