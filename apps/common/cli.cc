#include "apps/common/cli.h"

#include <unistd.h>

#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>

namespace dfo::apps {

bool SplitFlagValue(std::string* flag, std::string* value) {
  value->clear();
  const size_t eq = flag->find('=');
  if (flag->rfind("--", 0) != 0 || eq == std::string::npos) return false;
  *value = flag->substr(eq + 1);
  flag->resize(eq);
  return true;
}

int RunMain(const std::string& program, const std::function<int()>& body, bool hint_help) {
  try {
    return body();
  } catch (const UsageError& e) {
    std::cerr << program << ": error: " << e.what();
    if (hint_help) std::cerr << " (see " << program << " --help)";
    std::cerr << "\n";
    return 2;
  } catch (const std::exception& e) {
    std::cerr << program << ": error: " << e.what() << "\n";
    return 1;
  }
}

void UsePassiveOpenMpWait(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  if (setenv("OMP_WAIT_POLICY", "PASSIVE", 1) != 0) return;
  execv("/proc/self/exe", argv);
  // Only reached when the re-execution failed: the runtime keeps its default wait.
}

std::string OpenMpWaitPolicyAtStart() {
  std::ifstream in("/proc/self/environ", std::ios::binary);
  const std::string prefix = "OMP_WAIT_POLICY=";
  std::string entry;
  while (std::getline(in, entry, '\0')) {
    if (entry.compare(0, prefix.size(), prefix) == 0) return entry.substr(prefix.size());
  }
  return "";
}

}  // namespace dfo::apps
