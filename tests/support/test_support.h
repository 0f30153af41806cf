// Helpers shared by every dfo test: where the optional real data lives, temporary folders.
#ifndef DFO_TESTS_SUPPORT_TEST_SUPPORT_H_
#define DFO_TESTS_SUPPORT_TEST_SUPPORT_H_

#include <string>

namespace dfo::test {

// Folder of ../shared/data (or DFO_SHARED_DATA_DIR), or "" when it is absent. Tests that need it
// call DFO_SKIP_WITHOUT_SHARED_DATA() first.
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

// Runs `exe args` through the shell with standard input from /dev/null, capturing stdout and
// stderr separately (stderr through a temporary file).
CommandResult RunCommand(const std::string& exe, const std::string& args);

// A fresh copy, in its own temporary folder (MakeTempDir(tag)), of a `frames`-frame synthetic
// KITTI-layout sequence (depth maps, poses) that `synth_exe` (dfo_synth, seed 1) renders once per
// process and frame count. Throws std::runtime_error with dfo_synth's stderr when it fails.
std::string CopyOfSyntheticSequence(const std::string& synth_exe, int frames,
                                    const std::string& tag);

}  // namespace dfo::test

#define DFO_SKIP_WITHOUT_SHARED_DATA()                                                     \
  do {                                                                                     \
    if (::dfo::test::SharedDataDir().empty()) {                                            \
      GTEST_SKIP() << "../shared/data not found (set -DDFO_SHARED_DATA_DIR=...); skipped"; \
    }                                                                                      \
  } while (0)

#endif  // DFO_TESTS_SUPPORT_TEST_SUPPORT_H_
