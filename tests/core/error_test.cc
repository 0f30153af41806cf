#include "dfo_core/error.h"

#include <gtest/gtest.h>

#include "dfo_core/lie.h"

namespace dfo {
namespace {

TEST(Error, CheckThrowsInternalErrorWithLocationAndContext) {
  try {
    const int value = 3;
    DFO_CHECK(value == 4) << "value=" << value;
    FAIL() << "DFO_CHECK did not throw";
  } catch (const InternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("error_test.cc"), std::string::npos) << what;
    EXPECT_NE(what.find("value == 4"), std::string::npos) << what;
    EXPECT_NE(what.find("value=3"), std::string::npos) << what;
  }
}

TEST(Error, PassingCheckDoesNothing) { EXPECT_NO_THROW(DFO_CHECK(1 + 1 == 2) << "never"); }

TEST(Error, HierarchyLetsCallersCatchInputErrors) {
  EXPECT_THROW(throw ConfigError("bad key"), InputError);
  EXPECT_THROW(throw InputError("bad file"), Error);
}

}  // namespace
}  // namespace dfo
