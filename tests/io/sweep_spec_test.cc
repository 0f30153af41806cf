// Sweep files: grid and list expansion into runs, override order and folders, and every error a
// sweep file can make naming the file, line and (for misspelt keys) a suggestion.
#include "dfo_io/sweep_spec.h"

#include <gtest/gtest.h>

#include <string>

#include "dfo_core/error.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

std::string ConfigsDir() { return test::SourceDir() + "/configs"; }

SweepSpec Load(const std::string& text) {
  return LoadSweepSpecFromString(text, "sweep.yaml", ConfigsDir());
}

// The message of the ConfigError that loading `text` throws ("" when none).
std::string ErrorOf(const std::string& text) {
  try {
    Load(text);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

const char* kTwoByTwo = R"(base_config: demo.yaml
output: out/sweep_test
sequences:
  - name: synthetic
    set: {dataset.path: out/synthetic}
  - name: other
    config: demo_learned.yaml
    set:
      dataset.path: out/other
      run.threads: 1
grid:
  keyframe.translation_ratio: [0.05, 0.1]
  window.max_keyframes: [5, 7]
list:
  - {keyframe.translation_ratio: 0.2, run.mode: frontend}
set:
  run.plot: false
)";

TEST(SweepSpec, GridTimesListTimesSequencesInOrder) {
  const SweepSpec spec = Load(kTwoByTwo);
  EXPECT_EQ(spec.base_config, ConfigsDir() + "/demo.yaml");
  ASSERT_EQ(spec.sequences.size(), 2u);
  EXPECT_EQ(spec.sequences[1].config, ConfigsDir() + "/demo_learned.yaml");
  ASSERT_EQ(spec.settings.size(), 5u);  // 2 x 2 grid + 1 listed
  const std::vector<std::string> keys = {"keyframe.translation_ratio", "window.max_keyframes",
                                         "run.mode"};
  EXPECT_EQ(spec.swept_keys, keys);
  // The last grid key varies fastest.
  EXPECT_EQ(spec.settings[0].label, "translation_ratio=0.05, max_keyframes=5");
  EXPECT_EQ(spec.settings[1].label, "translation_ratio=0.05, max_keyframes=7");
  EXPECT_EQ(spec.settings[2].label, "translation_ratio=0.1, max_keyframes=5");
  EXPECT_EQ(spec.settings[3].label, "translation_ratio=0.1, max_keyframes=7");
  EXPECT_EQ(spec.settings[4].label, "translation_ratio=0.2, mode=frontend");
  EXPECT_EQ(spec.settings[0].folder, "translation_ratio=0.05__max_keyframes=5");

  const std::vector<SweepRun> runs = ExpandSweep(spec);
  ASSERT_EQ(runs.size(), 10u);
  for (size_t i = 0; i < runs.size(); ++i) {
    EXPECT_EQ(runs[i].index, static_cast<int>(i));
    EXPECT_EQ(runs[i].setting, static_cast<int>(i / 2));
    EXPECT_EQ(runs[i].sequence, static_cast<int>(i % 2));
  }
  const SweepRun& r = runs[3];  // setting 1 on "other"
  EXPECT_EQ(r.config, ConfigsDir() + "/demo_learned.yaml");
  EXPECT_EQ(r.output_dir, "out/sweep_test/runs/other/translation_ratio=0.05__max_keyframes=7");
  const std::vector<std::string> overrides = {"run.progress=none",
                                              "run.plot=false",
                                              "dataset.path=out/other",
                                              "run.threads=1",
                                              "keyframe.translation_ratio=0.05",
                                              "window.max_keyframes=7",
                                              "run.output_dir=" + r.output_dir};
  EXPECT_EQ(r.overrides, overrides);
  EXPECT_EQ(r.threads, 1);
  EXPECT_EQ(runs[0].threads, 2);  // demo.yaml's run.threads
}

TEST(SweepSpec, NoGridMeansOneBaseRunPerSequence) {
  const SweepSpec spec = Load("base_config: demo.yaml\nsequences:\n  - name: a\n  - name: b\n");
  ASSERT_EQ(spec.settings.size(), 1u);
  EXPECT_EQ(spec.settings[0].label, "base");
  EXPECT_EQ(spec.output, "out/sweep");  // out/<file stem>
  EXPECT_EQ(ExpandSweep(spec).size(), 2u);
}

TEST(SweepSpec, SameShortNamesKeepTheirSection) {
  const SweepSpec spec = Load(
      "base_config: demo.yaml\nsequences: [{name: a}]\ngrid:\n  tracker.num_levels: [3]\n"
      "  learned.num_levels: [4]\n");
  EXPECT_EQ(spec.settings[0].label, "tracker.num_levels=3, learned.num_levels=4");
}

TEST(SweepSpec, SlurmResources) {
  const SweepSpec spec = Load(
      "base_config: demo.yaml\nsequences: [{name: a}]\nslurm:\n  partition: gpu\n"
      "  time: \"01:00:00\"\n  cpus_per_task: 4\n  mem: 8G\n  max_parallel: 3\n"
      "  extra: [--constraint=avx512]\n");
  EXPECT_EQ(spec.slurm.partition, "gpu");
  EXPECT_EQ(spec.slurm.time, "01:00:00");
  EXPECT_EQ(spec.slurm.cpus_per_task, 4);
  EXPECT_EQ(spec.slurm.mem, "8G");
  EXPECT_EQ(spec.slurm.max_parallel, 3);
  ASSERT_EQ(spec.slurm.extra.size(), 1u);
}

TEST(SweepSpec, ErrorsNameFileLineAndSuggest) {
  const std::string seq = "base_config: demo.yaml\nsequences: [{name: a}]\n";
  // Unknown sweep key, with a suggestion.
  EXPECT_EQ(ErrorOf(seq + "gird:\n  run.threads: [1]\n"),
            "sweep.yaml:3: unknown sweep key 'gird' (did you mean 'grid'?)");
  // A dfo_run key that does not exist, checked against dfo_run's schema before any run.
  EXPECT_EQ(ErrorOf(seq + "grid:\n  keyframe.translation_ration: [0.1]\n"),
            "sweep.yaml:4: unknown dfo_run key 'keyframe.translation_ration' (did you mean "
            "'keyframe.translation_ratio'?)");
  // A value dfo_run would refuse: the line of the value itself.
  const std::string range = ErrorOf(seq +
                                    "grid:\n  keyframe.translation_ratio:\n    - 0.1\n"
                                    "    - -0.5\n");
  EXPECT_NE(range.find("sweep.yaml:6:"), std::string::npos) << range;
  EXPECT_NE(range.find("violates > 0"), std::string::npos) << range;
  const std::string type = ErrorOf(seq + "set: {window.max_keyframes: many}\n");
  EXPECT_NE(type.find("sweep.yaml:3:"), std::string::npos) << type;
  EXPECT_NE(type.find("expected an integer"), std::string::npos) << type;
  EXPECT_NE(ErrorOf(seq + "grid:\n  run.threads: []\n")
                .find("sweep.yaml:4: grid key "
                      "'run.threads' has no values"),
            std::string::npos);
  EXPECT_NE(ErrorOf(seq + "grid:\n  run.threads: [1, 1]\n").find("lists the value 1 twice"),
            std::string::npos);
  EXPECT_NE(ErrorOf(seq + "set: {run.output_dir: x}\n")
                .find("run.output_dir is chosen by the "
                      "sweep"),
            std::string::npos);
  EXPECT_NE(ErrorOf(seq + "slurm: {partiton: x}\n")
                .find("unknown slurm key 'partiton' (did you "
                      "mean 'partition'?)"),
            std::string::npos);
  EXPECT_NE(ErrorOf(seq + "parallel: -1\n").find("sweep.yaml:3: parallel = -1 violates >= 0"),
            std::string::npos);
  EXPECT_NE(ErrorOf(seq + "rank_by: best\n").find("one of auto|frontend|windowed"),
            std::string::npos);
  // Sequences.
  EXPECT_NE(ErrorOf("sequences: [{name: a}, {name: a}]\n").find("sequence 'a' is named twice"),
            std::string::npos);
  EXPECT_NE(ErrorOf("sequences: [{name: a/b}]\n").find("must be a folder name"), std::string::npos);
  EXPECT_NE(ErrorOf("sequences:\n  - name: a\n    sett: {}\n")
                .find("sweep.yaml:3: unknown sequence key 'sett' (did you mean 'set'?)"),
            std::string::npos);
  EXPECT_NE(ErrorOf("sequences: []\n").find("non-empty list"), std::string::npos);
  EXPECT_NE(ErrorOf("grid: {run.threads: [1]}\n").find("no 'sequences'"), std::string::npos);
  // Configuration files.
  EXPECT_NE(ErrorOf("base_config: nothere.yaml\nsequences: [{name: a}]\n")
                .find("sweep.yaml:1: base_config: configuration file not found"),
            std::string::npos);
  // Malformed YAML and duplicate settings.
  EXPECT_NE(ErrorOf("sequences: [{name: a}\n").find("malformed YAML"), std::string::npos);
  EXPECT_NE(ErrorOf(seq + "grid: {run.threads: [1]}\nlist:\n  - {run.threads: 1}\n")
                .find("sweep.yaml:5: setting threads=1 is the same as the one at line 3"),
            std::string::npos);
}

TEST(SweepSpec, MissingFileIsAnInputError) {
  EXPECT_THROW(LoadSweepSpec("/nonexistent/sweep.yaml"), InputError);
}

}  // namespace
}  // namespace dfo::io
