#include "apps/common/sweep_exec.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "apps/common/progress.h"
#include "dfo_core/error.h"
#include "dfo_io/json.h"

extern char** environ;

namespace dfo::apps {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

std::string RecordPath(const std::string& dir) { return dir + "/sweep_run.json"; }
std::string SummaryPath(const std::string& dir) { return dir + "/summary.json"; }

std::string ReadText(const std::string& path) {
  std::ifstream file(path);
  std::stringstream buffer;
  buffer << file.rdbuf();
  return buffer.str();
}

void WriteRecord(const std::string& dir, const SweepRunRecord& record) {
  io::JsonValue json = io::JsonValue::Object();
  json.Set("status", record.status);
  io::JsonValue command = io::JsonValue::Array();
  for (const std::string& a : record.command) command.Push(a);
  json.Set("command", command);
  json.Set("exit_status", record.exit_status);
  json.Set("error", record.error);
  json.Set("stderr_tail", record.stderr_tail);
  json.Set("wall_s", record.wall_s);
  char host[256] = {0};
  gethostname(host, sizeof(host) - 1);
  json.Set("host", std::string(host));
  const std::string path = RecordPath(dir);
  std::ofstream file(path + ".tmp");
  file << json.Dump(2) << "\n";
  file.close();
  std::error_code ec;
  fs::rename(path + ".tmp", path, ec);  // readers never see half a record
  if (!file || ec) throw InputError("cannot write run record " + path);
}

// The last `max_lines` non-empty lines of a text (at most 2000 characters).
std::string Tail(const std::string& text, int max_lines) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    // Progress lines redrawn with '\r' keep only their last state.
    const size_t cr = line.find_last_of('\r');
    if (cr != std::string::npos) line = line.substr(cr + 1);
    if (!line.empty()) lines.push_back(line);
  }
  std::string out;
  for (size_t i = lines.size() > static_cast<size_t>(max_lines) ? lines.size() - max_lines : 0;
       i < lines.size(); ++i) {
    out += (out.empty() ? "" : "\n") + lines[i];
  }
  return out.size() > 2000 ? out.substr(out.size() - 2000) : out;
}

std::string LastLine(const std::string& text) {
  const size_t nl = text.find_last_of('\n');
  return nl == std::string::npos ? text : text.substr(nl + 1);
}

// Starts argv with stdin from /dev/null and stdout/stderr to the given files. Returns the pid, or
// -1 with *error set.
pid_t Spawn(const std::vector<std::string>& argv, const std::string& out_path,
            const std::string& err_path, bool search_path, std::string* error) {
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 1, out_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC,
                                   0644);
  pid_t pid = -1;
  const int rc = search_path
                     ? posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ)
                     : posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    *error = "cannot start " + argv[0] + ": " + std::strerror(rc);
    return -1;
  }
  return pid;
}

// A started run: its process and when it started.
struct Started {
  pid_t pid = -1;
  Clock::time_point start;
  SweepRunRecord record;
};

// Creates the run's folder, removes a stale summary, writes the "running" record and starts
// dfo_run. On failure to start, record.status is "failed" and pid -1.
Started StartRun(const io::SweepRun& run, const std::string& dfo_run) {
  Started s;
  s.start = Clock::now();
  s.record.command = RunCommandLine(run, dfo_run);
  std::error_code ec;
  fs::create_directories(run.output_dir, ec);
  if (!fs::is_directory(run.output_dir, ec)) {
    s.record.status = "failed";
    s.record.error = "cannot create the run folder " + run.output_dir;
    return s;
  }
  fs::remove(SummaryPath(run.output_dir), ec);
  WriteRecord(run.output_dir, s.record);
  std::string error;
  s.pid = Spawn(s.record.command, run.output_dir + "/dfo_run.out",
                run.output_dir + "/dfo_run.err", /*search_path=*/false, &error);
  if (s.pid < 0) {
    s.record.status = "failed";
    s.record.error = error;
    WriteRecord(run.output_dir, s.record);
  }
  return s;
}

// Completes the record of a run whose process ended with `wait_status`, and writes it.
SweepRunRecord FinishRun(const io::SweepRun& run, Started started, int wait_status) {
  SweepRunRecord& r = started.record;
  r.wall_s = std::chrono::duration<double>(Clock::now() - started.start).count();
  r.stderr_tail = Tail(ReadText(run.output_dir + "/dfo_run.err"), 12);
  std::string incomplete;
  if (WIFEXITED(wait_status)) {
    r.exit_status = WEXITSTATUS(wait_status);
    if (r.exit_status != 0) {
      r.error = "dfo_run exited with status " + std::to_string(r.exit_status);
      if (!r.stderr_tail.empty()) r.error += ": " + LastLine(r.stderr_tail);
    } else if (!io::IsRunSummaryComplete(SummaryPath(run.output_dir), &incomplete)) {
      r.error = "dfo_run exited with status 0 but its summary is incomplete: " + incomplete;
    }
  } else if (WIFSIGNALED(wait_status)) {
    r.error = "dfo_run was killed by signal " + std::to_string(WTERMSIG(wait_status)) + " (" +
              strsignal(WTERMSIG(wait_status)) + ")";
  } else {
    r.error = "dfo_run ended abnormally";
  }
  r.status = r.error.empty() ? "ok" : "failed";
  WriteRecord(run.output_dir, r);
  return r;
}

std::string RunName(const io::SweepSpec& spec, const io::SweepRun& run) {
  return spec.sequences[run.sequence].name + " / " + spec.settings[run.setting].label;
}

std::string Quote(const std::string& s) {
  std::string out = "'";
  for (const char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::vector<std::string> RunCommandLine(const io::SweepRun& run, const std::string& dfo_run) {
  std::vector<std::string> argv = {dfo_run};
  if (!run.config.empty()) {
    argv.push_back("--config");
    argv.push_back(run.config);
  }
  for (const std::string& o : run.overrides) {
    argv.push_back("--set");
    argv.push_back(o);
  }
  return argv;
}

bool ReadRunRecord(const std::string& output_dir, SweepRunRecord* record) {
  std::error_code ec;
  const std::string path = RecordPath(output_dir);
  if (!fs::is_regular_file(path, ec)) return false;
  try {
    const io::JsonValue json = io::ParseJson(ReadText(path), path);
    SweepRunRecord r;
    r.status = json["status"].AsString();
    for (size_t i = 0; i < json["command"].size(); ++i) {
      r.command.push_back(json["command"][i].AsString());
    }
    r.exit_status = static_cast<int>(json["exit_status"].AsInt());
    r.error = json["error"].AsString();
    r.stderr_tail = json["stderr_tail"].AsString();
    r.wall_s = json["wall_s"].AsNumber();
    *record = r;
    return true;
  } catch (const InputError&) {
    return false;
  }
}

bool IsRunFinished(const io::SweepRun& run, std::string* why) {
  std::string reason;
  if (io::IsRunSummaryComplete(SummaryPath(run.output_dir), &reason)) {
    SweepRunRecord record;
    // The executable may differ (another build folder, a Slurm node): compare the arguments.
    const std::vector<std::string> now = RunCommandLine(run, "");
    if (ReadRunRecord(run.output_dir, &record) && !record.command.empty() &&
        !std::equal(now.begin() + 1, now.end(), record.command.begin() + 1,
                    record.command.end())) {
      reason = "its summary.json comes from other settings (" + RecordPath(run.output_dir) + ")";
    }
  }
  if (why) *why = reason;
  return reason.empty();
}

SweepRunRecord ExecuteRun(const io::SweepRun& run, const std::string& dfo_run) {
  Started started = StartRun(run, dfo_run);
  if (started.pid < 0) return started.record;
  int wait_status = 0;
  while (waitpid(started.pid, &wait_status, 0) < 0 && errno == EINTR) {
  }
  return FinishRun(run, std::move(started), wait_status);
}

LocalSweepCounts RunSweepLocally(const io::SweepSpec& spec, const std::vector<io::SweepRun>& runs,
                                 const std::string& dfo_run, const LocalSweepOptions& options) {
  DFO_CHECK(options.parallel >= 1) << options.parallel;
  LocalSweepCounts counts;
  std::vector<const io::SweepRun*> queue;
  for (const io::SweepRun& run : runs) {
    if (IsRunFinished(run)) {
      ++counts.skipped;
    } else {
      queue.push_back(&run);
    }
  }
  std::FILE* out = options.progress;
  if (out) {
    std::fprintf(out, "dfo_sweep: %zu runs (%zu settings x %zu sequences): %d already finished, "
                 "%zu to run, %d at a time -> %s\n",
                 runs.size(), spec.settings.size(), spec.sequences.size(), counts.skipped,
                 queue.size(), options.parallel, spec.output.c_str());
    std::fflush(out);
  }
  const Clock::time_point sweep_start = Clock::now();
  Clock::time_point last_line = sweep_start;
  std::map<pid_t, std::pair<const io::SweepRun*, Started>> running;
  size_t next = 0, done = 0;
  double wall_sum = 0.0;
  const auto report = [&](const io::SweepRun& run, const SweepRunRecord& r) {
    ++done;
    wall_sum += r.wall_s;
    (r.status == "ok" ? counts.ok : counts.failed)++;
    if (!out) return;
    const size_t left = queue.size() - done;
    const std::string eta =
        left == 0 ? "done"
                  : "ETA " + FormatDuration(wall_sum / done * static_cast<double>(left) /
                                            std::min<size_t>(options.parallel, left));
    std::fprintf(out, "[%zu/%zu] %-6s %s  (%s)  %s\n", done, queue.size(),
                 r.status == "ok" ? "ok" : "FAILED", RunName(spec, run).c_str(),
                 FormatDuration(r.wall_s).c_str(), eta.c_str());
    if (r.status != "ok") std::fprintf(out, "        %s\n", r.error.c_str());
    std::fflush(out);
    last_line = Clock::now();
  };
  while (next < queue.size() || !running.empty()) {
    while (next < queue.size() && static_cast<int>(running.size()) < options.parallel) {
      const io::SweepRun& run = *queue[next++];
      Started s = StartRun(run, dfo_run);
      if (s.pid < 0) {
        report(run, s.record);
      } else {
        running.emplace(s.pid, std::make_pair(&run, std::move(s)));
      }
    }
    if (running.empty()) continue;
    int wait_status = 0;
    const pid_t pid = waitpid(-1, &wait_status, WNOHANG);
    if (pid > 0 && running.count(pid)) {
      auto node = running.extract(pid);
      const io::SweepRun& run = *node.mapped().first;
      report(run, FinishRun(run, std::move(node.mapped().second), wait_status));
      continue;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const double quiet_s = std::chrono::duration<double>(Clock::now() - last_line).count();
    if (out && quiet_s >= options.status_interval_s) {
      std::string names;
      for (const auto& [p, entry] : running) {
        names += (names.empty() ? "" : "; ") + RunName(spec, *entry.first);
      }
      const double elapsed = std::chrono::duration<double>(Clock::now() - sweep_start).count();
      std::fprintf(out, "        %zu/%zu done after %s; running: %s\n", done, queue.size(),
                   FormatDuration(elapsed).c_str(), names.c_str());
      std::fflush(out);
      last_line = Clock::now();
    }
  }
  return counts;
}

std::vector<io::SweepRow> CollectSweepRows(const io::SweepSpec& spec,
                                           const std::vector<io::SweepRun>& runs) {
  std::vector<io::SweepRow> rows;
  for (const io::SweepRun& run : runs) {
    io::SweepRow row;
    const io::SweepSetting& setting = spec.settings[run.setting];
    row.sequence = spec.sequences[run.sequence].name;
    row.setting = setting.label;
    for (const std::string& key : spec.swept_keys) {
      std::string value;
      for (const io::SweepOverride& o : setting.values) {
        if (o.key == key) value = o.value;
      }
      row.values.push_back(value);
    }
    row.output_dir = run.output_dir;
    std::string why;
    const bool finished = IsRunFinished(run, &why);
    io::ReadRunSummary(SummaryPath(run.output_dir), &row);
    SweepRunRecord record;
    const bool has_record = ReadRunRecord(run.output_dir, &record);
    if (!finished && row.status == "ok") {
      row.status = "missing";  // a complete summary of other settings
      row.error = why;
    } else if (row.status != "ok" && has_record) {
      if (record.status == "failed") {
        row.status = "failed";
        row.error = record.error;
      } else if (record.status == "running") {
        row.status = "missing";
        row.error = "started but never finished (still running, or killed: see " +
                    run.output_dir + "/dfo_run.err and the Slurm logs)";
      }
    } else if (row.status == "missing") {
      row.error = "not run yet";
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

io::SweepTable MakeSweepTable(const io::SweepSpec& spec, std::vector<io::SweepRow> rows) {
  io::SweepTable table;
  table.swept_keys = spec.swept_keys;
  for (const auto& s : spec.settings) table.settings.push_back(s.label);
  for (const auto& q : spec.sequences) table.sequences.push_back(q.name);
  table.rank_by = spec.rank_by;
  table.rows = std::move(rows);
  io::ScoreSweepRows(table.rank_by, &table.rows);
  return table;
}

std::string SweepCsvPath(const io::SweepSpec& spec) { return spec.output + "/results.csv"; }
std::string SweepMarkdownPath(const io::SweepSpec& spec) { return spec.output + "/results.md"; }
std::string SweepPlotPath(const io::SweepSpec& spec) { return spec.output + "/pareto.png"; }

std::string ArrayRanges(const std::vector<int>& indices) {
  std::string out;
  for (size_t i = 0; i < indices.size();) {
    size_t j = i;
    while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1) ++j;
    out += (out.empty() ? "" : ",") + std::to_string(indices[i]);
    if (j > i) out += "-" + std::to_string(indices[j]);
    i = j + 1;
  }
  return out;
}

std::string SlurmScript(const io::SweepSpec& spec, const std::vector<io::SweepRun>& runs,
                        const std::vector<int>& indices, const std::string& dfo_sweep,
                        const std::string& dfo_run, const std::string& working_dir) {
  const io::SweepSlurm& slurm = spec.slurm;
  int cpus = slurm.cpus_per_task;
  if (cpus <= 0) {
    cpus = 1;
    for (const io::SweepRun& run : runs) cpus = std::max(cpus, run.threads);
  }
  const std::string logs = fs::absolute(fs::path(spec.output) / "slurm" / "logs").string();
  std::ostringstream s;
  s << "#!/bin/bash\n"
    << "# Written by dfo_sweep --slurm for " << spec.path << ": one array task per run.\n"
    << "#SBATCH --job-name=dfo_sweep_" << fs::path(spec.path).stem().string() << "\n"
    << "#SBATCH --array=" << ArrayRanges(indices)
    << (slurm.max_parallel > 0 ? "%" + std::to_string(slurm.max_parallel) : "") << "\n"
    << "#SBATCH --ntasks=1\n"
    << "#SBATCH --cpus-per-task=" << cpus << "\n";
  if (!slurm.partition.empty()) s << "#SBATCH --partition=" << slurm.partition << "\n";
  if (!slurm.time.empty()) s << "#SBATCH --time=" << slurm.time << "\n";
  if (!slurm.mem.empty()) s << "#SBATCH --mem=" << slurm.mem << "\n";
  if (!slurm.account.empty()) s << "#SBATCH --account=" << slurm.account << "\n";
  if (!slurm.qos.empty()) s << "#SBATCH --qos=" << slurm.qos << "\n";
  for (const std::string& e : slurm.extra) s << "#SBATCH " << e << "\n";
  s << "#SBATCH --chdir=" << working_dir << "\n"
    << "#SBATCH --output=" << logs << "/task_%A_%a.out\n"
    << "\n"
    << "exec " << Quote(dfo_sweep) << " --run-index \"$SLURM_ARRAY_TASK_ID\" --dfo-run "
    << Quote(dfo_run) << " " << Quote(fs::absolute(spec.path).string()) << "\n";
  return s.str();
}

ProgramOutput RunProgram(const std::vector<std::string>& argv, const std::string& scratch_dir) {
  static int counter = 0;
  const std::string base =
      scratch_dir + "/." + fs::path(argv.at(0)).filename().string() + "_" +
      std::to_string(getpid()) + "_" + std::to_string(counter++);
  ProgramOutput result;
  std::string error;
  const pid_t pid = Spawn(argv, base + ".out", base + ".err", /*search_path=*/true, &error);
  if (pid < 0) {
    result.err = error;
    return result;
  }
  int wait_status = 0;
  while (waitpid(pid, &wait_status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(wait_status)) result.exit_status = WEXITSTATUS(wait_status);
  result.out = ReadText(base + ".out");
  result.err = ReadText(base + ".err");
  std::error_code ec;
  fs::remove(base + ".out", ec);
  fs::remove(base + ".err", ec);
  return result;
}

}  // namespace dfo::apps
