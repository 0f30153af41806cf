// The configuration sections keyframe / window / backend and run.mode against the backend's
// structs: the schema in dfo_io cannot see them, so these tests keep the two in step.
#include "apps/common/backend_config.h"

#include <gtest/gtest.h>

#include <string>

#include "dfo_core/error.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"
#include "tests/support/test_support.h"

namespace dfo {
namespace {

TEST(BackendConfig, SchemaDefaultsEqualKeyframeOptionsDefaults) {
  const io::Config config(io::DfoSchema());
  const KeyframeOptions k = apps::KeyframeOptionsFromConfig(config);
  const KeyframeOptions d;
  EXPECT_EQ(k.translation_ratio, d.translation_ratio);
  EXPECT_EQ(k.rotation_deg, d.rotation_deg);
  EXPECT_EQ(k.residual_ratio, d.residual_ratio);
  EXPECT_EQ(k.min_inlier_ratio, d.min_inlier_ratio);
  EXPECT_EQ(k.min_interval, d.min_interval);
  EXPECT_EQ(k.max_interval, d.max_interval);
  // By default the keyframe manager drives the frontend, and dfo_run compares both trajectories.
  EXPECT_EQ(apps::ReferencePolicyFromConfig(config), "external");
  EXPECT_EQ(apps::RunModeFromConfig(config), apps::RunMode::kBoth);
}

TEST(BackendConfig, EveryKeyframeKeyReachesItsField) {
  const io::Config config = io::LoadConfigFromString(
      "keyframe:\n"
      "  decided_by: frontend\n"
      "  translation_ratio: 0.25\n"
      "  rotation_deg: 7.5\n"
      "  residual_ratio: 1.5\n"
      "  min_inlier_ratio: 0.3\n"
      "  min_interval: 2\n"
      "  max_interval: 6\n"
      "run:\n"
      "  mode: windowed\n",
      "all.yaml", io::DfoSchema());
  const KeyframeOptions k = apps::KeyframeOptionsFromConfig(config);
  EXPECT_EQ(k.translation_ratio, 0.25);
  EXPECT_EQ(k.rotation_deg, 7.5);
  EXPECT_EQ(k.residual_ratio, 1.5);
  EXPECT_EQ(k.min_inlier_ratio, 0.3);
  EXPECT_EQ(k.min_interval, 2);
  EXPECT_EQ(k.max_interval, 6);
  EXPECT_EQ(apps::ReferencePolicyFromConfig(config), "internal");
  EXPECT_EQ(apps::RunModeFromConfig(config), apps::RunMode::kWindowed);
}

// Contradicting keyframe settings are rejected at start-up with the key names.
TEST(BackendConfig, ContradictionsNameTheKeys) {
  const io::Config config = io::LoadConfigFromString(
      "keyframe:\n  min_interval: 12\n  max_interval: 10\n", "bad.yaml", io::DfoSchema());
  try {
    apps::KeyframeOptionsFromConfig(config);
    FAIL() << "no ConfigError for min_interval > max_interval";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe.min_interval = 12"), std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("keyframe.max_interval"), std::string::npos) << e.what();
  }
  // A ratio <= 0 is already outside the schema's range: the loader names file, key and line.
  EXPECT_THROW(io::LoadConfigFromString("keyframe:\n  translation_ratio: 0\n", "zero.yaml",
                                        io::DfoSchema()),
               ConfigError);
  EXPECT_THROW(apps::ParseRunMode("window"), ConfigError);
  EXPECT_STREQ(apps::RunModeName(apps::ParseRunMode("both")), "both");
}

TEST(BackendConfig, EveryShippedConfigGivesValidBackendOptions) {
  for (const char* name : {"default.yaml", "demo.yaml", "kitti.yaml", "tum.yaml", "synthetic.yaml"}) {
    SCOPED_TRACE(name);
    const io::Config config =
        io::LoadConfig(test::SourceDir() + "/configs/" + name, io::DfoSchema());
    EXPECT_NO_THROW(apps::KeyframeOptionsFromConfig(config));
    EXPECT_NO_THROW(apps::RunModeFromConfig(config));
  }
}

}  // namespace
}  // namespace dfo
