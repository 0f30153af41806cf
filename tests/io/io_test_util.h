// Helpers shared by the dfo_io tests: writing small text files and expecting an InputError whose
// message names given fragments.
#ifndef DFO_TESTS_IO_IO_TEST_UTIL_H_
#define DFO_TESTS_IO_IO_TEST_UTIL_H_

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dfo_core/error.h"

namespace dfo::io::test_util {

// Writes `text` to `path`, creating its parent folders.
inline void WriteText(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream(path) << text;
}

// Expects fn() to throw InputError whose message contains every fragment of `needles`.
template <typename Fn>
void ExpectInputError(Fn fn, const std::vector<std::string>& needles) {
  try {
    fn();
    FAIL() << "no InputError thrown";
  } catch (const InputError& e) {
    const std::string what = e.what();
    for (const auto& n : needles) {
      EXPECT_NE(what.find(n), std::string::npos) << what << "\n  missing: " << n;
    }
  }
}

}  // namespace dfo::io::test_util

#endif  // DFO_TESTS_IO_IO_TEST_UTIL_H_
