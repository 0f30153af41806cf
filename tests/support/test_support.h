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

}  // namespace dfo::test

#define DFO_SKIP_WITHOUT_SHARED_DATA()                                                  \
  do {                                                                                  \
    if (::dfo::test::SharedDataDir().empty()) {                                         \
      GTEST_SKIP() << "../shared/data not found (set -DDFO_SHARED_DATA_DIR=...); skipped"; \
    }                                                                                   \
  } while (0)

#endif  // DFO_TESTS_SUPPORT_TEST_SUPPORT_H_
