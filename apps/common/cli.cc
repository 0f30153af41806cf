#include "apps/common/cli.h"

#include <unistd.h>

#include <glog/logging.h>

#include <cctype>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <iostream>
#include <new>

namespace dfo::apps {

namespace {

// Lines that Ceres or LibTorch log through glog: "<program>: ceres warning (file.cc:12) <text>"
// instead of glog's own header and its "Logging before InitGoogleLogging()" line.
void LibraryLogPrefix(std::ostream& out, const google::LogMessageInfo& info, void* data) {
  std::string severity = info.severity;
  for (char& c : severity) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::string file = info.filename;
  const bool torch = file.find("c10") != std::string::npos ||
                     file.find("torch") != std::string::npos ||
                     file.find("aten") != std::string::npos;
  out << *static_cast<const std::string*>(data) << ": " << (torch ? "LibTorch " : "library ")
      << severity << " (" << file.substr(file.find_last_of('/') + 1) << ":" << info.line_number
      << ")";
}

void InitLibraryLogging(const std::string& program) {
  if (google::IsGoogleLoggingInitialized()) return;
  static const std::string name = program;
  FLAGS_logtostderr = true;  // never log files in /tmp
  FLAGS_minloglevel = google::GLOG_WARNING;
  google::InitGoogleLogging(name.c_str(), &LibraryLogPrefix, const_cast<std::string*>(&name));
}

}  // namespace

int RunMain(const std::string& program, const std::function<int()>& body, bool hint_help) {
  InitLibraryLogging(program);
  try {
    return body();
  } catch (const std::bad_alloc&) {
    std::cerr << program << ": error: out of memory (a size in the input or the configuration "
                            "beyond what this machine holds)\n";
    return 1;
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
