// tools/eval_model.py (models/README.md, "Measure"): the held-out figures of a model file from one
// command. Here on the committed default model with short synthetic sequences and no real sets:
// the figures it writes are those of the commands it runs, and a missing model is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "tests/support/test_support.h"

namespace dfo {
namespace {

#if defined(DFO_TRAIN_EXE) && defined(DFO_RUN_EXE) && defined(DFO_SYNTH_EXE) && defined(DFO_EVAL_EXE)

// The number after the first "key": that follows "after" (the whole text when `after` is empty).
double JsonNumber(const std::string& text, const std::string& after, const std::string& key) {
  const size_t from = after.empty() ? 0 : text.find("\"" + after + "\"");
  if (from == std::string::npos) return NAN;
  const size_t at = text.find("\"" + key + "\":", from);
  if (at == std::string::npos) return NAN;
  return std::strtod(text.c_str() + at + key.size() + 3, nullptr);
}

TEST(EvalModelTool, MeasuresAModelFileOnTheSyntheticSets) {
  const std::string dir = test::MakeTempDir("eval_model");
  const std::string exe = DFO_RUN_EXE;
  const std::string build = exe.substr(0, exe.rfind("/apps/"));
  const std::string script = test::SourceDir() + "/tools/eval_model.py";
  const test::CommandResult r = test::RunCommand(
      "/usr/bin/python3", script + " --model " + test::SourceDir() + "/models/default.dfo" +
                              " --output " + dir + "/out --build " + build +
                              " --skip-real --synthetic-frames 12 --demo-frames 30");
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("real sets skipped (--skip-real)"), std::string::npos) << r.out;
  std::ifstream in(dir + "/out/figures.json");
  ASSERT_TRUE(in.good());
  std::stringstream text;
  text << in.rdbuf();
  const double abs_rel = JsonNumber(text.str(), "synthetic", "abs_rel");
  const double cv = JsonNumber(text.str(), "synthetic", "median_scale_cv");
  const double windowed = JsonNumber(text.str(), "demo_learned", "windowed_ate_rmse");
  EXPECT_GT(abs_rel, 0.0);
  EXPECT_LT(abs_rel, 1.0);
  EXPECT_GT(cv, 0.0);
  EXPECT_LT(cv, 1.0);
  EXPECT_TRUE(std::isfinite(windowed) && windowed > 0.0) << text.str();
  // The figure is the one dfo_eval gives on the depth the tool wrote.
  const test::CommandResult e = test::RunCommand(
      DFO_EVAL_EXE, "depth --gt " + dir + "/out/synthetic/sequences/01/depth_0 --pred " + dir +
                        "/out/synthetic_depth --median-scaling --json");
  ASSERT_EQ(e.status, 0) << e.err;
  EXPECT_NEAR(JsonNumber(e.out, "", "abs_rel"), abs_rel, 1e-9) << e.out;

  const test::CommandResult bad = test::RunCommand(
      "/usr/bin/python3", script + " --model " + dir + "/missing.dfo --output " + dir + "/bad");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find("missing.dfo does not exist"), std::string::npos) << bad.err;
}

#else
TEST(EvalModelTool, MeasuresAModelFileOnTheSyntheticSets) {
  GTEST_SKIP() << "dfo_train is not built (no LibTorch): tools/eval_model.py needs it";
}
#endif

}  // namespace
}  // namespace dfo
