#include "dfo_io/sweep_results.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "dfo_core/error.h"
#include "dfo_io/config.h"
#include "dfo_io/curve_plot.h"
#include "dfo_io/json.h"

namespace dfo::io {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string ReadText(const std::string& path) {
  std::ifstream file(path);
  std::stringstream buffer;
  buffer << file.rdbuf();
  return buffer.str();
}

double NumberOr(const JsonValue& object, const std::string& key, double fallback) {
  if (!object.IsObject() || !object.Has(key) || !object[key].IsNumber()) return fallback;
  return object[key].AsNumber();
}

SweepTrajectoryFigures Figures(const JsonValue& summary, const std::string& key) {
  SweepTrajectoryFigures f;
  f.ate_rmse_m = f.ate_pct_of_path = f.rpe_trans_rmse_m = f.rpe_rot_rmse_deg = kNaN;
  if (!summary.Has(key) || !summary[key].IsObject()) return f;
  const JsonValue& e = summary[key];
  f.present = true;
  f.ate_rmse_m = NumberOr(e, "ate_rmse", kNaN);
  f.ate_pct_of_path = NumberOr(e, "ate_rmse_pct_of_path", kNaN);
  f.rpe_trans_rmse_m = NumberOr(e, "rpe_trans_rmse", kNaN);
  f.rpe_rot_rmse_deg = NumberOr(e, "rpe_rot_rmse_deg", kNaN);
  return f;
}

// Why a parsed summary is incomplete ("" when complete).
std::string Incomplete(const JsonValue& summary) {
  if (!summary.IsObject()) return "summary.json is not a JSON object";
  if (summary.Has("error") && !summary["error"].IsNull()) {
    return summary["error"].IsString() ? summary["error"].AsString() : "summary.json has an error";
  }
  for (const char* key : {"frames", "fps", "mode"}) {
    if (!summary.Has(key)) return std::string("summary.json has no '") + key + "'";
  }
  const std::string mode = summary["mode"].IsString() ? summary["mode"].AsString() : "";
  for (const char* key : {"frontend", "windowed"}) {
    const bool needed = mode == "both" || mode == key;
    if (needed && !summary.Has(key)) {
      return std::string("summary.json of a run.mode ") + mode + " run has no '" + key + "'";
    }
  }
  return "";
}

std::string Fixed(double v, int decimals) {
  if (!std::isfinite(v)) return "-";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

// Plain decimals that read back exactly ("50.0", "0.013174010690989627"); "" when absent.
std::string CsvNumber(double v) { return std::isfinite(v) ? FormatConfigValue(v) : ""; }

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (const char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// Markdown cell text: '|' escaped, newlines as spaces.
std::string Cell(std::string s) {
  std::string out;
  for (const char c : s) {
    if (c == '|') {
      out += "\\|";
    } else {
      out += (c == '\n' || c == '\r') ? ' ' : c;
    }
  }
  return out;
}

void WriteFile(const std::string& path, const std::string& text, const std::string& what) {
  const auto parent = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  std::ofstream file(path);
  if (!file) throw InputError("cannot write " + what + " " + path);
  file << text;
  if (!file) throw InputError("error while writing " + what + " " + path);
}

std::string RankedTrajectory(const std::string& rank_by) {
  return rank_by == "auto" ? "windowed (else frontend)" : rank_by;
}

}  // namespace

bool ReadRunSummary(const std::string& summary_path, SweepRow* row) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(summary_path, ec)) {
    row->status = "missing";
    row->error = "no " + summary_path;
    return false;
  }
  JsonValue summary = JsonValue::Object();
  std::string why;
  try {
    summary = ParseJson(ReadText(summary_path), summary_path);
    why = Incomplete(summary);
  } catch (const InputError& e) {
    why = e.what();
  }
  row->status = why.empty() ? "ok" : "failed";
  row->error = why;
  row->frames = static_cast<int>(NumberOr(summary, "frames", 0));
  row->frames_lost = static_cast<int>(NumberOr(summary, "frames_lost", 0));
  row->fps = NumberOr(summary, "fps", kNaN);
  row->keyframes = summary.Has("keyframes")
                       ? static_cast<int>(NumberOr(summary["keyframes"], "count", 0))
                       : 0;
  double ms = kNaN;
  if (summary.Has("timing_ms") && summary["timing_ms"].Has("total_per_frame")) {
    ms = NumberOr(summary["timing_ms"]["total_per_frame"], "mean", kNaN);
  }
  if (!std::isfinite(ms) && std::isfinite(row->fps) && row->fps > 0) ms = 1000.0 / row->fps;
  row->ms_per_frame = ms;
  row->frontend = Figures(summary, "frontend");
  row->windowed = Figures(summary, "windowed");
  return true;
}

bool IsRunSummaryComplete(const std::string& summary_path, std::string* why) {
  std::string reason;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(summary_path, ec)) {
    reason = "no " + summary_path;
  } else {
    try {
      reason = Incomplete(ParseJson(ReadText(summary_path), summary_path));
    } catch (const InputError& e) {
      reason = e.what();
    }
  }
  if (why) *why = reason;
  return reason.empty();
}

void ScoreSweepRows(const std::string& rank_by, std::vector<SweepRow>* rows) {
  for (SweepRow& row : *rows) {
    row.score = kNaN;
    if (row.status != "ok") continue;
    const bool windowed = rank_by == "windowed" || (rank_by == "auto" && row.windowed.present);
    const SweepTrajectoryFigures& f = windowed ? row.windowed : row.frontend;
    if (f.present && std::isfinite(f.ate_rmse_m)) row.score = f.ate_rmse_m;
  }
}

std::vector<size_t> ParetoFront(const std::vector<double>& x, const std::vector<double>& y) {
  DFO_CHECK(x.size() == y.size()) << x.size() << " x values, " << y.size() << " y values";
  std::vector<size_t> order;
  for (size_t i = 0; i < x.size(); ++i) {
    if (std::isfinite(x[i]) && std::isfinite(y[i])) order.push_back(i);
  }
  // By x, then y, then index: walking in this order, a point is on the front exactly when its y
  // is below every y seen so far (the earlier points have lower or equal x).
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return x[a] != x[b] ? x[a] < x[b] : y[a] < y[b];
  });
  std::vector<size_t> front;
  double best_y = std::numeric_limits<double>::infinity();
  for (const size_t i : order) {
    if (y[i] < best_y) {
      front.push_back(i);
      best_y = y[i];
    }
  }
  return front;
}

std::vector<int> BestPerSequence(const std::vector<SweepRow>& rows,
                                 const std::vector<std::string>& sequences) {
  std::vector<int> best(sequences.size(), -1);
  for (size_t q = 0; q < sequences.size(); ++q) {
    for (size_t r = 0; r < rows.size(); ++r) {
      if (rows[r].sequence != sequences[q] || !std::isfinite(rows[r].score)) continue;
      if (best[q] < 0 || rows[r].score < rows[best[q]].score) best[q] = static_cast<int>(r);
    }
  }
  return best;
}

std::vector<SweepStanding> RankSettings(const std::vector<SweepRow>& rows,
                                        const std::vector<std::string>& settings,
                                        const std::vector<std::string>& sequences) {
  std::vector<SweepStanding> standings(settings.size());
  std::vector<double> relative_sum(settings.size(), 0.0);
  std::vector<double> log_sum(settings.size(), 0.0);
  for (size_t s = 0; s < settings.size(); ++s) standings[s].setting = settings[s];
  for (const std::string& sequence : sequences) {
    // Scores of this sequence per setting (NaN = no result).
    std::vector<double> score(settings.size(), kNaN);
    for (const SweepRow& row : rows) {
      if (row.sequence != sequence || !std::isfinite(row.score)) continue;
      const auto it = std::find(settings.begin(), settings.end(), row.setting);
      if (it != settings.end()) score[it - settings.begin()] = row.score;
    }
    double best = std::numeric_limits<double>::infinity();
    int scored = 0;
    for (const double v : score) {
      if (std::isfinite(v)) {
        best = std::min(best, v);
        ++scored;
      }
    }
    for (size_t s = 0; s < settings.size(); ++s) {
      int rank = scored + 1;  // no result: after every scored setting
      if (std::isfinite(score[s])) {
        rank = 1;
        for (const double v : score) rank += std::isfinite(v) && v < score[s];
        ++standings[s].sequences_ok;
        relative_sum[s] += best > 0 ? score[s] / best : 1.0;
        log_sum[s] += score[s] > 0 ? std::log(score[s]) : -std::numeric_limits<double>::infinity();
      }
      standings[s].mean_rank += rank;
    }
  }
  for (size_t s = 0; s < settings.size(); ++s) {
    standings[s].mean_rank /= std::max<size_t>(1, sequences.size());
    standings[s].mean_relative_ate =
        standings[s].sequences_ok > 0 ? relative_sum[s] / standings[s].sequences_ok : kNaN;
    standings[s].geometric_mean_ate =
        standings[s].sequences_ok > 0 ? std::exp(log_sum[s] / standings[s].sequences_ok) : kNaN;
  }
  std::stable_sort(standings.begin(), standings.end(),
                   [](const SweepStanding& a, const SweepStanding& b) {
                     if (a.mean_rank != b.mean_rank) return a.mean_rank < b.mean_rank;
                     const double ra = std::isfinite(a.mean_relative_ate) ? a.mean_relative_ate
                                                                          : 1e300;
                     const double rb = std::isfinite(b.mean_relative_ate) ? b.mean_relative_ate
                                                                          : 1e300;
                     return ra < rb;
                   });
  return standings;
}

void WriteSweepCsv(const std::string& path, const SweepTable& table) {
  std::ostringstream out;
  out << "sequence,setting";
  for (const std::string& key : table.swept_keys) out << "," << CsvField(key);
  out << ",status,frames,frames_lost,keyframes,ms_per_frame,fps"
         ",frontend_ate_rmse_m,frontend_ate_pct_of_path,frontend_rpe_trans_rmse_m,"
         "frontend_rpe_rot_rmse_deg,windowed_ate_rmse_m,windowed_ate_pct_of_path,"
         "windowed_rpe_trans_rmse_m,windowed_rpe_rot_rmse_deg,score_ate_rmse_m,output_dir,error\n";
  for (const SweepRow& row : table.rows) {
    out << CsvField(row.sequence) << "," << CsvField(row.setting);
    for (size_t k = 0; k < table.swept_keys.size(); ++k) {
      out << "," << CsvField(k < row.values.size() ? row.values[k] : "");
    }
    const bool ok = row.status == "ok";
    out << "," << row.status << "," << (ok ? std::to_string(row.frames) : "") << ","
        << (ok ? std::to_string(row.frames_lost) : "") << ","
        << (ok ? std::to_string(row.keyframes) : "") << ","
        << CsvNumber(ok ? row.ms_per_frame : kNaN) << "," << CsvNumber(ok ? row.fps : kNaN);
    for (const SweepTrajectoryFigures* f : {&row.frontend, &row.windowed}) {
      const bool has = ok && f->present;
      for (const double v :
           {f->ate_rmse_m, f->ate_pct_of_path, f->rpe_trans_rmse_m, f->rpe_rot_rmse_deg}) {
        out << "," << CsvNumber(has ? v : kNaN);
      }
    }
    out << "," << CsvNumber(row.score) << "," << CsvField(row.output_dir) << ","
        << CsvField(row.error) << "\n";
  }
  WriteFile(path, out.str(), "sweep CSV");
}

std::string SweepMarkdown(const SweepTable& table) {
  std::ostringstream md;
  const auto setting_number = [&](const std::string& label) {
    const auto it = std::find(table.settings.begin(), table.settings.end(), label);
    return it == table.settings.end() ? std::string("?")
                                      : "#" + std::to_string(it - table.settings.begin() + 1);
  };
  md << "| # | setting | sequence | status | frontend ATE [m] | frontend RPE [m/frame] "
        "| windowed ATE [m] | windowed RPE [m/frame] | keyframes | ms/frame |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const SweepRow& row : table.rows) {
    const bool ok = row.status == "ok";
    const auto figure = [&](const SweepTrajectoryFigures& f, double v, int decimals) {
      return ok && f.present ? Fixed(v, decimals) : std::string("-");
    };
    md << "| " << setting_number(row.setting) << " | " << Cell(row.setting) << " | "
       << Cell(row.sequence) << " | " << row.status << " | "
       << figure(row.frontend, row.frontend.ate_rmse_m, 4) << " | "
       << figure(row.frontend, row.frontend.rpe_trans_rmse_m, 4) << " | "
       << figure(row.windowed, row.windowed.ate_rmse_m, 4) << " | "
       << figure(row.windowed, row.windowed.rpe_trans_rmse_m, 4) << " | "
       << (ok ? std::to_string(row.keyframes) : "-") << " | "
       << (ok ? Fixed(row.ms_per_frame, 1) : "-") << " |\n";
  }
  md << "\nATE: Sim3-aligned ATE rmse; RPE: translation rmse between consecutive frames; "
        "ms/frame: mean time per frame of the whole run (loading, frontend, window).\n";

  md << "\n**Best setting per sequence** (lowest " << RankedTrajectory(table.rank_by)
     << " ATE):\n\n";
  const std::vector<int> best = BestPerSequence(table.rows, table.sequences);
  for (size_t q = 0; q < table.sequences.size(); ++q) {
    md << "- " << Cell(table.sequences[q]) << ": ";
    if (best[q] < 0) {
      md << "no successful run\n";
    } else {
      const SweepRow& row = table.rows[best[q]];
      md << setting_number(row.setting) << " " << Cell(row.setting) << " (ATE "
         << Fixed(row.score, 4) << " m, " << Fixed(row.ms_per_frame, 1) << " ms/frame)\n";
    }
  }

  md << "\n**Overall**: settings by mean rank across the " << table.sequences.size()
     << " sequence(s) (rank 1 = lowest ATE on that sequence; no result = last); ties broken by "
        "the mean relative ATE (ATE / best ATE on the sequence). Geometric mean ATE: over the "
        "sequences the setting has a result on.\n\n"
     << "| place | # | setting | mean rank | mean relative ATE | geometric mean ATE [m] | "
        "sequences ok |\n"
     << "|---|---|---|---|---|---|---|\n";
  const std::vector<SweepStanding> standings =
      RankSettings(table.rows, table.settings, table.sequences);
  for (size_t i = 0; i < standings.size(); ++i) {
    const SweepStanding& s = standings[i];
    md << "| " << i + 1 << " | " << setting_number(s.setting) << " | " << Cell(s.setting) << " | "
       << Fixed(s.mean_rank, 2) << " | " << Fixed(s.mean_relative_ate, 3) << " | "
       << Fixed(s.geometric_mean_ate, 4) << " | " << s.sequences_ok << "/"
       << table.sequences.size() << " |\n";
  }

  std::ostringstream problems;
  for (const SweepRow& row : table.rows) {
    if (row.status == "ok") continue;
    problems << "- " << Cell(row.sequence) << " / " << Cell(row.setting) << ": " << row.status
             << " (" << Cell(row.error) << ")\n";
  }
  if (!problems.str().empty()) md << "\n**Failed or missing runs**:\n\n" << problems.str();
  return md.str();
}

void WriteSweepMarkdown(const std::string& path, const SweepTable& table) {
  WriteFile(path, SweepMarkdown(table), "sweep Markdown table");
}

void WriteSweepParetoPlot(const std::string& path, const SweepTable& table) {
  std::vector<ScatterSeries> series;
  for (const std::string& sequence : table.sequences) {
    ScatterSeries s;
    s.name = sequence;
    for (const SweepRow& row : table.rows) {
      if (row.sequence != sequence || !std::isfinite(row.score)) continue;
      s.x.push_back(row.ms_per_frame);
      s.y.push_back(row.score);
      const auto it = std::find(table.settings.begin(), table.settings.end(), row.setting);
      s.labels.push_back("#" + std::to_string(it - table.settings.begin() + 1));
    }
    s.front = ParetoFront(s.x, s.y);
    if (!s.x.empty()) series.push_back(std::move(s));
  }
  if (series.empty()) {
    throw InputError("sweep plot " + path + ": no successful run with an ATE to draw");
  }
  ScatterPlotOptions options;
  options.title = "Accuracy against speed (ringed and joined: Pareto front per sequence)";
  options.x_label = "ms per frame (whole run)";
  options.y_label = "ATE rmse [m], " + RankedTrajectory(table.rank_by);
  options.log_y = true;
  for (size_t s = 0; s < table.settings.size() && s < 24; ++s) {
    options.notes.push_back("#" + std::to_string(s + 1) + " " + table.settings[s]);
  }
  if (table.settings.size() > 24) options.notes.push_back("... (see results.md)");
  options.height = 600 + 17 * static_cast<int>(options.notes.size());
  WriteScatterPlot(path, series, options);
}

}  // namespace dfo::io
