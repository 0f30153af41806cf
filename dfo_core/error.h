// Error types and check macros shared by every dfo module.
//
// Three kinds of failure (see STYLE.md "Errors"):
//  1. Bad input from outside (files, configuration, datasets, model files, messages): throw an
//     InputError (or ConfigError) whose message says what, where, what was found and what was
//     expected. Third-party exceptions are wrapped with that context.
//  2. Broken internal contracts: DFO_CHECK throws an InternalError with file and line, so tests can
//     catch it and libraries never abort.
//  3. Expected outcomes (tracking lost, solver not converged): a status in a result struct.
#ifndef DFO_CORE_ERROR_H_
#define DFO_CORE_ERROR_H_

#include <sstream>
#include <stdexcept>
#include <string>

namespace dfo {

// Base of every exception dfo throws.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Bad input from outside the program: a missing or malformed file, an inconsistent dataset.
class InputError : public Error {
 public:
  using Error::Error;
};

// A configuration value that is unknown, of the wrong type or out of range.
class ConfigError : public InputError {
 public:
  using InputError::InputError;
};

// A broken internal contract (a bug in dfo or in a caller of its API).
class InternalError : public Error {
 public:
  using Error::Error;
};

namespace internal {
[[noreturn]] void ThrowCheckFailure(const char* file, int line, const char* condition,
                                    const std::string& message);
}  // namespace internal

}  // namespace dfo

// DFO_CHECK(cond) << "optional context"; throws dfo::InternalError naming file and line.
#define DFO_CHECK(condition)                                                    \
  if (condition) {                                                              \
  } else                                                                        \
    ::dfo::internal::CheckMessage(__FILE__, __LINE__, #condition).stream()

namespace dfo::internal {
// Collects the streamed context of a failed DFO_CHECK and throws when destroyed.
class CheckMessage {
 public:
  CheckMessage(const char* file, int line, const char* condition)
      : file_(file), line_(line), condition_(condition) {}
  CheckMessage(const CheckMessage&) = delete;
  CheckMessage& operator=(const CheckMessage&) = delete;
  ~CheckMessage() noexcept(false) { ThrowCheckFailure(file_, line_, condition_, stream_.str()); }
  std::ostringstream& stream() { return stream_; }

 private:
  const char* file_;
  int line_;
  const char* condition_;
  std::ostringstream stream_;
};
}  // namespace dfo::internal

#endif  // DFO_CORE_ERROR_H_
