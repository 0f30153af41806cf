// Runs the real dfo_bench_backend (DFO_BENCH_BACKEND_EXE) on frames given as a KITTI layout
// (--kitti, --depth-dir): synthetic frames written by dfo_synth (DFO_SYNTH_EXE) with their true
// depth, so that the window, started at the true poses, must stay near them. Checks the error
// messages of the real-frame options. Nothing is asserted about time.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <string>

#include "tests/support/test_support.h"

namespace dfo {
namespace {

using test::CommandResult;

// The number after `label` in `text`; NaN when absent.
double NumberAfter(const std::string& text, const std::string& label) {
  const size_t at = text.find(label);
  if (at == std::string::npos) return std::nan("");
  return std::strtod(text.c_str() + at + label.size(), nullptr);
}

// 16 synthetic frames in the KITTI layout, written once for the whole suite.
const std::string& SyntheticRoot() {
  static const std::string root = [] {
    const std::string dir = test::MakeTempDir("dfo_bench_backend_app");
    const CommandResult r = test::RunCommand(
        DFO_SYNTH_EXE, "--output " + dir + " --sequence 00 --seed 2 --frames 16 --threads 2");
    EXPECT_EQ(r.status, 0) << r.err;
    return dir;
  }();
  return root;
}

std::string RealFrameArgs() {
  return "--kitti " + SyntheticRoot() + " --sequence 00 --depth-dir " + SyntheticRoot() +
         "/sequences/00/depth_0 --keyframes 8 --step 2 --window 5 --points 80 --threads 1 "
         "--perturbation 0 --time-limit 100 --depth-search 1";
}

TEST(DfoBenchBackendAppTest, WindowOnFramesGivenAsKittiStaysNearTheTruth) {
  for (const std::string extra : {"", " --follow-window"}) {
    const CommandResult r = test::RunCommand(DFO_BENCH_BACKEND_EXE, RealFrameArgs() + extra);
    ASSERT_EQ(r.status, 0) << extra << "\n" << r.out << r.err;
    EXPECT_NE(
        r.out.find("preparing 8 keyframes (every 2 frames of KITTI 00 frames 0-14, 416 x 128"),
        std::string::npos)
        << r.out;
    // True poses, true depth, 14 frames (about 16 m): the keyframes' trajectory stays within
    // centimetres of the truth.
    const double ate = NumberAfter(r.out, "Sim3 ATE ");
    EXPECT_LT(ate, 0.05) << extra << "\n" << r.out;
    EXPECT_GE(ate, 0.0) << r.out;
  }
}

TEST(DfoBenchBackendAppTest, RealFrameOptionsAreChecked) {
  const CommandResult no_depth =
      test::RunCommand(DFO_BENCH_BACKEND_EXE, "--kitti " + SyntheticRoot() + " --keyframes 4");
  EXPECT_NE(no_depth.status, 0);
  EXPECT_NE(no_depth.err.find("--depth-dir"), std::string::npos) << no_depth.err;

  const CommandResult missing = test::RunCommand(
      DFO_BENCH_BACKEND_EXE,
      "--kitti " + SyntheticRoot() + " --keyframes 4 --depth-dir " + SyntheticRoot() + "/nowhere");
  EXPECT_NE(missing.status, 0);
  EXPECT_NE(missing.err.find("nowhere"), std::string::npos) << missing.err;
}

}  // namespace
}  // namespace dfo
