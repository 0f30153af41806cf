// Sweep results: reading run summaries, scoring, the Pareto front on known points, per-sequence
// best and overall ranking, and the CSV / Markdown / PNG files.
#include "dfo_io/sweep_results.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include "dfo_io/image_io.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string Read(const std::string& path) {
  std::ifstream file(path);
  std::stringstream buffer;
  buffer << file.rdbuf();
  return buffer.str();
}

constexpr const char* kSummary = R"({
  "mode": "both", "frames": 30, "frames_lost": 1, "fps": 20.0,
  "frontend": {"ate_rmse": 0.5, "ate_rmse_pct_of_path": 1.5, "rpe_trans_rmse": 0.05,
               "rpe_rot_rmse_deg": 0.2},
  "windowed": {"ate_rmse": 0.25, "ate_rmse_pct_of_path": 0.75, "rpe_trans_rmse": 0.04,
               "rpe_rot_rmse_deg": 0.1},
  "keyframes": {"count": 7},
  "timing_ms": {"total_per_frame": {"median": 10.0, "mean": 42.0}}
})";

TEST(SweepResults, ReadsTheFiguresOfASummary) {
  const std::string dir = test::MakeTempDir("sweep_summary");
  SweepRow row;
  ASSERT_TRUE(ReadRunSummary(Write(dir, "s.json", kSummary), &row));
  EXPECT_EQ(row.status, "ok");
  EXPECT_EQ(row.frames, 30);
  EXPECT_EQ(row.frames_lost, 1);
  EXPECT_EQ(row.keyframes, 7);
  EXPECT_DOUBLE_EQ(row.ms_per_frame, 42.0);
  EXPECT_DOUBLE_EQ(row.frontend.ate_rmse_m, 0.5);
  EXPECT_DOUBLE_EQ(row.windowed.rpe_trans_rmse_m, 0.04);
  EXPECT_TRUE(IsRunSummaryComplete(dir + "/s.json"));

  // Incomplete or failed summaries.
  std::string why;
  EXPECT_FALSE(IsRunSummaryComplete(dir + "/none.json", &why));
  EXPECT_NE(why.find("no "), std::string::npos);
  Write(dir, "err.json", R"({"mode": "frontend", "frames": 3, "fps": 1, "frontend": {},
                             "error": "unreadable image 000004.png"})");
  EXPECT_FALSE(IsRunSummaryComplete(dir + "/err.json", &why));
  EXPECT_EQ(why, "unreadable image 000004.png");
  SweepRow failed;
  ASSERT_TRUE(ReadRunSummary(dir + "/err.json", &failed));
  EXPECT_EQ(failed.status, "failed");
  Write(dir, "nowin.json", R"({"mode": "both", "frames": 3, "fps": 1, "frontend": {}})");
  EXPECT_FALSE(IsRunSummaryComplete(dir + "/nowin.json", &why));
  EXPECT_NE(why.find("'windowed'"), std::string::npos) << why;
  Write(dir, "cut.json", R"({"mode": "both", "fra)");
  EXPECT_FALSE(IsRunSummaryComplete(dir + "/cut.json", &why));
  SweepRow missing;
  EXPECT_FALSE(ReadRunSummary(dir + "/none.json", &missing));
  EXPECT_EQ(missing.status, "missing");
}

TEST(SweepResults, ParetoFrontOfKnownPoints) {
  //  y
  //  5 a
  //  4     b         e
  //  3           c
  //  2       d           f
  //  1                       g
  //    1   2 3   4   5   6   7  x
  const std::vector<double> x = {1, 2, 4, 3, 5, 6, 7, NAN, 0.5};
  const std::vector<double> y = {5, 4, 3, 2, 4, 2, 1, 0.1, NAN};
  // a (1,5), b (2,4), d (3,2), g (7,1); c, e, f are dominated by d; NaN points never count.
  EXPECT_EQ(ParetoFront(x, y), (std::vector<size_t>{0, 1, 3, 6}));
  // Equal points: the first is kept; equal x: the lower y only.
  EXPECT_EQ(ParetoFront({1, 1, 1}, {2, 2, 1}), (std::vector<size_t>{2}));
  EXPECT_EQ(ParetoFront({1, 1}, {2, 2}), (std::vector<size_t>{0}));
  EXPECT_TRUE(ParetoFront({}, {}).empty());
}

SweepRow Row(const std::string& sequence, const std::string& setting, double windowed_ate,
             double ms) {
  SweepRow r;
  r.sequence = sequence;
  r.setting = setting;
  r.values = {setting.substr(2)};
  r.status = std::isfinite(windowed_ate) ? "ok" : "failed";
  r.error = std::isfinite(windowed_ate) ? "" : "dfo_run exited with status 1: boom";
  r.frames = 10;
  r.keyframes = 3;
  r.ms_per_frame = ms;
  r.frontend = {true, 2.0 * windowed_ate, 1.0, 0.1, 0.01};
  r.windowed = {true, windowed_ate, 1.0, 0.1, 0.01};
  return r;
}

SweepTable Table() {
  SweepTable t;
  t.swept_keys = {"keyframe.translation_ratio"};
  t.settings = {"r=0.05", "r=0.1", "r=0.2"};
  t.sequences = {"synthetic", "kitti"};
  t.rows = {Row("synthetic", "r=0.05", 0.3, 50), Row("kitti", "r=0.05", 2.0, 60),
            Row("synthetic", "r=0.1", 0.2, 40),  Row("kitti", "r=0.1", NAN, 0),
            Row("synthetic", "r=0.2", 0.6, 20),  Row("kitti", "r=0.2", 1.0, 30)};
  ScoreSweepRows(t.rank_by, &t.rows);
  return t;
}

TEST(SweepResults, BestPerSequenceAndOverallRanking) {
  const SweepTable t = Table();
  EXPECT_DOUBLE_EQ(t.rows[0].score, 0.3);  // auto: windowed
  EXPECT_TRUE(std::isnan(t.rows[3].score));
  EXPECT_EQ(BestPerSequence(t.rows, t.sequences), (std::vector<int>{2, 5}));
  const std::vector<SweepStanding> s = RankSettings(t.rows, t.settings, t.sequences);
  ASSERT_EQ(s.size(), 3u);
  // synthetic ranks: r=0.1 1, r=0.05 2, r=0.2 3; kitti: r=0.2 1, r=0.05 2, r=0.1 none -> 3.
  // Mean ranks: r=0.05 2.0, r=0.1 2.0, r=0.2 2.0: all tied, so the mean relative ATE decides:
  // r=0.05 (1.5 + 2) / 2 = 1.75, r=0.1 1.0 (one sequence), r=0.2 (3 + 1) / 2 = 2.
  EXPECT_EQ(s[0].setting, "r=0.1");
  EXPECT_DOUBLE_EQ(s[0].mean_rank, 2.0);
  EXPECT_DOUBLE_EQ(s[0].mean_relative_ate, 1.0);
  EXPECT_EQ(s[0].sequences_ok, 1);
  EXPECT_EQ(s[1].setting, "r=0.05");
  EXPECT_DOUBLE_EQ(s[1].mean_relative_ate, 1.75);
  EXPECT_EQ(s[2].setting, "r=0.2");
  // Geometric mean ATE over the sequences with a result: r=0.1 0.2 (one sequence), r=0.05
  // sqrt(0.3 * 2.0), r=0.2 sqrt(0.6 * 1.0).
  EXPECT_NEAR(s[0].geometric_mean_ate, 0.2, 1e-12);
  EXPECT_NEAR(s[1].geometric_mean_ate, std::sqrt(0.6), 1e-12);
  EXPECT_NEAR(s[2].geometric_mean_ate, std::sqrt(0.6), 1e-12);

  // Ranked by the frontend trajectory the scores double; the order is the same here.
  SweepTable f = Table();
  ScoreSweepRows("frontend", &f.rows);
  EXPECT_DOUBLE_EQ(f.rows[0].score, 0.6);
}

TEST(SweepResults, CsvAndMarkdownContent) {
  const std::string dir = test::MakeTempDir("sweep_files");
  const SweepTable t = Table();
  WriteSweepCsv(dir + "/results.csv", t);
  std::istringstream csv(Read(dir + "/results.csv"));
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("sequence,setting,keyframe.translation_ratio,status,frames,", 0), 0u)
      << header;
  EXPECT_NE(header.find("frontend_ate_rmse_m"), std::string::npos);
  EXPECT_NE(header.find("windowed_rpe_trans_rmse_m"), std::string::npos);
  EXPECT_NE(header.find("ms_per_frame"), std::string::npos);
  std::getline(csv, line);
  EXPECT_EQ(line.rfind("synthetic,r=0.05,0.05,ok,10,0,3,50.0,", 0), 0u) << line;
  EXPECT_NE(line.find(",0.6,"), std::string::npos) << line;  // frontend ATE
  int lines = 1;
  std::string failed_line;
  while (std::getline(csv, line)) {
    ++lines;
    if (line.find("failed") != std::string::npos) failed_line = line;
  }
  EXPECT_EQ(lines, 6);
  EXPECT_NE(failed_line.find("dfo_run exited with status 1: boom"), std::string::npos);

  const std::string md = SweepMarkdown(t);
  EXPECT_NE(md.find("| #1 | r=0.05 | synthetic | ok | 0.6000 | 0.1000 | 0.3000 | 0.1000 | 3 | "
                    "50.0 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| #2 | r=0.1 | kitti | failed | - |"), std::string::npos) << md;
  EXPECT_NE(md.find("- synthetic: #2 r=0.1 (ATE 0.2000 m, 40.0 ms/frame)"), std::string::npos)
      << md;
  EXPECT_NE(md.find("- kitti: #3 r=0.2"), std::string::npos) << md;
  EXPECT_NE(md.find("mean rank across the 2 sequence(s)"), std::string::npos);
  EXPECT_NE(md.find("| 1 | #2 | r=0.1 | 2.00 | 1.000 | 0.2000 | 1/2 |"), std::string::npos) << md;
  EXPECT_NE(md.find("- kitti / r=0.1: failed (dfo_run exited with status 1: boom)"),
            std::string::npos)
      << md;

  WriteSweepParetoPlot(dir + "/pareto.png", t);
  const ImageU8 image = ReadRgb(dir + "/pareto.png");
  EXPECT_GT(image.width(), 0);
  SweepTable empty = t;
  for (SweepRow& r : empty.rows) r.score = NAN;
  EXPECT_THROW(WriteSweepParetoPlot(dir + "/none.png", empty), InputError);
}

}  // namespace
}  // namespace dfo::io
