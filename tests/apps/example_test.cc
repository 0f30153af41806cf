// The "use dfo from your own program" example (apps/example/odometry_example.cc, README): runs
// the built dfo_example on a short synthetic image folder with the committed default model and
// checks that it prints a pose for every frame that follows the true path; then installs this
// build into a fresh prefix and does the same with the example built against the installed
// package (find_package(dfo)) and its installed default model.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_core/trajectory.h"
#include "dfo_core/trajectory_evaluation.h"
#include "dfo_io/synth_writer.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

// Runs `command` (the example and its environment) on a 40-frame synthetic image folder with
// `model_arg` ("" = the example's default model) and checks that it prints a pose for every
// frame, none lost, along the true path.
void ExpectPosesAlongTheTruePath(const std::string& command, const std::string& model_arg,
                                 const std::string& tag) {
  SyntheticOptions synth;
  synth.seed = 1;  // held out of training
  synth.num_frames = 40;
  const SyntheticSequence sequence(synth);
  const std::string root = test::MakeTempDir(tag);
  io::SynthWriteOptions write;
  write.output_dir = root;
  write.write_rgb = false;
  write.write_depth = false;
  io::WriteSyntheticSequence(sequence, write);

  const PinholeCamera& c = sequence.camera();
  std::ostringstream args;
  args.precision(17);
  args << root << "/sequences/00/image_0 " << c.fx << " " << c.fy << " " << c.cx << " " << c.cy
       << " " << model_arg;
  const test::CommandResult r = test::RunCommand(command, args.str());
  ASSERT_EQ(r.status, 0) << r.err;

  Trajectory estimate, truth;
  std::istringstream lines(r.out);
  std::string line;
  int lost = 0;
  while (std::getline(lines, line)) {
    std::istringstream in(line);
    int index = -1;
    std::string status;
    double t[3], q[4];
    ASSERT_TRUE(in >> index >> status >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3])
        << line;
    ASSERT_EQ(index, static_cast<int>(estimate.size())) << line;
    lost += status == "lost" ? 1 : 0;
    const SE3d pose(Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized(),
                    Eigen::Vector3d(t[0], t[1], t[2]));
    ASSERT_TRUE(pose.translation().allFinite()) << line;
    estimate.Add(index, pose);
    truth.Add(index, sequence.WorldFromCam(index));
  }
  ASSERT_EQ(estimate.size(), static_cast<size_t>(synth.num_frames)) << r.out << r.err;
  EXPECT_EQ(lost, 0) << r.out;
  TrajectoryEvaluationOptions sim3;
  sim3.alignment = AlignmentType::kSim3;
  const TrajectoryEvaluation e = EvaluateTrajectory(truth, estimate, sim3);
  // The example runs the library with its defaults; its path must follow the true one (a
  // standing still or reversed estimate leaves an ATE near the path's own spread).
  EXPECT_LT(e.ate.stats.rmse, 0.1 * e.gt_path_length_m)
      << "Sim3 ATE " << e.ate.stats.rmse << " m over " << e.gt_path_length_m << " m";
  std::printf("[ figures  ] %s: %zu frames, Sim3 ATE %.3f m over %.1f m\n", tag.c_str(),
              estimate.size(), e.ate.stats.rmse, e.gt_path_length_m);
}

#ifdef DFO_EXAMPLE_EXE
TEST(OdometryExample, PrintsAPoseForEveryFrameAlongTheTruePath) {
  ExpectPosesAlongTheTruePath(DFO_EXAMPLE_EXE, test::SourceDir() + "/models/default.dfo",
                              "odometry_example");
}
#endif

#if defined(DFO_CMAKE_COMMAND) && defined(DFO_CXX_COMPILER)
// The quoted #include lines of every installed header that name no installed file.
std::vector<std::string> UnresolvedIncludes(const std::filesystem::path& include_dir) {
  std::vector<std::string> missing;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(include_dir)) {
    if (!entry.is_regular_file()) continue;
    std::ifstream in(entry.path());
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("#include \"", 0) != 0) continue;
      const std::string name = line.substr(10, line.find('"', 10) - 10);
      if (!std::filesystem::exists(include_dir / name) &&
          !std::filesystem::exists(include_dir / "lcm_types" / name)) {
        missing.push_back(entry.path().string() + ": " + name);
      }
    }
  }
  return missing;
}

// `cmake --install` of this build into a fresh prefix, then apps/example as a project of its own
// (find_package(dfo)) built against it and run with the installed default model.
TEST(InstalledPackage, TheExampleBuildsAgainstItAndFindsTheInstalledModel) {
  const std::filesystem::path work = test::MakeTempDir("installed_package");
  const std::filesystem::path prefix = work / "prefix";
  const std::string cmake = DFO_CMAKE_COMMAND;
  test::CommandResult r = test::RunCommand(
      cmake, std::string("--install ") + DFO_BINARY_DIR + " --prefix " + prefix.string());
  ASSERT_EQ(r.status, 0) << r.out << r.err;

  const std::filesystem::path include_dir = prefix / "include" / "dfo";
  EXPECT_TRUE(std::filesystem::is_regular_file(include_dir / "dfo_backend" / "odometry.h"));
  EXPECT_TRUE(std::filesystem::is_regular_file(include_dir / "dfo_frontend" / "learned" /
                                               "learned_sources.h"));
  EXPECT_FALSE(std::filesystem::exists(include_dir / "dfo_frontend" / "learned" / "internal"))
      << "internal headers were installed";
  const std::vector<std::string> missing = UnresolvedIncludes(include_dir);
  EXPECT_TRUE(missing.empty()) << "installed headers include files that were not installed: "
                               << missing.front();
  const std::filesystem::path models = prefix / "share" / "dfo" / "models";
  ASSERT_TRUE(std::filesystem::is_regular_file(models / "default.dfo"));
  EXPECT_TRUE(std::filesystem::is_regular_file(prefix / "lib" / "cmake" / "dfo" /
                                               "dfoConfigVersion.cmake"));

  const std::filesystem::path build = work / "example_build";
  std::string configure = "-S " + test::SourceDir() + "/apps/example -B " + build.string() +
                          " -DCMAKE_PREFIX_PATH=" + prefix.string() +
                          " -DCMAKE_CXX_COMPILER=" + DFO_CXX_COMPILER;
#ifdef DFO_CCACHE
  configure += std::string(" -DCMAKE_CXX_COMPILER_LAUNCHER=") + DFO_CCACHE;
#endif
  r = test::RunCommand(cmake, configure);
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  r = test::RunCommand(cmake, "--build " + build.string());
  ASSERT_EQ(r.status, 0) << r.out << r.err;

  // No MODEL argument: dfo::DefaultModelPath(), here the installed copy.
  ExpectPosesAlongTheTruePath(
      "DFO_MODEL_DIR=" + models.string() + " " + (build / "dfo_example").string(), "",
      "installed_example");
}
#endif

}  // namespace
}  // namespace dfo
