// dfo_sweep through a real Slurm: a single-node cluster on localhost (tools/local_slurm.sh:
// munged with its own key, slurmctld, slurmd, a slurm.conf generated for this host) runs a
// 2-run sweep as a job array; --collect --wait gathers the results. Skipped with the reason when
// Slurm cannot run here (not root, slurm-wlm or munge not installed, a daemon that does not
// start).
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

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
  // 0 running; 3 cannot run here; other: did not come up. `output` gets what the script said.
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
  if (geteuid() != 0) GTEST_SKIP() << "Slurm test skipped: not root (slurmd must run as root)";
  const std::string dir = test::MakeTempDir("sweep_slurm");
  LocalSlurm slurm(dir + "/cluster");
  std::string said;
  const int status = slurm.Start(&said);
  if (status == 3) GTEST_SKIP() << "Slurm test skipped: " << LastLine(said);
  if (status != 0) {
    GTEST_SKIP() << "Slurm test skipped: the local cluster did not start (status " << status
                 << "):\n"
                 << said;
  }
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
