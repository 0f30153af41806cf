// dfo_sweep: runs dfo_run over a grid of settings and a set of sequences, here (N runs at a time)
// or as a Slurm job array, and ranks the results.
//
//   dfo_sweep [--parallel N] SWEEP.yaml                 run here, then write the results
//   dfo_sweep --slurm [--no-submit] [--wait] SWEEP.yaml submit one array task per run
//   dfo_sweep --collect [--wait] SWEEP.yaml             write the results of what has run
//   dfo_sweep --run-index I SWEEP.yaml                  run one run (what each array task does)
//
// The sweep file is described in dfo_io/sweep_spec.h and docs/sweeps.md. dfo_sweep
// never links LibTorch: every run is a dfo_run process.
#include <unistd.h>

#include <chrono>
#include <climits>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "apps/common/cli.h"
#include "apps/common/sweep_exec.h"
#include "dfo_core/error.h"
#include "dfo_io/sweep_results.h"
#include "dfo_io/sweep_spec.h"

namespace dfo {
namespace {

namespace fs = std::filesystem;
using apps::UsageError;

constexpr const char* kUsage =
    R"(usage: dfo_sweep [options] SWEEP.yaml

Runs dfo_run for every combination of the sweep's settings (grid and/or list of --set
overrides) on every sequence of the sweep, each run in its own folder
<output>/runs/<sequence>/<setting>/, and writes into <output>:
  results.csv   one line per run: settings, sequence, status, frontend and windowed Sim3 ATE
                and RPE, keyframes, ms per frame, fps, error
  results.md    the same as a Markdown table, the best setting per sequence, the overall ranking
                (mean rank across sequences) and the failed or missing runs
  pareto.png    ATE against ms per frame, the Pareto front of each sequence marked
A run whose summary.json is present and complete is not run again: restarting a sweep finishes
what is missing. A failing run is recorded (exit status, stderr tail in its sweep_run.json) and
the sweep goes on.

modes:
  (none)             run the unfinished runs here, N at a time, then write the results
  --slurm            write <output>/slurm/sweep.sbatch, a Slurm job array of the unfinished runs
                     (one task per run; resources from the sweep's slurm section), and submit it
                     with sbatch
  --collect          write the results from what the run folders hold; list missing and failed runs
  --run-index I      run the I-th run (0-based, see --list) here; what each array task does
  --list             print every run (index, sequence, setting, finished or not) and exit

options:
  --parallel N       runs at a time here (default: the sweep's parallel, else cores / run.threads)
  --no-submit        with --slurm: write the script, do not submit it
  --wait             with --slurm or --collect: wait until the submitted job has left the Slurm
                     queue, then collect
  --dfo-run PATH     the dfo_run executable (default: dfo_run beside dfo_sweep)
  --help             this text
Flags also take their value after '=' (--parallel=2).

Exit status: 0 when every run is finished and ok, 1 when some failed or are missing (or on an
error, one line on stderr), 2 for a command-line mistake.
)";

struct Args {
  std::string sweep;
  std::string dfo_run;
  int parallel = 0;
  int run_index = -1;
  bool slurm = false, no_submit = false, wait = false, collect = false, list = false;
  bool help = false;
};

Args ParseArgs(int argc, char** argv) {
  Args args;
  apps::ArgParser parser;
  parser.Flag("--help", &args.help, "-h")
      .Flag("--slurm", &args.slurm)
      .Flag("--no-submit", &args.no_submit)
      .Flag("--wait", &args.wait)
      .Flag("--collect", &args.collect)
      .Flag("--list", &args.list)
      .Int("--parallel", &args.parallel, 1, 4096)
      .Int("--run-index", &args.run_index, 0, std::numeric_limits<int>::max())
      .Value("--dfo-run", &args.dfo_run)
      .Positional("SWEEP_FILE", &args.sweep, /*required=*/false);
  parser.Parse(argc, argv);
  if (args.help) return args;
  if (args.sweep.empty()) throw UsageError("no sweep file given");
  const int modes = args.slurm + args.collect + (args.run_index >= 0) + args.list;
  if (modes > 1) throw UsageError("--slurm, --collect, --run-index and --list exclude each other");
  if (args.no_submit && !args.slurm) throw UsageError("--no-submit goes with --slurm");
  if (args.wait && !args.slurm && !args.collect) {
    throw UsageError("--wait goes with --slurm or --collect");
  }
  if (args.wait && args.no_submit) throw UsageError("--wait needs a submitted job (no --no-submit)");
  return args;
}

// This executable's path (for the Slurm script and to find dfo_run beside it).
std::string SelfPath() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw InputError("cannot find dfo_sweep's own path (/proc/self/exe)");
  return self.string();
}

std::string FindDfoRun(const std::string& given) {
  const std::string path =
      given.empty() ? (fs::path(SelfPath()).parent_path() / "dfo_run").string() : given;
  if (access(path.c_str(), X_OK) != 0) {
    throw InputError("dfo_run not found or not executable: " + path +
                     (given.empty() ? " (build it, or name it with --dfo-run PATH)" : ""));
  }
  return fs::absolute(path).string();
}

std::string SlurmDir(const io::SweepSpec& spec) { return spec.output + "/slurm"; }

// Writes the result files and prints the Markdown; returns the exit status (0 = all ok).
int WriteResults(const io::SweepSpec& spec, const std::vector<io::SweepRun>& runs) {
  const io::SweepTable table = apps::MakeSweepTable(spec, apps::CollectSweepRows(spec, runs));
  io::WriteSweepCsv(apps::SweepCsvPath(spec), table);
  io::WriteSweepMarkdown(apps::SweepMarkdownPath(spec), table);
  std::cout << "\n" << io::SweepMarkdown(table) << "\n";
  std::cout << "written:     " << apps::SweepCsvPath(spec) << "\n             "
            << apps::SweepMarkdownPath(spec) << "\n";
  try {
    io::WriteSweepParetoPlot(apps::SweepPlotPath(spec), table);
    std::cout << "             " << apps::SweepPlotPath(spec) << "\n";
  } catch (const InputError& e) {
    std::cout << "no plot:     " << e.what() << "\n";
  }
  int ok = 0, failed = 0, missing = 0;
  for (const io::SweepRow& row : table.rows) {
    ok += row.status == "ok";
    failed += row.status == "failed";
    missing += row.status == "missing";
  }
  std::cout << "runs:        " << ok << " ok, " << failed << " failed, " << missing
            << " missing of " << table.rows.size() << "\n";
  std::cout.flush();
  return ok == static_cast<int>(table.rows.size()) ? 0 : 1;
}

// The id of the job last submitted for this sweep ("" when none).
std::string LastJobId(const io::SweepSpec& spec) {
  std::ifstream file(SlurmDir(spec) + "/job_ids");
  std::string line, last;
  while (std::getline(file, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

// Waits until `job_id` has no task left in the Slurm queue.
void WaitForJob(const io::SweepSpec& spec, const std::string& job_id) {
  if (job_id.empty()) {
    throw InputError("no submitted job to wait for (" + SlurmDir(spec) +
                     "/job_ids is missing; submit with dfo_sweep --slurm first)");
  }
  std::cout << "waiting for Slurm job " << job_id << " to leave the queue..." << std::endl;
  int errors = 0;
  std::string last_state;
  while (true) {
    const apps::ProgramOutput q =
        apps::RunProgram({"squeue", "-h", "-j", job_id, "-o", "%i %T"}, SlurmDir(spec));
    if (q.exit_status == 0 && q.out.find_first_not_of(" \n") == std::string::npos) return;
    // squeue forgets a job some time after it ended: "Invalid job id specified".
    if (q.exit_status != 0 && q.err.find("Invalid job id") != std::string::npos) return;
    if (q.exit_status != 0 && ++errors >= 30) {
      throw InputError("squeue keeps failing while waiting for job " + job_id + ": " + q.err);
    }
    if (q.exit_status == 0) {
      errors = 0;
      int count = 0;
      for (const char c : q.out) count += c == '\n';
      const std::string state = std::to_string(count) + " task(s) queued or running";
      if (state != last_state) std::cout << "  " << state << std::endl;
      last_state = state;
    }
    std::this_thread::sleep_for(std::chrono::seconds(2));
  }
}

int SubmitSlurm(const Args& args, const io::SweepSpec& spec,
                const std::vector<io::SweepRun>& runs, const std::string& dfo_run) {
  std::vector<int> indices;
  for (const io::SweepRun& run : runs) {
    if (!apps::IsRunFinished(run)) indices.push_back(run.index);
  }
  std::cout << "dfo_sweep: " << runs.size() << " runs, " << runs.size() - indices.size()
            << " already finished, " << indices.size() << " to submit\n";
  if (indices.empty()) return WriteResults(spec, runs);
  std::error_code ec;
  fs::create_directories(SlurmDir(spec) + "/logs", ec);
  const std::string script_path = SlurmDir(spec) + "/sweep.sbatch";
  {
    std::ofstream script(script_path);
    script << apps::SlurmScript(spec, runs, indices, SelfPath(), dfo_run,
                                fs::current_path().string());
    if (!script) throw InputError("cannot write " + script_path);
  }
  std::cout << "written:     " << script_path << "\n";
  if (args.no_submit) {
    std::cout << "submit with: sbatch " << script_path << "\n";
    return 0;
  }
  const apps::ProgramOutput r = apps::RunProgram({"sbatch", "--parsable", script_path},
                                                 SlurmDir(spec));
  if (r.exit_status != 0) {
    throw InputError("sbatch " + script_path + " failed" +
                     (r.exit_status < 0 ? "" : " (exit status " + std::to_string(r.exit_status) +
                                                   ")") +
                     ": " + (r.err.empty() ? r.out : r.err));
  }
  std::string job_id = r.out.substr(0, r.out.find_first_of(";\n"));
  std::ofstream(SlurmDir(spec) + "/job_ids", std::ios::app) << job_id << "\n";
  std::cout << "submitted:   Slurm job " << job_id << ", " << indices.size()
            << " array task(s) (" << apps::ArrayRanges(indices) << "); logs in "
            << SlurmDir(spec) << "/logs/\n";
  if (!args.wait) {
    std::cout << "when done:   dfo_sweep --collect " << spec.path << "\n";
    return 0;
  }
  WaitForJob(spec, job_id);
  return WriteResults(spec, runs);
}

int Run(const Args& args) {
  const io::SweepSpec spec = io::LoadSweepSpec(args.sweep);
  const std::vector<io::SweepRun> runs = io::ExpandSweep(spec);
  if (args.list) {
    for (const io::SweepRun& run : runs) {
      std::cout << run.index << "\t" << spec.sequences[run.sequence].name << "\t"
                << spec.settings[run.setting].label << "\t"
                << (apps::IsRunFinished(run) ? "finished" : "to run") << "\t" << run.output_dir
                << "\n";
    }
    return 0;
  }
  if (args.collect) {
    if (args.wait) WaitForJob(spec, LastJobId(spec));
    return WriteResults(spec, runs);
  }
  const std::string dfo_run = FindDfoRun(args.dfo_run);
  if (args.slurm) return SubmitSlurm(args, spec, runs, dfo_run);
  if (args.run_index >= 0) {
    if (args.run_index >= static_cast<int>(runs.size())) {
      throw UsageError("--run-index " + std::to_string(args.run_index) + " is out of range: " +
                       args.sweep + " has " + std::to_string(runs.size()) + " runs (0.." +
                       std::to_string(runs.size() - 1) + ")");
    }
    const io::SweepRun& run = runs[args.run_index];
    const std::string name =
        spec.sequences[run.sequence].name + " / " + spec.settings[run.setting].label;
    if (apps::IsRunFinished(run)) {
      std::cout << "dfo_sweep: run " << run.index << " (" << name << ") is already finished\n";
      return 0;
    }
    std::cout << "dfo_sweep: run " << run.index << " (" << name << ") -> " << run.output_dir
              << std::endl;
    const apps::SweepRunRecord r = apps::ExecuteRun(run, dfo_run);
    std::cout << "dfo_sweep: run " << run.index << " " << r.status << " after "
              << static_cast<int>(r.wall_s + 0.5) << " s\n";
    if (r.status != "ok") std::cerr << "dfo_sweep: run " << run.index << ": " << r.error << "\n";
    return r.status == "ok" ? 0 : 1;
  }
  int parallel = args.parallel > 0 ? args.parallel : spec.parallel;
  if (parallel <= 0) {
    int threads = 1;
    for (const io::SweepRun& run : runs) threads = std::max(threads, run.threads);
    const int cores = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
    parallel = std::max(1, cores / threads);
  }
  apps::LocalSweepOptions options;
  options.parallel = parallel;
  apps::RunSweepLocally(spec, runs, dfo_run, options);
  return WriteResults(spec, runs);
}

}  // namespace
}  // namespace dfo

int main(int argc, char** argv) {
  return dfo::apps::RunMain("dfo_sweep", [&] {
    const dfo::Args args = dfo::ParseArgs(argc, argv);
    if (args.help) {
      std::cout << dfo::kUsage;
      return 0;
    }
    return dfo::Run(args);
  });
}
