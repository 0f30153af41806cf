// Running one piece of work on several threads and waiting for all of them.
#ifndef DFO_CORE_PARALLEL_H_
#define DFO_CORE_PARALLEL_H_

#include <exception>
#include <system_error>
#include <thread>
#include <vector>

namespace dfo {

// Calls work(k) for k = 0 .. threads - 1 (at least once, k = 0, for threads <= 1): k = 0 on the
// calling thread, the others on threads of their own, and returns when every call has returned.
// A thread the system cannot start has its call made on the calling thread instead. The first
// exception a call throws is rethrown once all threads are joined, so an exception never leaves
// a joinable std::thread behind (whose destruction would end the process).
template <typename Work>
void RunOnThreads(int threads, const Work& work) {
  std::vector<std::exception_ptr> errors(threads > 1 ? threads : 1);
  const auto call = [&work, &errors](int k) {
    try {
      work(k);
    } catch (...) {
      errors[k] = std::current_exception();
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads > 1 ? threads - 1 : 0);  // no reallocation while threads run
  std::vector<int> not_started;
  for (int k = 1; k < threads; ++k) {
    try {
      pool.emplace_back(call, k);
    } catch (const std::system_error&) {
      not_started.push_back(k);
    }
  }
  call(0);
  for (int k : not_started) call(k);
  for (std::thread& thread : pool) thread.join();
  for (const std::exception_ptr& error : errors) {
    if (error) std::rethrow_exception(error);
  }
}

}  // namespace dfo

#endif  // DFO_CORE_PARALLEL_H_
