// dfo_run with the learned sources (apps/learned_wiring.h): the real executable (DFO_RUN_EXE) on a
// tiny synthetic sequence written by dfo_synth (DFO_SYNTH_EXE), with an untrained model of the
// sequence's size written by `dfo_bench --write-untrained-model` (DFO_BENCH_EXE). An untrained
// model tracks badly; these tests check the wiring (every mix of sources runs to the end and
// writes one pose per frame, datasets without depth maps run with learned depth) and the errors,
// not accuracy.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/support/test_support.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;

// Small frames keep the CPU network runs short: 128 x 64 (divisible by 2^3 for 4 levels).
constexpr int kFrames = 5;
constexpr int kWidth = 128;
constexpr int kHeight = 64;

using test::CommandResult;
using test::RunCommand;

// Pose lines of a trajectory file (comment lines skipped).
size_t CountLines(const std::string& path) {
  std::ifstream file(path);
  size_t n = 0;
  std::string line;
  while (std::getline(file, line)) n += line.empty() || line[0] == '#' ? 0 : 1;
  return n;
}

// Exactly one line on stderr containing every fragment, exit status 1.
void ExpectOneLineError(const CommandResult& r, const std::vector<std::string>& fragments) {
  EXPECT_EQ(r.status, 1) << r.err;
  ASSERT_FALSE(r.err.empty()) << "stdout: " << r.out;
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "more than one line: " << r.err;
  for (const std::string& f : fragments) {
    EXPECT_NE(r.err.find(f), std::string::npos) << r.err << "\n  missing: " << f;
  }
}

class DfoRunLearned : public ::testing::Test {
 protected:
  // One sequence with depth maps, a copy without (KITTI-like), and one model, per test process.
  static void SetUpTestSuite() {
    base_ = new std::string(test::MakeTempDir("dfo_run_learned"));
    const std::string size =
        " --width " + std::to_string(kWidth) + " --height " + std::to_string(kHeight);
    const CommandResult synth =
        RunCommand(DFO_SYNTH_EXE, "--output " + *base_ + "/with_depth --frames " +
                                      std::to_string(kFrames) + " --seed 1 --threads 2" + size);
    if (synth.status != 0) throw std::runtime_error("dfo_synth failed: " + synth.err);
    fs::copy(*base_ + "/with_depth", *base_ + "/no_depth", fs::copy_options::recursive);
    fs::remove_all(*base_ + "/no_depth/sequences/00/depth_0");
    const CommandResult model =
        RunCommand(DFO_BENCH_EXE, "--write-untrained-model " + ModelPath() + " --model-size " +
                                      std::to_string(kWidth) + "x" + std::to_string(kHeight));
    if (model.status != 0) throw std::runtime_error("dfo_bench failed: " + model.err);
  }
  static void TearDownTestSuite() {
    delete base_;
    base_ = nullptr;
  }
  static std::string ModelPath() { return *base_ + "/untrained.dfo"; }

  // dfo_run on `sequence` ("with_depth" or "no_depth") with the given extra --set flags.
  static CommandResult Run(const std::string& sequence, const std::string& out,
                           const std::string& sets) {
    return RunCommand(
        DFO_RUN_EXE,
        "--set dataset.path=" + *base_ + "/" + sequence +
            " --set dataset.sequence=00 --set dataset.image_width=" + std::to_string(kWidth) +
            " --set dataset.image_height=" + std::to_string(kHeight) +
            " --set learned.model=" + ModelPath() +
            " --set run.progress=none --set run.plot=false --output " + out + " " + sets);
  }

  static std::string* base_;
};
std::string* DfoRunLearned::base_ = nullptr;

// Every mix of learned and classic sources runs to the end, frontend-only and windowed, with one
// pose per frame; learned depth needs no depth maps in the dataset.
TEST_F(DfoRunLearned, EveryMixOfSourcesWritesOnePosePerFrame) {
  struct Case {
    const char* sequence;
    const char* sets;
  };
  const std::vector<Case> cases = {
      {"with_depth", "--set frontend.features=learned --set frontend.depth=gt"},
      {"no_depth", "--set frontend.features=handmade --set frontend.depth=learned"},
      {"no_depth", "--set frontend.features=learned --set frontend.depth=learned"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(std::string(c.sequence) + " " + c.sets);
    const std::string out = test::MakeTempDir("dfo_run_learned_out");
    const CommandResult r = Run(c.sequence, out, c.sets);
    ASSERT_EQ(r.status, 0) << r.err << "\n" << r.out;
    EXPECT_NE(r.out.find("model " + ModelPath()), std::string::npos) << r.out;
    EXPECT_EQ(CountLines(out + "/frontend_kitti.txt"), static_cast<size_t>(kFrames));
    EXPECT_EQ(CountLines(out + "/windowed_kitti.txt"), static_cast<size_t>(kFrames));
    EXPECT_EQ(CountLines(out + "/frontend_tum.txt"), static_cast<size_t>(kFrames));
  }
}

TEST_F(DfoRunLearned, MissingModelIsOneClearLine) {
  const std::string out = test::MakeTempDir("dfo_run_learned_missing");
  const std::string missing = *base_ + "/nowhere/model.dfo";
  const CommandResult r =
      Run("no_depth", out, "--set frontend.depth=learned --set learned.model=" + missing);
  ExpectOneLineError(
      r, {"model file " + missing, "not found", "learned.model", "frontend.depth = learned"});
  // A file that is not a model.
  const std::string junk = *base_ + "/junk.dfo";
  std::ofstream(junk) << "not a model\n";
  ExpectOneLineError(
      Run("with_depth", out, "--set frontend.features=learned --set learned.model=" + junk),
      {junk, "learned.model", "frontend.features = learned"});
}

// A dataset size other than the model's input size is refused up front, naming both sizes and the
// way out; with learned.require_input_size = false any size the levels divide runs.
TEST_F(DfoRunLearned, InputSizeMismatch) {
  const std::string out = test::MakeTempDir("dfo_run_learned_size");
  const std::string sets =
      "--set frontend.depth=learned --set dataset.image_width=256 --set run.mode=frontend";
  ExpectOneLineError(Run("no_depth", out, sets),
                     {"256x64", "128x64", "learned.require_input_size = false"});
  const CommandResult r = Run("no_depth", out, sets + " --set learned.require_input_size=false");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(CountLines(out + "/frontend_kitti.txt"), static_cast<size_t>(kFrames));
}

// A size no tracker level and no network can take (130 x 64: sides not divisible by 8) stops the
// run at start-up, naming the keys, not at the first frame; dataset.processing_width keeps the
// frames' aspect ratio, rounds to the pyramid's multiple and runs the depth network at the
// model's own size, and config_effective.yaml says so.
TEST_F(DfoRunLearned, ProcessingWidthKeepsTheAspectRatioAndOddSizesStopAtStartUp) {
  const std::string out = test::MakeTempDir("dfo_run_learned_processing");
  const std::string sets = "--set frontend.depth=learned --set run.mode=frontend";
  const CommandResult odd = Run("no_depth", out,
                                sets + " --set dataset.image_width=130 --set "
                                       "learned.require_input_size=false");
  ExpectOneLineError(odd, {"130x64", "divisible by 8", "dataset.processing_width",
                           "learned.depth_at_model_size = false"});
  EXPECT_FALSE(fs::exists(out + "/frames.csv"));
  // With the depth network at the model's size the frame itself needs no multiple of 8.
  const CommandResult at_model = Run("no_depth", out,
                                     sets + " --set dataset.image_width=130 --set "
                                            "learned.require_input_size=false --set "
                                            "learned.depth_at_model_size=true");
  ASSERT_EQ(at_model.status, 0) << at_model.err;
  EXPECT_EQ(CountLines(out + "/frontend_kitti.txt"), static_cast<size_t>(kFrames));
  // 128 x 64 frames at width 200: the height 100 rounds to the multiple of 8 above it (half-way
  // cases round away from zero), 200 x 104.
  const CommandResult processed =
      Run("no_depth", out, sets + " --set dataset.processing_width=200");
  ASSERT_EQ(processed.status, 0) << processed.err;
  const std::string effective = test::ReadFile(out + "/config_effective.yaml");
  EXPECT_NE(effective.find("image_width: 200"), std::string::npos) << effective;
  EXPECT_NE(effective.find("image_height: 104"), std::string::npos) << effective;
  EXPECT_NE(effective.find("depth_at_model_size: true"), std::string::npos) << effective;
  EXPECT_NE(effective.find("# from dataset.processing_width = 200"), std::string::npos)
      << effective;
  EXPECT_EQ(CountLines(out + "/frontend_kitti.txt"), static_cast<size_t>(kFrames));
}

// The model file is read only when a source is learned: the classic sources run without one.
TEST_F(DfoRunLearned, ClassicSourcesNeverReadTheModel) {
  const std::string out = test::MakeTempDir("dfo_run_learned_classic");
  const CommandResult r =
      Run("with_depth", out,
          "--set run.mode=frontend --set learned.model=" + *base_ + "/nowhere/model.dfo");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.out.find("(dfo, "), std::string::npos) << r.out;  // no model description line
  EXPECT_EQ(CountLines(out + "/frontend_kitti.txt"), static_cast<size_t>(kFrames));
}

}  // namespace
}  // namespace dfo
