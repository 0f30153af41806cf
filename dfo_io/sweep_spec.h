// The sweep file of dfo_sweep: which dfo_run settings to try on which sequences, and the runs
// it expands to.
//
//   base_config: demo.yaml            # dfo_run configuration every run starts from
//   output: out/sweep_keyframes       # results.csv, results.md, pareto.png, runs/<seq>/<setting>/
//   sequences:                        # each: a name, optionally its own config, overrides
//     - name: synthetic
//       set: {dataset.path: out/sweep/synthetic}
//     - name: kitti06
//       config: kitti.yaml            # replaces base_config for this sequence
//       set: {frontend.depth: learned}
//   grid:                             # every combination of these values is one setting
//     keyframe.translation_ratio: [0.05, 0.1]
//     window.max_keyframes: [5, 7]
//   list:                             # settings named one by one (added to the grid's)
//     - {keyframe.translation_ratio: 0.2, window.max_keyframes: 7}
//   set: {run.threads: 1}             # overrides of every run
//   parallel: 0                       # local runs at a time; 0 = cores / run.threads
//   rank_by: auto                     # frontend | windowed | auto (windowed when present)
//   slurm: {partition: debug, time: "00:30:00", cpus_per_task: 2, mem: 2G}
//
// Config paths (base_config, a sequence's config) are relative to the sweep file's folder;
// everything passed to dfo_run (dataset.path, output) is relative to the working folder, as in
// dfo_run's own configurations. Every override key is checked against dfo_run's schema
// (DfoSchema) when the file is loaded, so a typo stops the sweep before any run starts; errors
// name the sweep file and line, with a "did you mean" suggestion for misspelt keys.
//
// Each run gets the overrides, later ones winning: run.progress=none, the sweep's `set`, the
// sequence's `set`, the setting's values, run.output_dir=<output>/runs/<sequence>/<setting>.
#ifndef DFO_IO_SWEEP_SPEC_H_
#define DFO_IO_SWEEP_SPEC_H_

#include <string>
#include <utility>
#include <vector>

namespace dfo::io {

// One "key: value" override from the sweep file, value as YAML text ("0.1", "[4, 4]").
struct SweepOverride {
  std::string key;    // dfo_run key "section.key"
  std::string value;  // value text as given to --set
  int line = 0;       // 1-based line in the sweep file (0 = unknown)
  std::string Text() const { return key + "=" + value; }
};

// One sequence of the sweep.
struct SweepSequence {
  std::string name;         // unique, used as folder name ([A-Za-z0-9._-]+)
  std::string config;       // dfo_run configuration of this sequence (path as resolved)
  std::vector<SweepOverride> overrides;  // its `set`
};

// One combination of swept values.
struct SweepSetting {
  std::vector<SweepOverride> values;  // in the order of the swept keys
  std::string label;                  // "translation_ratio=0.05, max_keyframes=5" ("base": none)
  std::string folder;                 // "translation_ratio=0.05__max_keyframes=5" ("base": none)
};

// Slurm resources of each array task (sbatch options; empty = the cluster's default).
struct SweepSlurm {
  std::string partition;
  std::string time;      // --time, e.g. "00:30:00"
  int cpus_per_task = 0;  // 0 = run.threads of the base configuration (at least 1)
  std::string mem;       // --mem, e.g. "2G"
  std::string account;
  std::string qos;
  int max_parallel = 0;  // array throttle (--array=...%N); 0 = none
  std::vector<std::string> extra;  // further sbatch options, e.g. "--constraint=avx512"
};

// The most runs (settings x sequences) one sweep file may ask for; more is refused, naming the
// count, before the runs are listed.
inline constexpr int kMaxSweepRuns = 100000;

// A whole sweep file.
struct SweepSpec {
  std::string path;         // the sweep file
  std::string base_config;  // resolved path ("" = dfo_run's defaults)
  std::string output;       // output folder
  std::vector<SweepSequence> sequences;
  std::vector<std::string> swept_keys;  // keys of grid and list, in order of appearance
  std::vector<SweepSetting> settings;   // grid combinations, then list entries
  std::vector<SweepOverride> common;    // the sweep's `set`
  int parallel = 0;                     // 0 = automatic
  std::string rank_by = "auto";         // frontend | windowed | auto
  SweepSlurm slurm;
};

// One dfo_run of the sweep: a setting on a sequence.
struct SweepRun {
  int index = 0;  // 0-based, setting-major: setting * sequences + sequence
  int setting = 0;
  int sequence = 0;
  std::string config;                  // --config ("" = none)
  std::vector<std::string> overrides;  // --set values, in order (run.output_dir last)
  std::string output_dir;              // <output>/runs/<sequence>/<setting folder>
  int threads = 1;                     // run.threads of its effective configuration (>= 1)
};

// Reads and validates a sweep file: unknown or duplicate keys, wrong types, empty value lists,
// duplicate sequence names or settings, keys unknown to dfo_run, values dfo_run would refuse
// (type, range), and configurations that do not load. Throws dfo::ConfigError naming the file
// and line (dfo::InputError when the file cannot be read).
SweepSpec LoadSweepSpec(const std::string& path);
// Same from text; `name` stands for the file in messages, `folder` is where config paths are
// resolved from.
SweepSpec LoadSweepSpecFromString(const std::string& text, const std::string& name,
                                  const std::string& folder);

// Every run of the sweep (settings x sequences), with its effective configuration checked.
// Throws dfo::ConfigError when a run's configuration does not load (naming the run).
std::vector<SweepRun> ExpandSweep(const SweepSpec& spec);

}  // namespace dfo::io

#endif  // DFO_IO_SWEEP_SPEC_H_
