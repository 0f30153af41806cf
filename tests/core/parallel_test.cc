#include "dfo_core/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

namespace dfo {
namespace {

TEST(RunOnThreads, CallsEveryIndexOnceAndTheFirstOnTheCallingThread) {
  for (int threads : {-1, 0, 1, 2, 5}) {
    const int calls = threads > 1 ? threads : 1;
    std::vector<std::atomic<int>> count(calls);
    std::thread::id first;
    RunOnThreads(threads, [&](int k) {
      count[k].fetch_add(1);
      if (k == 0) first = std::this_thread::get_id();
    });
    for (int k = 0; k < calls; ++k) EXPECT_EQ(count[k].load(), 1) << threads << " threads, k " << k;
    EXPECT_EQ(first, std::this_thread::get_id());
  }
}

TEST(RunOnThreads, RethrowsAfterEveryThreadHasFinished) {
  // The calling thread's call throws at once while the others are still working: the exception
  // must wait for them (a joinable std::thread destroyed by the unwinding would end the process).
  std::atomic<int> finished{0};
  const auto work = [&](int k) {
    if (k == 0) throw std::runtime_error("call 0 failed");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    finished.fetch_add(1);
  };
  try {
    RunOnThreads(3, work);
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "call 0 failed");
  }
  EXPECT_EQ(finished.load(), 2);
  // An exception on another thread reaches the caller too.
  EXPECT_THROW(RunOnThreads(2,
                            [](int k) {
                              if (k == 1) throw std::invalid_argument("call 1 failed");
                            }),
               std::invalid_argument);
}

}  // namespace
}  // namespace dfo
