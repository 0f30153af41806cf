// Results of a dfo_sweep: one row per run read from its summary.json, the ranking of settings,
// the accuracy / speed Pareto front, and the files: results.csv, results.md and pareto.png.
//
// Ranking. Each run is scored by the Sim3 ATE rmse of one trajectory: windowed or frontend
// (SweepRankBy; auto = windowed when the run has it). Per sequence the best setting is the one
// with the lowest score. Overall, settings are ranked by their mean rank across sequences (rank 1
// = best on that sequence, ties share the lower rank; a setting without a result on a sequence
// gets that sequence's last rank + 1); ties in mean rank are broken by the mean relative ATE
// (score / best score of that sequence).
#ifndef DFO_IO_SWEEP_RESULTS_H_
#define DFO_IO_SWEEP_RESULTS_H_

#include <string>
#include <vector>

namespace dfo::io {

// Figures of one trajectory (frontend-only or windowed) of a run; NaN where absent.
struct SweepTrajectoryFigures {
  bool present = false;  // the summary has this trajectory's evaluation
  double ate_rmse_m = 0.0;         // Sim3-aligned ATE rmse
  double ate_pct_of_path = 0.0;    // the same in % of the ground-truth path length
  double rpe_trans_rmse_m = 0.0;   // RPE per frame, translation rmse
  double rpe_rot_rmse_deg = 0.0;   // RPE per frame, rotation rmse
};

// One run of the sweep.
struct SweepRow {
  std::string sequence;
  std::string setting;                  // label, e.g. "translation_ratio=0.05, max_keyframes=5"
  std::vector<std::string> values;      // value of each swept key ("" = not set by the setting)
  std::string status = "missing";       // ok | failed | missing
  std::string error;                    // why it failed or is missing (one line)
  std::string output_dir;
  int frames = 0;
  int frames_lost = 0;
  int keyframes = 0;
  double ms_per_frame = 0.0;  // mean of timing_ms.total_per_frame (backend included), else 1000/fps
  double fps = 0.0;
  SweepTrajectoryFigures frontend;
  SweepTrajectoryFigures windowed;
  double score = 0.0;  // ranking ATE (see SweepRank), NaN when not ok
};

// Fills the figures of `row` from a dfo_run summary.json and sets status "ok"; a summary with an
// "error" member, without frames or fps, or not valid JSON, is "failed" with the reason in
// row->error. Returns false (status "missing", reason set) when the file does not exist.
bool ReadRunSummary(const std::string& summary_path, SweepRow* row);

// Whether a summary.json is present and complete: it parses, has "frames", "fps" and the
// evaluations of its mode, and no "error". `why` (optional) receives the reason when not.
bool IsRunSummaryComplete(const std::string& summary_path, std::string* why = nullptr);

// Which trajectory's ATE ranks the settings: "auto", "frontend" or "windowed".
// Sets each row's score (NaN for rows not ok or without that trajectory).
void ScoreSweepRows(const std::string& rank_by, std::vector<SweepRow>* rows);

// Indices of the points not dominated by another (lower or equal in both x and y, lower in one);
// both are costs to minimise (e.g. ms per frame and ATE). Non-finite points are never on the
// front. Sorted by increasing x; of points equal in both, the first is kept.
std::vector<size_t> ParetoFront(const std::vector<double>& x, const std::vector<double>& y);

// A setting's overall standing.
struct SweepStanding {
  std::string setting;
  double mean_rank = 0.0;
  double mean_relative_ate = 0.0;  // mean of score / best score on each sequence (NaN if none)
  // Geometric mean of the score (ATE, m) over the sequences with a result (NaN if none): the
  // figure to compare settings by over many similar sequences (not used for the ranking).
  double geometric_mean_ate = 0.0;
  int sequences_ok = 0;            // sequences with a scored result
};

// Best row per sequence (index into rows, -1 when no row of that sequence is scored), in the
// order of `sequences`.
std::vector<int> BestPerSequence(const std::vector<SweepRow>& rows,
                                 const std::vector<std::string>& sequences);

// Settings ordered best first (see the file comment), `settings` in sweep order.
std::vector<SweepStanding> RankSettings(const std::vector<SweepRow>& rows,
                                        const std::vector<std::string>& settings,
                                        const std::vector<std::string>& sequences);

// Everything the result files need.
struct SweepTable {
  std::vector<std::string> swept_keys;  // one CSV column each
  std::vector<std::string> settings;    // labels, sweep order
  std::vector<std::string> sequences;   // names, sweep order
  std::string rank_by = "auto";
  std::vector<SweepRow> rows;           // scored (ScoreSweepRows)
};

// CSV: a header, then one line per row (RFC 4180 quoting); numbers with full precision, empty
// where absent. Throws InputError when the file cannot be written.
void WriteSweepCsv(const std::string& path, const SweepTable& table);

// Markdown: the table of every run, the best setting per sequence, the overall ranking with how it
// is computed, and the runs that failed or are missing with their reason.
std::string SweepMarkdown(const SweepTable& table);
void WriteSweepMarkdown(const std::string& path, const SweepTable& table);

// Accuracy (score, y) against speed (ms per frame, x): one colour per sequence, each sequence's
// Pareto front joined and ringed, points labelled by setting number (#1 = first setting).
// Throws InputError when no row is scored or the file cannot be written.
void WriteSweepParetoPlot(const std::string& path, const SweepTable& table);

}  // namespace dfo::io

#endif  // DFO_IO_SWEEP_RESULTS_H_
