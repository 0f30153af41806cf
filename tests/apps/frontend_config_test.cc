// The configuration sections frontend / tracker / reference against the frontend's structs: the
// schema in dfo_io cannot see FrontendOptions, so these tests keep the two in step.
#include "apps/common/frontend_config.h"

#include <gtest/gtest.h>

#include <string>

#include "dfo_core/error.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

TEST(FrontendConfig, SchemaDefaultsEqualFrontendOptionsDefaults) {
  const io::Config config(io::DfoSchema());
  const FrontendOptions from_config = apps::FrontendOptionsFromConfig(config);
  const FrontendOptions d;
  EXPECT_EQ(from_config.features, d.features);
  EXPECT_EQ(from_config.depth, d.depth);
  EXPECT_EQ(from_config.handmade.descriptor, d.handmade.descriptor);
  EXPECT_EQ(from_config.handmade.blur_sigma_px, d.handmade.blur_sigma_px);

  const TrackerOptions& t = from_config.tracker;
  EXPECT_EQ(t.num_levels, d.tracker.num_levels);
  EXPECT_EQ(t.patch_size, d.tracker.patch_size);
  EXPECT_EQ(t.max_points, d.tracker.max_points);
  EXPECT_EQ(t.min_cell_px, d.tracker.min_cell_px);
  EXPECT_EQ(t.min_gradient, d.tracker.min_gradient);
  EXPECT_EQ(t.max_patch_depth_ratio, d.tracker.max_patch_depth_ratio);
  EXPECT_EQ(t.max_iterations, d.tracker.max_iterations);
  EXPECT_EQ(t.convergence_threshold, d.tracker.convergence_threshold);
  EXPECT_EQ(t.outlier_rule, d.tracker.outlier_rule);
  EXPECT_EQ(t.rotation_hypotheses_deg, d.tracker.rotation_hypotheses_deg);
  EXPECT_EQ(t.hypothesis_abandon_ratio, d.tracker.hypothesis_abandon_ratio);
  EXPECT_EQ(t.good_enough_rmse, d.tracker.good_enough_rmse);
  EXPECT_EQ(t.min_inliers_ok, d.tracker.min_inliers_ok);
  EXPECT_EQ(t.min_inlier_ratio_ok, d.tracker.min_inlier_ratio_ok);
  EXPECT_EQ(t.max_rmse_ok, d.tracker.max_rmse_ok);
  EXPECT_EQ(t.min_inliers_lost, d.tracker.min_inliers_lost);
  EXPECT_EQ(t.max_rmse_lost, d.tracker.max_rmse_lost);

  const ReferenceOptions& r = from_config.reference;
  EXPECT_EQ(r.translation_ratio, d.reference.translation_ratio);
  EXPECT_EQ(r.rotation_deg, d.reference.rotation_deg);
  EXPECT_EQ(r.min_inlier_ratio, d.reference.min_inlier_ratio);
  EXPECT_EQ(r.max_interval, d.reference.max_interval);

  // The one deliberate difference: the thread count is the program-wide run.threads (default 2,
  // the machine class dfo targets), not a second frontend key.
  EXPECT_EQ(from_config.num_threads, config.GetInt("run.threads"));
}

// Every key of the three sections reaches its field (a key read into the wrong field, or not read
// at all, fails here).
TEST(FrontendConfig, EveryKeyReachesItsField) {
  const io::Config config = io::LoadConfigFromString(
      "frontend:\n"
      "  handmade_descriptor: rich\n"
      "  handmade_blur_sigma_px: 0.75\n"
      "tracker:\n"
      "  num_levels: 3\n"
      "  patch_size: 5\n"
      "  max_points: 321\n"
      "  min_cell_px: 3\n"
      "  min_gradient: 0.125\n"
      "  max_patch_depth_ratio: 1.5\n"
      "  max_iterations: [4, 5, 6]\n"
      "  convergence_threshold: [0.001, 0.002]\n"
      "  outlier_rule: false\n"
      "  rotation_hypotheses_deg: 2.5\n"
      "  hypothesis_abandon_ratio: 1.75\n"
      "  good_enough_rmse: 0.0\n"
      "  min_inliers_ok: 90\n"
      "  min_inlier_ratio_ok: 0.4\n"
      "  max_rmse_ok: 0.45\n"
      "  min_inliers_lost: 20\n"
      "  max_rmse_lost: 0.9\n"
      "reference:\n"
      "  translation_ratio: 0.3\n"
      "  rotation_deg: 7.5\n"
      "  min_inlier_ratio: 0.55\n"
      "  max_interval: 4\n"
      "run:\n"
      "  threads: 3\n",
      "all.yaml", io::DfoSchema());
  const FrontendOptions o = apps::FrontendOptionsFromConfig(config);
  EXPECT_EQ(o.handmade.descriptor, "rich");
  EXPECT_EQ(o.handmade.blur_sigma_px, 0.75);
  EXPECT_EQ(o.tracker.num_levels, 3);
  EXPECT_EQ(o.tracker.patch_size, 5);
  EXPECT_EQ(o.tracker.max_points, 321);
  EXPECT_EQ(o.tracker.min_cell_px, 3);
  EXPECT_EQ(o.tracker.min_gradient, 0.125);
  EXPECT_EQ(o.tracker.max_patch_depth_ratio, 1.5);
  EXPECT_EQ(o.tracker.max_iterations, (std::vector<int>{4, 5, 6}));
  EXPECT_EQ(o.tracker.convergence_threshold, (std::vector<double>{0.001, 0.002}));
  EXPECT_FALSE(o.tracker.outlier_rule);
  EXPECT_EQ(o.tracker.rotation_hypotheses_deg, 2.5);
  EXPECT_EQ(o.tracker.hypothesis_abandon_ratio, 1.75);
  EXPECT_EQ(o.tracker.good_enough_rmse, 0.0);
  EXPECT_EQ(o.tracker.min_inliers_ok, 90);
  EXPECT_EQ(o.tracker.min_inlier_ratio_ok, 0.4);
  EXPECT_EQ(o.tracker.max_rmse_ok, 0.45);
  EXPECT_EQ(o.tracker.min_inliers_lost, 20);
  EXPECT_EQ(o.tracker.max_rmse_lost, 0.9);
  EXPECT_EQ(o.reference.translation_ratio, 0.3);
  EXPECT_EQ(o.reference.rotation_deg, 7.5);
  EXPECT_EQ(o.reference.min_inlier_ratio, 0.55);
  EXPECT_EQ(o.reference.max_interval, 4);
  EXPECT_EQ(o.num_threads, 3);
}

TEST(FrontendConfig, RulesOutsideTheSchemaAreConfigErrors) {
  // An even patch size passes the schema's range [1, 7] but not TrackerOptions::Check.
  const io::Config even =
      io::LoadConfigFromString("tracker:\n  patch_size: 4\n", "even.yaml", io::DfoSchema());
  try {
    apps::FrontendOptionsFromConfig(even);
    FAIL() << "no ConfigError for an even patch size";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("patch_size"), std::string::npos) << e.what();
  }
}

TEST(FrontendConfig, ThreadsZeroMeansHardwareThreads) {
  const io::Config config =
      io::LoadConfigFromString("run:\n  threads: 0\n", "t.yaml", io::DfoSchema());
  EXPECT_GE(apps::ThreadsFromConfig(config), 1);
  EXPECT_EQ(apps::FrontendOptionsFromConfig(config).num_threads, apps::ThreadsFromConfig(config));
}

TEST(FrontendConfig, EveryShippedConfigGivesValidFrontendOptions) {
  for (const char* name :
       {"default.yaml", "demo.yaml", "demo_learned.yaml", "kitti.yaml", "tum.yaml"}) {
    SCOPED_TRACE(name);
    const io::Config config =
        io::LoadConfig(test::SourceDir() + "/configs/" + name, io::DfoSchema());
    EXPECT_NO_THROW(apps::FrontendOptionsFromConfig(config));
  }
}

}  // namespace
}  // namespace dfo
