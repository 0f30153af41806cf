// dfo_sweep end to end with the real dfo_run on a short synthetic sequence: a local sweep writes
// its result files, records a failing run and goes on; a restart skips finished runs; --collect
// reports missing runs; --slurm --no-submit writes the job array; bad sweep files and flags are
// one clear line. And through a real Slurm: a single-node cluster on localhost
// (tools/local_slurm.sh: munged with its own key, slurmctld, slurmd, a slurm.conf generated for
// this host) runs a 2-run sweep as a job array; --collect --wait gathers the results. That test is
// skipped, saying which, only when Slurm cannot run here (not root, slurm-wlm or munge not
// installed); a cluster that does not come up although they are installed fails it.
#include <unistd.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "apps/common/sweep_exec.h"
#include "dfo_io/sweep_spec.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;

std::string Read(const std::string& path) {
  std::ifstream file(path);
  std::stringstream buffer;
  buffer << file.rdbuf();
  return buffer.str();
}

int CountLines(const std::string& text, const std::string& needle) {
  int n = 0;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) n += line.find(needle) != std::string::npos;
  return n;
}

class DfoSweepTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new std::string(test::MakeTempDir("sweep_data") + "/synthetic");
    const test::CommandResult r =
        test::RunCommand(DFO_SYNTH_EXE, "--output " + *data_ + " --seed 1 --frames 20");
    ASSERT_EQ(r.status, 0) << r.err;
  }
  static void TearDownTestSuite() {
    delete data_;
    data_ = nullptr;
  }

  // A sweep of two settings on the synthetic sequence and, with `broken`, on a sequence whose
  // folder does not exist (dfo_run fails there). Frontend only, so each run takes a moment.
  std::string WriteSweep(const std::string& dir, bool broken, const std::string& extra = "") {
    std::ostringstream s;
    s << "base_config: " << test::SourceDir() << "/configs/demo.yaml\n"
      << "output: " << dir << "/out\n"
      << "sequences:\n"
      << "  - name: synthetic\n"
      << "    set: {dataset.path: " << *data_ << "}\n";
    if (broken) s << "  - name: broken\n    set: {dataset.path: " << dir << "/nothing}\n";
    s << "grid:\n  keyframe.translation_ratio: [0.05, 0.15]\n"
      << "set: {run.mode: frontend, run.plot: false, run.threads: 1}\n"
      << "parallel: 2\n"
      << extra;
    const std::string path = dir + "/sweep.yaml";
    std::ofstream(path) << s.str();
    return path;
  }

  static std::string* data_;
};

std::string* DfoSweepTest::data_ = nullptr;

TEST_F(DfoSweepTest, LocalSweepRecordsFailuresWritesResultsAndRestartSkipsFinishedRuns) {
  const std::string dir = test::MakeTempDir("sweep_local");
  const std::string sweep = WriteSweep(dir, /*broken=*/true);
  const std::string args = "--dfo-run " + std::string(DFO_RUN_EXE) + " " + sweep;
  test::CommandResult r = test::RunCommand(DFO_SWEEP_EXE, args);
  // Two runs fail; the sweep goes on and ends with status 1.
  EXPECT_EQ(r.status, 1) << r.out << r.err;
  EXPECT_NE(r.out.find("4 runs (2 settings x 2 sequences): 0 already finished, 4 to run"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(CountLines(r.out, "] ok "), 2) << r.out;
  EXPECT_EQ(CountLines(r.out, "] FAILED broken / "), 2) << r.out;
  EXPECT_NE(r.out.find("ETA"), std::string::npos);
  EXPECT_NE(r.out.find("runs:        2 ok, 2 failed, 0 missing of 4"), std::string::npos);

  // The failed run's record: exit status and stderr tail.
  const std::string failed_dir = dir + "/out/runs/broken/translation_ratio=0.05";
  apps::SweepRunRecord record;
  ASSERT_TRUE(apps::ReadRunRecord(failed_dir, &record));
  EXPECT_EQ(record.status, "failed");
  EXPECT_EQ(record.exit_status, 1);
  EXPECT_NE(record.stderr_tail.find("not found"), std::string::npos) << record.stderr_tail;
  EXPECT_NE(record.error.find("dfo_run exited with status 1: dfo_run: error:"),
            std::string::npos)
      << record.error;

  // Result files.
  const std::string csv = Read(dir + "/out/results.csv");
  EXPECT_EQ(CountLines(csv, ",ok,"), 2) << csv;
  EXPECT_EQ(CountLines(csv, ",failed,"), 2) << csv;
  EXPECT_NE(csv.find("keyframe.translation_ratio"), std::string::npos);
  const std::string md = Read(dir + "/out/results.md");
  EXPECT_NE(md.find("| #1 | translation_ratio=0.05 | synthetic | ok |"), std::string::npos) << md;
  EXPECT_NE(md.find("**Best setting per sequence**"), std::string::npos);
  EXPECT_NE(md.find("- broken: no successful run"), std::string::npos);
  EXPECT_NE(md.find("**Overall**"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir + "/out/pareto.png"));
  const std::string ok_summary = dir + "/out/runs/synthetic/translation_ratio=0.05/summary.json";
  ASSERT_TRUE(fs::exists(ok_summary));
  const auto written = fs::last_write_time(ok_summary);

  // Restart: the finished runs are not redone, the failed ones are tried again.
  r = test::RunCommand(DFO_SWEEP_EXE, args);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("2 already finished, 2 to run"), std::string::npos) << r.out;
  EXPECT_EQ(fs::last_write_time(ok_summary), written);

  // A finished run whose summary went missing is run again; --list shows which.
  fs::remove(ok_summary);
  r = test::RunCommand(DFO_SWEEP_EXE, "--list " + sweep);
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(CountLines(r.out, "\tfinished\t"), 1) << r.out;
  r = test::RunCommand(DFO_SWEEP_EXE, args);
  EXPECT_NE(r.out.find("1 already finished, 3 to run"), std::string::npos) << r.out;
  EXPECT_TRUE(fs::exists(ok_summary));
}

TEST_F(DfoSweepTest, RunIndexRunsOneRunAndCollectReportsTheMissingOnes) {
  const std::string dir = test::MakeTempDir("sweep_collect");
  const std::string sweep = WriteSweep(dir, /*broken=*/false);
  test::CommandResult r = test::RunCommand(DFO_SWEEP_EXE, "--collect " + sweep);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("0 ok, 0 failed, 2 missing of 2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no plot:"), std::string::npos);

  r = test::RunCommand(DFO_SWEEP_EXE, "--run-index 1 --dfo-run " + std::string(DFO_RUN_EXE) +
                                          " " + sweep);
  EXPECT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("run 1 (synthetic / translation_ratio=0.15)"), std::string::npos) << r.out;
  r = test::RunCommand(DFO_SWEEP_EXE, "--run-index 1 --dfo-run " + std::string(DFO_RUN_EXE) +
                                          " " + sweep);
  EXPECT_NE(r.out.find("is already finished"), std::string::npos) << r.out;

  r = test::RunCommand(DFO_SWEEP_EXE, "--collect " + sweep);
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.out.find("1 ok, 0 failed, 1 missing of 2"), std::string::npos) << r.out;
  const std::string md = Read(dir + "/out/results.md");
  EXPECT_NE(md.find("- synthetic / translation_ratio=0.05: missing (not run yet)"),
            std::string::npos)
      << md;
  EXPECT_TRUE(fs::exists(dir + "/out/pareto.png"));

  r = test::RunCommand(DFO_SWEEP_EXE, "--run-index 2 " + sweep);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("--run-index 2 is out of range"), std::string::npos) << r.err;
}

TEST_F(DfoSweepTest, SlurmNoSubmitWritesTheJobArray) {
  const std::string dir = test::MakeTempDir("sweep_slurm_script");
  const std::string sweep = WriteSweep(
      dir, /*broken=*/false,
      "slurm: {partition: short, time: \"00:05:00\", mem: 1G, max_parallel: 1,"
      " extra: [--qos=low]}\n");
  const test::CommandResult r = test::RunCommand(
      DFO_SWEEP_EXE, "--slurm --no-submit --dfo-run " + std::string(DFO_RUN_EXE) + " " + sweep);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  const std::string script = Read(dir + "/out/slurm/sweep.sbatch");
  for (const char* line :
       {"#SBATCH --array=0-1%1\n", "#SBATCH --cpus-per-task=1\n", "#SBATCH --partition=short\n",
        "#SBATCH --time=00:05:00\n", "#SBATCH --mem=1G\n", "#SBATCH --qos=low\n",
        "--run-index \"$SLURM_ARRAY_TASK_ID\" --dfo-run"}) {
    EXPECT_NE(script.find(line), std::string::npos) << line << " not in\n" << script;
  }
  EXPECT_EQ(apps::ArrayRanges({0, 1, 2, 3, 5, 7, 8, 9}), "0-3,5,7-9");
  EXPECT_EQ(apps::ArrayRanges({4}), "4");
}

TEST_F(DfoSweepTest, BadSweepFilesAndFlagsAreOneClearLine) {
  const std::string dir = test::MakeTempDir("sweep_bad");
  const std::string sweep =
      WriteSweep(dir, /*broken=*/false, "list:\n  - {window.max_keyframe: 5}\n");
  test::CommandResult r = test::RunCommand(DFO_SWEEP_EXE, sweep);
  EXPECT_EQ(r.status, 1);
  EXPECT_EQ(r.err, "dfo_sweep: error: " + sweep +
                       ":11: unknown dfo_run key 'window.max_keyframe' (did you mean "
                       "'window.max_keyframes'?)\n");
  EXPECT_FALSE(fs::exists(dir + "/out"));  // nothing ran
  r = test::RunCommand(DFO_SWEEP_EXE, "--bogus " + sweep);
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("unknown argument '--bogus'"), std::string::npos);
  r = test::RunCommand(DFO_SWEEP_EXE, "");
  EXPECT_EQ(r.status, 2);
  EXPECT_NE(r.err.find("no sweep file given"), std::string::npos);
  r = test::RunCommand(DFO_SWEEP_EXE, "--slurm --collect " + sweep);
  EXPECT_EQ(r.status, 2);
  r = test::RunCommand(DFO_SWEEP_EXE, "--dfo-run /nonexistent/dfo_run " + WriteSweep(dir, false));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("dfo_run not found or not executable: /nonexistent/dfo_run"),
            std::string::npos)
      << r.err;
  r = test::RunCommand(DFO_SWEEP_EXE, "--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("usage: dfo_sweep"), std::string::npos);
}

std::string LastLine(const std::string& text) {
  std::string t = text;
  while (!t.empty() && t.back() == '\n') t.pop_back();
  const size_t nl = t.find_last_of('\n');
  return nl == std::string::npos ? t : t.substr(nl + 1);
}

// Starts the local cluster; stops it when destroyed, whatever the test did.
class LocalSlurm {
 public:
  explicit LocalSlurm(std::string dir) : dir_(std::move(dir)) {}
  ~LocalSlurm() {
    if (started_) test::RunCommand(Script(), "stop " + dir_);
  }
  // Whether a local Slurm can run here at all: 0 yes; 3 not root or slurm-wlm / munge not
  // installed (the last line of `output` says which); other: the script is broken.
  static int Check(std::string* output) {
    const test::CommandResult r = test::RunCommand(Script(), "check");
    *output = r.out + r.err;
    return r.status;
  }
  // 0 running; else it did not come up and `output` holds the log tails and the reason.
  int Start(std::string* output) {
    const test::CommandResult r = test::RunCommand(Script(), "start " + dir_);
    started_ = true;  // stop even after a half start
    *output = r.out + r.err;
    return r.status;
  }
  std::string conf() const { return dir_ + "/slurm.conf"; }

 private:
  static std::string Script() { return test::SourceDir() + "/tools/local_slurm.sh"; }
  std::string dir_;
  bool started_ = false;
};

TEST(DfoSweepSlurm, JobArrayOnALocalClusterThenCollect) {
  // Skipped only where Slurm cannot run: not root, or slurm-wlm or munge not installed. Where
  // they are installed and this is root, a cluster that does not come up fails the test.
  if (geteuid() != 0) GTEST_SKIP() << "Slurm test skipped: not root (slurmd must run as root)";
  std::string said;
  const int can_run = LocalSlurm::Check(&said);
  if (can_run == 3) GTEST_SKIP() << "Slurm test skipped: " << LastLine(said);
  ASSERT_EQ(can_run, 0) << "tools/local_slurm.sh check:\n" << said;
  const std::string dir = test::MakeTempDir("sweep_slurm");
  LocalSlurm slurm(dir + "/cluster");
  const int status = slurm.Start(&said);
  ASSERT_EQ(status, 0) << "slurm-wlm and munge are installed and this is root, but the local "
                          "cluster did not start (tools/local_slurm.sh start, status "
                       << status << "):\n"
                       << said;
  // From here on Slurm runs: failures are failures.
  const std::string data = dir + "/synthetic";
  test::CommandResult r =
      test::RunCommand(DFO_SYNTH_EXE, "--output " + data + " --seed 1 --frames 30");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string sweep = dir + "/sweep.yaml";
  std::ofstream(sweep) << "base_config: " << test::SourceDir() << "/configs/demo.yaml\n"
                       << "output: " << dir << "/out\n"
                       << "sequences:\n  - name: synthetic\n    set: {dataset.path: " << data
                       << "}\n"
                       << "grid:\n  keyframe.translation_ratio: [0.05, 0.15]\n"
                       << "set: {run.plot: false, run.threads: 1}\n"
                       << "slurm: {partition: dfo, time: \"00:10:00\", cpus_per_task: 1, "
                          "mem: 500M}\n";
  const std::string env = "SLURM_CONF=" + slurm.conf() + " ";
  r = test::RunCommand(env + DFO_SWEEP_EXE,
                       "--slurm --dfo-run " + std::string(DFO_RUN_EXE) + " " + sweep);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("2 array task(s) (0-1)"), std::string::npos) << r.out;
  r = test::RunCommand(env + DFO_SWEEP_EXE, "--collect --wait " + sweep);
  EXPECT_EQ(r.status, 0) << r.out << r.err << Read(dir + "/cluster/log/slurmd.log");
  EXPECT_NE(r.out.find("2 ok, 0 failed, 0 missing of 2"), std::string::npos) << r.out;
  const std::string csv = Read(dir + "/out/results.csv");
  EXPECT_NE(csv.find("synthetic,translation_ratio=0.05,0.05,ok,30,"), std::string::npos) << csv;
  EXPECT_NE(csv.find("synthetic,translation_ratio=0.15,0.15,ok,30,"), std::string::npos) << csv;
  EXPECT_TRUE(fs::exists(dir + "/out/pareto.png"));
  // Each array task left its log and ran its run through dfo_sweep --run-index.
  int logs = 0;
  for (const auto& entry : fs::directory_iterator(dir + "/out/slurm/logs")) {
    logs += Read(entry.path().string()).find(" ok after ") != std::string::npos;
  }
  EXPECT_EQ(logs, 2);
  // Submitting again finds nothing left to do.
  r = test::RunCommand(env + DFO_SWEEP_EXE,
                       "--slurm --dfo-run " + std::string(DFO_RUN_EXE) + " " + sweep);
  EXPECT_EQ(r.status, 0);
  EXPECT_NE(r.out.find("2 already finished, 0 to submit"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace dfo
