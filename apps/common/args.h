// The command-line parser every dfo tool uses (dfo_run, dfo_eval, dfo_train, ..., and the
// embedding example, which links only this and cli.h: no LCM, no Torch). One grammar everywhere:
//
//   --name VALUE or --name=VALUE   an option with a value; given twice is an error unless the
//                                  option is declared repeatable (like --set)
//   --name                         a flag (no value; --name=VALUE is an error)
//   WORD                           a positional argument, in the declared order
//
// Every mistake throws UsageError with one line naming the argument and what was expected (the
// caller's RunMain prints "<tool>: error: <line>" and exits with status 2): an unknown argument
// (with the closest known one), a missing or empty value, a value that looks like another option,
// an option given twice, a number that is not one in full ("247.9x", "abc", "1e999") or is
// outside its range, a missing or surplus positional argument.
#ifndef DFO_APPS_COMMON_ARGS_H_
#define DFO_APPS_COMMON_ARGS_H_

#include <cstdint>
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "dfo_core/error.h"

namespace dfo::apps {

// A mistake on the command line (unknown flag, missing or malformed value): exit status 2.
class UsageError : public Error {
 public:
  using Error::Error;
};

// `text` as an integer in [lo, hi], all of it ("12x" and "" are refused). `what` names the
// argument in the UsageError ("--frames", "FX").
int64_t ParseIntArgument(const std::string& what, const std::string& text, int64_t lo, int64_t hi);

// `text` as a finite number in [lo, hi], all of it ("247.9x", "abc", "nan", "1e999" are refused).
double ParseNumberArgument(const std::string& what, const std::string& text, double lo, double hi);

class ArgParser {
 public:
  // A flag: `*target` becomes true when given. `alias` e.g. "-h" for "--help".
  ArgParser& Flag(const std::string& name, bool* target, const std::string& alias = "");
  // An option with a non-empty string value, at most once.
  ArgParser& Value(const std::string& name, std::string* target);
  // A repeatable option: each value is appended, in order.
  ArgParser& Values(const std::string& name, std::vector<std::string>* target);
  // Numeric options, at most once, the value checked in full and against [lo, hi].
  ArgParser& Int(const std::string& name, int* target, int lo, int hi);
  ArgParser& Number(const std::string& name, double* target, double lo, double hi);
  // Any other option: `take` receives the value (it may throw UsageError naming `name`).
  ArgParser& Custom(const std::string& name, std::function<void(const std::string&)> take,
                    bool repeatable = false);
  // The next positional argument; the required ones come first.
  ArgParser& Positional(const std::string& name, std::string* target, bool required = true);

  // Parses argv[first] .. argv[argc - 1]. Throws UsageError at the first mistake. With --help
  // (or -h) among the arguments nothing else is checked: the caller prints its usage.
  void Parse(int argc, char** argv, int first = 1);

  // Whether the option `name` was given.
  bool Given(const std::string& name) const { return given_.count(name) != 0; }

 private:
  struct Option {
    std::string name, alias;
    bool takes_value = true;
    bool repeatable = false;
    bool* flag = nullptr;
    std::function<void(const std::string&)> take;
  };
  struct Positional_ {
    std::string name;
    std::string* target = nullptr;
    bool required = true;
  };
  Option& Add(const std::string& name);
  const Option* Find(const std::string& name) const;
  std::string Suggestion(const std::string& unknown) const;

  std::vector<Option> options_;
  std::vector<Positional_> positionals_;
  std::set<std::string> given_;
  std::map<std::string, std::string> first_values_;  // for the "given twice" message
};

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_ARGS_H_
