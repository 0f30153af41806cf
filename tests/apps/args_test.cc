// The command-line parser every tool uses (apps/common/args.h), and the tools' exit status 2 with
// one "<tool>: error:" line for each kind of mistake.
#include "apps/common/args.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include "tests/support/test_support.h"

namespace dfo::apps {
namespace {

// argv from words (argv[0] = "tool").
class Argv {
 public:
  explicit Argv(std::vector<std::string> words) : words_(std::move(words)) {
    words_.insert(words_.begin(), "tool");
    for (std::string& w : words_) pointers_.push_back(w.data());
  }
  int argc() const { return static_cast<int>(pointers_.size()); }
  char** argv() { return pointers_.data(); }

 private:
  std::vector<std::string> words_;
  std::vector<char*> pointers_;
};

struct Parsed {
  bool help = false, flag = false;
  std::string config, positional, optional_positional;
  std::vector<std::string> sets;
  int count = 3;
  double scale = 1.0;
};

// Parses `words` with a parser of every kind of option; returns the UsageError's message ("" when
// none) and fills *out.
std::string ParseWords(const std::vector<std::string>& words, Parsed* out,
                       bool with_positionals = false) {
  ArgParser parser;
  parser.Flag("--help", &out->help, "-h")
      .Flag("--flag", &out->flag)
      .Value("--config", &out->config)
      .Values("--set", &out->sets)
      .Int("--count", &out->count, 1, 10)
      .Number("--scale", &out->scale, -5.0, 5.0);
  if (with_positionals) {
    parser.Positional("FIRST", &out->positional)
        .Positional("SECOND", &out->optional_positional, /*required=*/false);
  }
  Argv argv(words);
  try {
    parser.Parse(argv.argc(), argv.argv());
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(ArgParser, ReadsEveryKindOfArgumentInBothSpellings) {
  Parsed p;
  EXPECT_EQ(ParseWords({"--flag", "--config", "a.yaml", "--set=x=1", "--set", "y=2", "--count=7",
                        "--scale", "-2.5", "in", "out"},
                       &p, true),
            "");
  EXPECT_TRUE(p.flag);
  EXPECT_EQ(p.config, "a.yaml");
  EXPECT_EQ(p.sets, (std::vector<std::string>{"x=1", "y=2"}));  // repeatable, in order
  EXPECT_EQ(p.count, 7);
  EXPECT_DOUBLE_EQ(p.scale, -2.5);  // a negative number is a value, not an option
  EXPECT_EQ(p.positional, "in");
  EXPECT_EQ(p.optional_positional, "out");
}

TEST(ArgParser, EveryMistakeIsAUsageErrorNamingTheArgument) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--config", "a.yaml", "--config", "b.yaml"},
       "--config given twice ('a.yaml', then 'b.yaml'): give it once"},
      {{"--count", "2", "--count=3"}, "--count given twice"},
      {{"--confg", "a"}, "unknown argument '--confg' (did you mean '--config'?)"},
      {{"--nothing-like-it"}, "unknown argument '--nothing-like-it'"},
      {{"--config"}, "--config needs a value"},
      {{"--config", "--flag"}, "--config needs a value, found the option '--flag'"},
      {{"--config="}, "--config needs a non-empty value"},
      {{"--flag=1"}, "--flag takes no value"},
      {{"--count", "7x"}, "--count: '7x' is not an integer"},
      {{"--count", "1e1"}, "--count: '1e1' is not an integer"},
      {{"--count", " 7"}, "--count: ' 7' is not an integer"},
      {{"--count", "11"}, "--count: 11 is out of range (expected an integer in [1, 10])"},
      {{"--count", "99999999999999999999"}, "--count: '99999999999999999999' is not an integer"},
      {{"--scale", "247.9x"}, "--scale: '247.9x' is not a (finite) number"},
      {{"--scale", "abc"}, "--scale: 'abc' is not a (finite) number"},
      {{"--scale", "nan"}, "--scale: 'nan' is not a (finite) number"},
      {{"--scale", "1e999"}, "--scale: '1e999' is not a (finite) number"},
      {{"--scale", "6"}, "--scale: 6 is out of range"},
      {{"stray"}, "unexpected argument 'stray' (this tool takes only options)"},
  };
  for (const auto& [words, expected] : cases) {
    Parsed p;
    const std::string message = ParseWords(words, &p);
    EXPECT_TRUE(Contains(message, expected)) << words[0] << ": got '" << message << "'";
  }
  Parsed p;
  EXPECT_EQ(ParseWords({}, &p, true), "FIRST is missing");
  EXPECT_EQ(ParseWords({"a", "b", "c"}, &p, true), "unexpected argument 'c' after SECOND");
}

TEST(ArgParser, HelpSkipsEveryOtherCheck) {
  Parsed p;
  EXPECT_EQ(ParseWords({"--bogus", "-h"}, &p, true), "");
  EXPECT_TRUE(p.help);
}

TEST(ArgParser, StrictNumbersOnTheirOwn) {
  EXPECT_EQ(ParseIntArgument("N", "-12", -20, 20), -12);
  EXPECT_DOUBLE_EQ(ParseNumberArgument("X", "1e-3", 0, 1), 1e-3);
  EXPECT_THROW(ParseIntArgument("N", "", 0, 1), UsageError);
  EXPECT_THROW(ParseNumberArgument("X", "", 0, 1), UsageError);
  EXPECT_THROW(ParseNumberArgument("X", "1.5 ", 0, 2), UsageError);
}

// Each tool: a mistake is one "<tool>: error:" line on stderr and exit status 2.
void ExpectUsageError(const char* exe, const std::string& tool, const std::string& args,
                      const std::string& expected) {
  const test::CommandResult r = test::RunCommand(exe, args);
  EXPECT_EQ(r.status, 2) << tool << " " << args << ": " << r.err;
  EXPECT_EQ(r.err.rfind(tool + ": error: ", 0), 0u) << tool << " " << args << ": " << r.err;
  EXPECT_TRUE(Contains(r.err, expected)) << tool << " " << args << ": " << r.err;
  EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(ToolArguments, EveryToolRefusesTheSameMistakesTheSameWay) {
  const std::string demo = test::SourceDir() + "/configs/demo.yaml";
#ifdef DFO_RUN_EXE
  // Two configuration files: the first would be dropped without a word.
  ExpectUsageError(DFO_RUN_EXE, "dfo_run", "--config " + demo + " --config " + demo,
                   "--config given twice");
  ExpectUsageError(DFO_RUN_EXE, "dfo_run", "--output a --output=b", "--output given twice");
#endif
#ifdef DFO_TRAIN_EXE
  ExpectUsageError(DFO_TRAIN_EXE, "dfo_train", "--config a --config b", "--config given twice");
#endif
#ifdef DFO_EXAMPLE_EXE
  const std::string dir = test::MakeTempDir("args_example");
  ExpectUsageError(DFO_EXAMPLE_EXE, "dfo_example", dir + " 247.9x 240 100 50",
                   "FX: '247.9x' is not a (finite) number");
  ExpectUsageError(DFO_EXAMPLE_EXE, "dfo_example", dir + " abc 240 100 50",
                   "FX: 'abc' is not a (finite) number");
  ExpectUsageError(DFO_EXAMPLE_EXE, "dfo_example", dir + " -247.9 240 100 50",
                   "FX: -247.9 is not a focal length (> 0)");
  ExpectUsageError(DFO_EXAMPLE_EXE, "dfo_example", dir + " 247.9 240 100", "CY is missing");
#endif
#ifdef DFO_SYNTH_EXE
  ExpectUsageError(DFO_SYNTH_EXE, "dfo_synth", "--output o --frames 10x",
                   "--frames: '10x' is not an integer");
#endif
#ifdef DFO_LCM_LISTEN_EXE
  ExpectUsageError(DFO_LCM_LISTEN_EXE, "dfo_lcm_listen", "--timeout 1s",
                   "--timeout: '1s' is not a (finite) number");
#endif
#ifdef DFO_BENCH_EXE
  ExpectUsageError(DFO_BENCH_EXE, "dfo_bench", "--frames 5 --frames 6", "--frames given twice");
#endif
#ifdef DFO_SWEEP_EXE
  ExpectUsageError(DFO_SWEEP_EXE, "dfo_sweep", "a.yaml b.yaml",
                   "unexpected argument 'b.yaml' after SWEEP_FILE");
#endif
#ifdef DFO_EVAL_EXE
  ExpectUsageError(DFO_EVAL_EXE, "dfo_eval traj", "traj --gt a --gt b", "--gt given twice");
#endif
}

}  // namespace
}  // namespace dfo::apps
