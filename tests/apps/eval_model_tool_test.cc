// tools/eval_model.py (models/README.md, "Measure"): the held-out figures of a model file from one
// command. Here on the committed default model with short synthetic sequences and no real sets:
// the figures it writes are those of the commands it runs, and a missing model is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "dfo_io/file_reader.h"
#include "dfo_io/json.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

#if defined(DFO_TRAIN_EXE) && defined(DFO_RUN_EXE) && defined(DFO_SYNTH_EXE) && \
    defined(DFO_EVAL_EXE)

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
  const io::JsonValue figures =
      io::ParseJson(io::ReadWholeFile(dir + "/out/figures.json", "figures.json", 1u << 20),
                    "figures.json");
  const double abs_rel = figures["synthetic"]["abs_rel"].AsNumber();
  const double cv = figures["synthetic"]["median_scale_cv"].AsNumber();
  const double windowed = figures["demo_learned"]["windowed_ate_rmse"].AsNumber();
  EXPECT_GT(abs_rel, 0.0);
  EXPECT_LT(abs_rel, 1.0);
  EXPECT_GT(cv, 0.0);
  EXPECT_LT(cv, 1.0);
  EXPECT_TRUE(std::isfinite(windowed) && windowed > 0.0);
  // The figure is the one dfo_eval gives on the depth the tool wrote.
  const test::CommandResult e = test::RunCommand(
      DFO_EVAL_EXE, "depth --gt " + dir + "/out/synthetic/sequences/01/depth_0 --pred " + dir +
                        "/out/synthetic_depth --median-scaling --json");
  ASSERT_EQ(e.status, 0) << e.err;
  EXPECT_NEAR(io::ParseJson(e.out, "dfo_eval stdout")["abs_rel"].AsNumber(), abs_rel, 1e-9)
      << e.out;

  const test::CommandResult bad = test::RunCommand(
      "/usr/bin/python3", script + " --model " + dir + "/missing.dfo --output " + dir + "/bad");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find("missing.dfo does not exist"), std::string::npos) << bad.err;
  // --trained-on names the real sequences whose figures are not held out: only measured ones.
  const test::CommandResult trained = test::RunCommand(
      "/usr/bin/python3", script + " --model " + test::SourceDir() + "/models/default.dfo" +
                              " --output " + dir + "/bad2 --trained-on 03,05");
  EXPECT_NE(trained.status, 0);
  EXPECT_NE(trained.err.find("05 is not one of the measured sequences 00, 03, 06"),
            std::string::npos)
      << trained.err;
}

#else
TEST(EvalModelTool, MeasuresAModelFileOnTheSyntheticSets) {
  GTEST_SKIP() << "dfo_train is not built (no LibTorch): tools/eval_model.py needs it";
}
#endif

}  // namespace
}  // namespace dfo
