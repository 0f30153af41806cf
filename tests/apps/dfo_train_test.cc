// Runs the real dfo_train executable (DFO_TRAIN_EXE) with configs/train_tiny.yaml on a short
// sequence written by dfo_synth: a run stopped by SIGTERM leaves a checkpoint and resumes where it
// stopped (iteration counter and loss curve continue), files are written, --write-depth feeds
// `dfo_eval depth`, and command-line mistakes are named.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dfo_io/json.h"
#include "tests/support/measured_figures.h"
#include "tests/support/test_support.h"

#if defined(DFO_TRAIN_EXE) && defined(DFO_SYNTH_EXE) && defined(DFO_EVAL_EXE)

namespace dfo {
namespace {

namespace fs = std::filesystem;

struct CommandResult {
  int status = -1;
  std::string out;
};

// Runs a shell command line, stdout and stderr together.
CommandResult Shell(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  char buf[4096];
  size_t n = 0;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) result.out.append(buf, n);
  const int wait_status = pclose(pipe);
  result.status = WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : -1;
  return result;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

class DfoTrainAppTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new std::string(test::MakeTempDir("dfo_train_data"));
    const CommandResult r = Shell(std::string(DFO_SYNTH_EXE) + " --output " + *data_ +
                                  " --seed 9 --frames 8 --threads 1");
    ASSERT_EQ(r.status, 0) << r.out;
  }
  static void TearDownTestSuite() { delete data_; }
  static std::string Train(const std::string& args) {
    return std::string(DFO_TRAIN_EXE) + " --config " + test::SourceDir() +
           "/configs/train_tiny.yaml --set 'data.sequences=[" + *data_ + "/sequences/00]' " + args;
  }
  static std::string* data_;
};
std::string* DfoTrainAppTest::data_ = nullptr;

TEST_F(DfoTrainAppTest, SigtermLeavesACheckpointAndResumeContinuesTheCurve) {
  const std::string out = test::MakeTempDir("dfo_train_app");
  const std::string log = out + "/log.txt";
  // Start a long run, wait for iteration 3 in its log, stop it with SIGTERM.
  const std::string script = Train("--set train.iterations=100000 --output " + out + "/run") +
                             " > " + log + " 2>&1 & p=$!; i=0; while ! grep -q 'it 3/' " + log +
                             " && [ $i -lt 1200 ]; do sleep 0.1; i=$((i+1)); done; kill -TERM $p;"
                             " wait $p; echo rc=$?";
  const CommandResult stopped = Shell(script);  // popen runs it with sh -c
  ASSERT_NE(stopped.out.find("rc=0"), std::string::npos) << stopped.out;
  std::ifstream in(log);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  const size_t at = text.find("stopped at iteration ");
  ASSERT_NE(at, std::string::npos) << text;
  const int stopped_at = std::stoi(text.substr(at + 21));
  EXPECT_GE(stopped_at, 3);
  ASSERT_TRUE(fs::exists(out + "/run/checkpoint.pt"));
  ASSERT_FALSE(fs::exists(out + "/run/model.dfo"));  // stopped runs write no model
  EXPECT_EQ(static_cast<int>(ReadLines(out + "/run/losses.csv").size()), stopped_at + 1);
  const std::vector<std::string> before = ReadLines(out + "/run/losses.csv");

  // Without --resume the run refuses to overwrite it.
  const CommandResult refused =
      Shell(Train("--set train.iterations=100000 --output " + out + "/run"));
  EXPECT_EQ(refused.status, 2);
  EXPECT_NE(refused.out.find("pass --resume"), std::string::npos) << refused.out;

  // Resume to stopped_at + 3 iterations.
  const int target = stopped_at + 3;
  const CommandResult resumed = Shell(Train("--set train.iterations=" + std::to_string(target) +
                                            " --output " + out + "/run --resume"));
  ASSERT_EQ(resumed.status, 0) << resumed.out;
  EXPECT_NE(resumed.out.find("resuming at iteration " + std::to_string(stopped_at)),
            std::string::npos)
      << resumed.out;
  const std::vector<std::string> after = ReadLines(out + "/run/losses.csv");
  ASSERT_EQ(static_cast<int>(after.size()), target + 1);  // header + one row per iteration
  for (size_t i = 0; i < before.size(); ++i) EXPECT_EQ(after[i], before[i]) << "row " << i;
  EXPECT_EQ(after.back().substr(0, after.back().find(',')), std::to_string(target));
  EXPECT_TRUE(fs::exists(out + "/run/model.dfo"));
  EXPECT_TRUE(fs::exists(out + "/run/losses.png"));
  EXPECT_TRUE(fs::exists(out + "/run/config_effective.yaml"));

  // Depth PNGs for dfo_eval depth.
  const CommandResult depth = Shell(Train("--output " + out + "/run --write-depth " + out +
                                          "/depth --sequence " + *data_ + "/sequences/00"));
  ASSERT_EQ(depth.status, 0) << depth.out;
  const CommandResult eval =
      Shell(std::string(DFO_EVAL_EXE) + " depth --gt " + *data_ + "/sequences/00/depth_0 --pred " +
            out + "/depth --median-scaling --json");
  ASSERT_EQ(eval.status, 0) << eval.out;
  EXPECT_NE(eval.out.find("abs_rel"), std::string::npos) << eval.out;
  // A TUM RGB-D folder (with ../shared/data only): predictions at the images' aspect ratio, named
  // as the associated depth maps, so that dfo_eval pairs every ground-truth map.
  if (!test::SharedDataDir().empty()) {
    const std::string tum = test::SharedDataDir() + "/tum/fr3_cabinet_keyframes";
    const CommandResult written = Shell(
        Train("--output " + out + "/run --write-depth " + out + "/tum_depth --sequence " + tum));
    ASSERT_EQ(written.status, 0) << written.out;
    EXPECT_NE(written.out.find("wrote 58 depth maps"), std::string::npos) << written.out;
    const CommandResult tum_eval =
        Shell(std::string(DFO_EVAL_EXE) + " depth --gt " + tum + "/depth --gt-scale 5000 --pred " +
              out + "/tum_depth --median-scaling --json");
    ASSERT_EQ(tum_eval.status, 0) << tum_eval.out;
    EXPECT_NE(tum_eval.out.find("abs_rel"), std::string::npos) << tum_eval.out;
  }
  // Export from the checkpoint.
  const CommandResult exported =
      Shell(Train("--output " + out + "/run --export --model " + out + "/exported.dfo"));
  ASSERT_EQ(exported.status, 0) << exported.out;
  EXPECT_TRUE(fs::exists(out + "/exported.dfo"));
  // Depth from the model file alone: no checkpoint in the output folder, and a configuration of
  // other network shapes (the default's), so shapes and input size must come from the file. The
  // maps equal those of the checkpoint it was exported from.
  const CommandResult from_model =
      Shell(std::string(DFO_TRAIN_EXE) + " --config " + test::SourceDir() +
            "/configs/train_default.yaml --output " + out + "/no_checkpoint --write-depth " + out +
            "/model_depth --sequence " + *data_ + "/sequences/00 --model " + out + "/exported.dfo");
  ASSERT_EQ(from_model.status, 0) << from_model.out;
  EXPECT_NE(from_model.out.find("model " + out + "/exported.dfo"), std::string::npos)
      << from_model.out;
  EXPECT_FALSE(fs::exists(out + "/no_checkpoint/checkpoint.pt"));
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(out + "/depth")) {
    const std::string name = entry.path().filename().string();
    EXPECT_EQ(ReadBytes(entry.path().string()), ReadBytes(out + "/model_depth/" + name)) << name;
    ++compared;
  }
  EXPECT_GT(compared, 0);
  // A model file that is not one is named.
  const CommandResult bad_model = Shell(Train("--output " + out + "/no_checkpoint --write-depth " +
                                              out + "/bad_depth --sequence " + *data_ +
                                              "/sequences/00 --model " + out + "/run/losses.csv"));
  EXPECT_EQ(bad_model.status, 1) << bad_model.out;
  EXPECT_NE(bad_model.out.find(out + "/run/losses.csv"), std::string::npos) << bad_model.out;
}

// The shipped default model is loaded and its held-out depth checked against the measured
// figure (tests/support/measured_figures.h): a broken or worse model fails here.
TEST(DefaultModel, KeepsItsHeldOutDepthAccuracy) {
  const std::string dir = test::MakeTempDir("default_model_depth");
  CommandResult r = Shell(std::string(DFO_SYNTH_EXE) + " --output " + dir +
                          "/syn --sequence 01 --seed 1 --frames 20 --threads 1");
  ASSERT_EQ(r.status, 0) << r.out;
  r = Shell(std::string(DFO_TRAIN_EXE) + " --config " + test::SourceDir() +
            "/configs/train_default.yaml --output " + dir + "/none --write-depth " + dir +
            "/pred --sequence " + dir + "/syn/sequences/01 --model " + test::SourceDir() +
            "/models/default.dfo");
  ASSERT_EQ(r.status, 0) << r.out;
  r = Shell(std::string(DFO_EVAL_EXE) + " depth --gt " + dir + "/syn/sequences/01/depth_0 --pred " +
            dir + "/pred --median-scaling --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const double abs_rel = io::ParseJson(r.out)["abs_rel"].AsNumber();
  EXPECT_LE(abs_rel, test::kDefaultModelHeldOutAbsRelBound)
      << "measured " << test::kDefaultModelHeldOutAbsRel << " when the model was committed";
  EXPECT_GT(abs_rel, 0.5 * test::kDefaultModelHeldOutAbsRel)
      << "better than measured: update tests/support/measured_figures.h";
}

TEST_F(DfoTrainAppTest, CommandLineMistakesAreNamed) {
  const std::string out = test::MakeTempDir("dfo_train_cli");
  CommandResult r = Shell(std::string(DFO_TRAIN_EXE) + " --bogus");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("unknown argument '--bogus'"), std::string::npos) << r.out;
  r = Shell(Train(""));
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.out.find("--output"), std::string::npos) << r.out;
  r = Shell(Train("--set train.batch_sise=2 --output " + out));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("batch_size"), std::string::npos) << r.out;
  r = Shell(std::string(DFO_TRAIN_EXE) + " --config " + test::SourceDir() +
            "/configs/train_tiny.yaml --output " + out);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("data.sequences and data.teachers are empty"), std::string::npos) << r.out;
  r = Shell(Train("--output " + out + "/none --export"));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("no checkpoint"), std::string::npos) << r.out;
}

#ifdef DFO_RUN_EXE
// data.teachers: a keyframe depth folder written by dfo_run trains as a sequence of its keyframes
// with their settled depths as targets (the term shows as "te" on the progress lines and in
// losses.csv); a folder whose image is missing, or without a single target, is refused naming it.
TEST_F(DfoTrainAppTest, TrainsOnAKeyframeDepthFolderAndRefusesDamagedOnes) {
  const std::string out = test::MakeTempDir("dfo_train_teacher");
  const CommandResult run = Shell(std::string(DFO_RUN_EXE) + " --config " + test::SourceDir() +
                                  "/configs/demo.yaml --set dataset.path=" + *data_ +
                                  " --set run.progress=none --set run.plot=false --output " + out +
                                  "/run --set run.write_keyframe_depth=" + out + "/teacher");
  ASSERT_EQ(run.status, 0) << run.out;
  const std::string teach = std::string(DFO_TRAIN_EXE) + " --config " + test::SourceDir() +
                            "/configs/train_tiny.yaml --set 'data.sequences=[]' --set "
                            "data.teacher_min_observations=1 ";
  const CommandResult r =
      Shell(teach + "--set 'data.teachers=[" + out + "/teacher]' --output " + out + "/train");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find(" depth targets (at least 1 observations)"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(" te "), std::string::npos) << r.out;
  const std::vector<std::string> curve = ReadLines(out + "/train/losses.csv");
  ASSERT_GT(curve.size(), 2u);
  EXPECT_NE(curve[0].find(",teacher"), std::string::npos) << curve[0];

  // A keyframe whose image is gone.
  fs::copy(out + "/teacher", out + "/missing", fs::copy_options::recursive);
  std::string list = ReadBytes(out + "/missing/keyframes.txt");
  const size_t png = list.rfind(".png");
  ASSERT_NE(png, std::string::npos);
  list.replace(png, 4, "_gone.png");
  std::ofstream(out + "/missing/keyframes.txt") << list;
  const CommandResult missing =
      Shell(teach + "--set 'data.teachers=[" + out + "/missing]' --output " + out + "/train2");
  EXPECT_EQ(missing.status, 1) << missing.out;
  EXPECT_NE(missing.out.find(out + "/missing/keyframes.txt, frame "), std::string::npos)
      << missing.out;
  EXPECT_NE(missing.out.find("image file not found"), std::string::npos) << missing.out;
  // No point with enough observations.
  const CommandResult none =
      Shell(teach + "--set data.teacher_min_observations=1000 --set " + "'data.teachers=[" + out +
            "/teacher]' --output " + out + "/train3");
  EXPECT_EQ(none.status, 1) << none.out;
  EXPECT_NE(none.out.find("no point with at least 1000 observations"), std::string::npos)
      << none.out;
}
#endif

// The largest inputs the configuration accepts (4096 x 4096) in batches of 64 would need terabytes:
// refused before any data is read or file written, naming the estimate, the keys and the limit.
TEST_F(DfoTrainAppTest, InputsBeyondTheMemoryLimitAreRefusedUpFront) {
  const std::string out = test::MakeTempDir("dfo_train_memory");
  const CommandResult r = Shell(
      std::string(DFO_TRAIN_EXE) + " --config " + test::SourceDir() +
      "/configs/train_default.yaml --set 'data.sequences=[" + out +
      "/no_such_sequence]' --set network.input_width=4096 --set network.input_height=4096 --set " +
      "train.batch_size=64 --output " + out + "/run");
  EXPECT_EQ(r.status, 1) << r.out;
  for (const char* part :
       {"dfo_train: error: training would need about", "MiB", "4096 x 4096", "network.input_width",
        "train.batch_size", "train.memory_limit_mb = 4096 ("}) {
    EXPECT_NE(r.out.find(part), std::string::npos) << r.out;
  }
  EXPECT_FALSE(fs::exists(out + "/run"));
}

// train.device: a name other than cpu, cuda, cuda:N is a configuration error naming the key, and
// with Debian's CPU-only LibTorch `cuda` stops dfo_train at start-up with one line saying why,
// before any data is read or file written.
TEST_F(DfoTrainAppTest, DeviceErrorsStopAtStartUp) {
  const std::string out = test::MakeTempDir("dfo_train_device");
  for (const char* bad : {"gpu", "cuda:x"}) {
    const CommandResult r =
        Shell(Train("--set train.device=" + std::string(bad) + " --output " + out + "/bad"));
    EXPECT_EQ(r.status, 1) << r.out;
    EXPECT_NE(
        r.out.find("train.device = \"" + std::string(bad) + "\" violates one of cpu, cuda, cuda:N"),
        std::string::npos)
        << r.out;
  }
  EXPECT_FALSE(fs::exists(out + "/bad"));
  // The shipped default configuration; its data folders are replaced by one that does not exist,
  // so that only the device check can stop the run before the data (or, with CUDA, the data).
  const CommandResult r =
      Shell(std::string(DFO_TRAIN_EXE) + " --config " + test::SourceDir() +
            "/configs/train_default.yaml --set 'data.sequences=[" + out +
            "/no_such_sequence]' --output " + out + "/run --set train.device=cuda");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_FALSE(fs::exists(out + "/run"));
  if (r.out.find("no_such_sequence") != std::string::npos) {
    // A CUDA LibTorch with a device: the device was accepted and the missing data stopped it.
    EXPECT_EQ(r.out.find("train.device"), std::string::npos) << r.out;
    return;
  }
  EXPECT_EQ(r.out,
            "dfo_train: error: train.device = \"cuda\": this LibTorch has no usable CUDA device "
            "(Debian's libtorch is built for the CPU only; build dfo against a CUDA LibTorch, see "
            "README, or use cpu)\n");
}

}  // namespace
}  // namespace dfo

#endif
