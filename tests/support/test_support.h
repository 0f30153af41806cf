// Helpers shared by every dfo test: where the optional real data lives, temporary folders.
#ifndef DFO_TESTS_SUPPORT_TEST_SUPPORT_H_
#define DFO_TESTS_SUPPORT_TEST_SUPPORT_H_

#include <cstdlib>
#include <string>

namespace dfo::test {

// Folder of ../shared/data ($DFO_SHARED_DATA when set, else the CMake cache's
// DFO_SHARED_DATA_DIR), or "" when it is absent. Tests that need it call
// DFO_SKIP_WITHOUT_SHARED_DATA() first.
std::string SharedDataDir();

// A fresh, empty temporary folder unique to this test; removed at process exit is not promised.
std::string MakeTempDir(const std::string& tag);

// The project's source folder (for configs/ and the like).
std::string SourceDir();

// What a finished command printed and how it exited.
struct CommandResult {
  int status = -1;  // exit status; -1 when it could not start or did not exit normally
  std::string out;  // standard output
  std::string err;  // standard error
};

// The whole file's bytes ("" when it cannot be read).
std::string ReadFile(const std::string& path);

// Runs `exe args` through the shell with standard input from /dev/null, capturing stdout and
// stderr separately (stderr through a temporary file).
CommandResult RunCommand(const std::string& exe, const std::string& args);

// The folder of a `frames`-frame synthetic KITTI-layout sequence (depth maps, poses) that
// `synth_exe` (dfo_synth, seed 1) renders once per process and frame count; shared, so read
// only. Throws std::runtime_error with dfo_synth's stderr when it fails.
std::string SyntheticSequence(const std::string& synth_exe, int frames);

// A fresh copy of SyntheticSequence(synth_exe, frames) in its own temporary folder
// (MakeTempDir(tag)), for tests that change it.
std::string CopyOfSyntheticSequence(const std::string& synth_exe, int frames,
                                    const std::string& tag);

namespace internal {
// The skip message of DFO_SKIP_WITHOUT_SHARED_DATA: the folder SharedDataDir() looked at
// ($DFO_SHARED_DATA when set, else the CMake cache's DFO_SHARED_DATA_DIR) is not a folder.
inline std::string SharedDataSkipReason() {
  const char* env = std::getenv("DFO_SHARED_DATA");
  const std::string where =
      env != nullptr ? "$DFO_SHARED_DATA = '" + std::string(env) + "'"
                     : "DFO_SHARED_DATA_DIR = '" + std::string(DFO_SHARED_DATA_DIR) + "'";
  return "skipped: needs the real data of ../shared/data, but " + where +
         " is not a folder (configure with -DDFO_SHARED_DATA_DIR=... or run with "
         "DFO_SHARED_DATA=...)";
}
}  // namespace internal

}  // namespace dfo::test

// Skips the test when SharedDataDir() is "", saying which folder was looked at and how to point
// the tests elsewhere. Only an absent folder skips: a folder without the files a test reads
// fails that test (the reader's error names the file).
#define DFO_SKIP_WITHOUT_SHARED_DATA()                               \
  do {                                                               \
    if (::dfo::test::SharedDataDir().empty()) {                      \
      GTEST_SKIP() << ::dfo::test::internal::SharedDataSkipReason(); \
    }                                                                \
  } while (0)

#endif  // DFO_TESTS_SUPPORT_TEST_SUPPORT_H_
