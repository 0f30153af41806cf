#include "apps/common/cli.h"

#include <exception>
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

}  // namespace dfo::apps
