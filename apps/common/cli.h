// Command-line plumbing shared by dfo's executables: the usage-error type, "--flag=value"
// splitting, and main()'s mapping of exceptions to one stderr line and an exit status.
#ifndef DFO_APPS_COMMON_CLI_H_
#define DFO_APPS_COMMON_CLI_H_

#include <functional>
#include <string>

#include "dfo_core/error.h"

namespace dfo::apps {

// A mistake on the command line (unknown flag, missing or malformed value): exit status 2.
class UsageError : public Error {
 public:
  using Error::Error;
};

// Splits an argument of the form "--flag=value" into *flag = "--flag" and *value = "value" and
// returns true; any other argument is left as it is (*value cleared) and false is returned.
bool SplitFlagValue(std::string* flag, std::string* value);

// Runs `body` (which parses the arguments and does the work) and returns its exit status. A
// UsageError prints "<program>: error: <what>" (plus " (see <program> --help)" when
// `hint_help`) and returns 2; any other exception prints "<program>: error: <what>" and returns 1.
int RunMain(const std::string& program, const std::function<int()>& body, bool hint_help = true);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_CLI_H_
