// Running the dfo_run processes of a sweep (dfo_sweep): one run at a time or N in parallel on this
// machine, one run per Slurm array task, and gathering their results.
//
// Each run writes into its own folder: dfo_run's outputs, dfo_run.out / dfo_run.err (its stdout
// and stderr) and sweep_run.json, the record dfo_sweep keeps of it:
//   {"status": "running" | "ok" | "failed", "command": [...], "exit_status": 0,
//    "error": "...", "stderr_tail": "...", "wall_s": 12.3, "host": "..."}
// A run is finished when its summary.json is present and complete (dfo_io/sweep_results.h) and
// its record, when there is one, shows the same command (same configuration and overrides);
// finished runs are never started again.
#ifndef DFO_APPS_COMMON_SWEEP_EXEC_H_
#define DFO_APPS_COMMON_SWEEP_EXEC_H_

#include <cstdio>
#include <string>
#include <vector>

#include "dfo_io/sweep_results.h"
#include "dfo_io/sweep_spec.h"

namespace dfo::apps {

// What happened to one run.
struct SweepRunRecord {
  std::string status = "running";  // running | ok | failed
  std::vector<std::string> command;
  int exit_status = -1;     // dfo_run's exit status; -1 when it did not exit normally
  std::string error;        // one line: why it failed
  std::string stderr_tail;  // the last lines of dfo_run's stderr
  double wall_s = 0.0;
};

// The dfo_run command line of a run: dfo_run [--config FILE] --set ... (the output folder is the
// last --set).
std::vector<std::string> RunCommandLine(const io::SweepRun& run, const std::string& dfo_run);

// Whether the run is finished (see the file comment); `why` receives the reason when not.
bool IsRunFinished(const io::SweepRun& run, std::string* why = nullptr);

// Reads <run folder>/sweep_run.json; false when absent or unreadable.
bool ReadRunRecord(const std::string& output_dir, SweepRunRecord* record);

// Runs one run to its end (creating its folder, removing a stale summary.json first) and writes
// its record. Never throws for a failing dfo_run: the failure is in the record.
SweepRunRecord ExecuteRun(const io::SweepRun& run, const std::string& dfo_run);

// Options of RunSweepLocally.
struct LocalSweepOptions {
  int parallel = 1;                  // runs at a time, >= 1
  std::FILE* progress = stdout;      // progress lines (one per finished run); null = none
  double status_interval_s = 60.0;   // a "still running" line when nothing finished for this long
};

// Counts of a local sweep.
struct LocalSweepCounts {
  int skipped = 0;  // already finished
  int ok = 0;
  int failed = 0;
};

// Starts every unfinished run, `parallel` at a time, and waits for all of them. Progress: a line
// per finished run with its status, time and the estimated time left (mean time per run so far x
// runs left / parallel).
LocalSweepCounts RunSweepLocally(const io::SweepSpec& spec, const std::vector<io::SweepRun>& runs,
                                 const std::string& dfo_run, const LocalSweepOptions& options);

// One row per run from what its folder holds: the summary's figures, else the failure or why it
// is missing (from its record).
std::vector<io::SweepRow> CollectSweepRows(const io::SweepSpec& spec,
                                           const std::vector<io::SweepRun>& runs);

// The table of the result files (rows scored by the spec's rank_by).
io::SweepTable MakeSweepTable(const io::SweepSpec& spec, std::vector<io::SweepRow> rows);

// Paths of the sweep's result files.
std::string SweepCsvPath(const io::SweepSpec& spec);       // <output>/results.csv
std::string SweepMarkdownPath(const io::SweepSpec& spec);  // <output>/results.md
std::string SweepPlotPath(const io::SweepSpec& spec);      // <output>/pareto.png

// "0-3,5,7-9" for the indices {0,1,2,3,5,7,8,9} (sorted, distinct).
std::string ArrayRanges(const std::vector<int>& indices);

// The sbatch script of a Slurm job array, one task per run in `indices`: resources from
// spec.slurm (cpus_per_task 0 = the runs' largest run.threads), each task running
// `<dfo_sweep> --run-index $SLURM_ARRAY_TASK_ID --dfo-run <dfo_run> <sweep file>` in
// `working_dir`, logs in <output>/slurm/logs/. All paths absolute.
std::string SlurmScript(const io::SweepSpec& spec, const std::vector<io::SweepRun>& runs,
                        const std::vector<int>& indices, const std::string& dfo_sweep,
                        const std::string& dfo_run, const std::string& working_dir);

// Result of running a program to its end with its output captured.
struct ProgramOutput {
  int exit_status = -1;  // -1 when it could not start or did not exit normally
  std::string out;
  std::string err;
};

// Runs `argv` (argv[0] looked up on PATH) with stdin from /dev/null; stdout and stderr go through
// files in `scratch_dir`.
ProgramOutput RunProgram(const std::vector<std::string>& argv, const std::string& scratch_dir);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_SWEEP_EXEC_H_
