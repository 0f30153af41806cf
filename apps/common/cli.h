// Command-line plumbing shared by dfo's executables: main()'s mapping of exceptions to one stderr
// line and an exit status (the argument parser and the usage-error type: args.h).
#ifndef DFO_APPS_COMMON_CLI_H_
#define DFO_APPS_COMMON_CLI_H_

#include <functional>
#include <string>

#include "apps/common/args.h"
#include "dfo_core/error.h"

namespace dfo::apps {

// Runs `body` (which parses the arguments and does the work) and returns its exit status. A
// UsageError prints "<program>: error: <what>" (plus " (see <program> --help)" when
// `hint_help`) and returns 2; any other exception prints "<program>: error: <what>" and returns 1.
int RunMain(const std::string& program, const std::function<int()>& body, bool hint_help = true);

// OpenMP's passive wait for the LibTorch executables: idle OpenMP threads sleep instead of
// spinning, so that the network is not slowed down by its own spinning threads when other
// processes share the cores (measured 7x slower with the default wait beside another process).
// The OpenMP runtime reads OMP_WAIT_POLICY once, when it is loaded, before main(): so when the
// variable is unset this sets it to PASSIVE and re-executes the program (/proc/self/exe, same
// arguments, file descriptors and environment otherwise). A value the user set is kept. When the
// re-execution fails the program goes on with the runtime's default. Call first in main().
void UsePassiveOpenMpWait(char** argv);

// OMP_WAIT_POLICY as this process image started with it (/proc/self/environ, which setenv() does
// not change): the value the OpenMP runtime read. "" when unset or unreadable.
std::string OpenMpWaitPolicyAtStart();

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_CLI_H_
