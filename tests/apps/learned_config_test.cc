// The configuration section `learned` against LearnedModelOptions (apps/learned_wiring.h): the
// schema in dfo_io cannot see the learned sources' options, so these tests keep the two in step.
// Only the torch-free configuration part of the wiring is used here (dfo_apps_tests does not link
// LibTorch); the model loading is tested through dfo_run (dfo_run_learned_test.cc).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "apps/learned_wiring.h"
#include "dfo_core/error.h"
#include "dfo_io/config.h"
#include "dfo_io/config_schema.h"

namespace dfo {
namespace {

TEST(LearnedConfig, SchemaDefaultsEqualLearnedModelOptionsDefaults) {
  const io::Config config(io::DfoSchema());
  const LearnedModelOptions from_config = apps::LearnedModelOptionsFromConfig(config);
  const LearnedModelOptions d;
  EXPECT_EQ(from_config.num_levels, d.num_levels);
  EXPECT_EQ(from_config.channels, d.channels);
  EXPECT_EQ(from_config.rho, d.rho);
  EXPECT_EQ(from_config.require_input_size, d.require_input_size);
  // The deliberate differences: LearnedModelOptions requires a path (no default) while the
  // configuration names the shipped model, and the threads follow run.threads (default 2, equal
  // to LearnedModelOptions' own default).
  EXPECT_TRUE(d.model_path.empty());
  EXPECT_EQ(from_config.model_path, "models/default.dfo");
  EXPECT_EQ(config.GetInt("learned.threads"), 0);
  EXPECT_EQ(from_config.num_threads, config.GetInt("run.threads"));
  EXPECT_EQ(from_config.num_threads, d.num_threads);
}

TEST(LearnedConfig, EveryKeyReachesItsField) {
  const io::Config config = io::LoadConfigFromString(
      "learned:\n"
      "  model: /tmp/some.dfo\n"
      "  threads: 3\n"
      "  num_levels: 4\n"
      "  channels: [8, 8, 16, 16]\n"
      "  rho: [0.1, 0.2, 0.3, 0.4]\n"
      "  require_input_size: false\n"
      "run:\n"
      "  threads: 1\n",
      "test.yaml", io::DfoSchema());
  const LearnedModelOptions o = apps::LearnedModelOptionsFromConfig(config);
  EXPECT_EQ(o.model_path, "/tmp/some.dfo");
  EXPECT_EQ(o.num_threads, 3);  // learned.threads wins over run.threads
  EXPECT_EQ(o.num_levels, 4);
  EXPECT_EQ(o.channels, (std::vector<int>{8, 8, 16, 16}));
  EXPECT_EQ(o.rho, (std::vector<double>{0.1, 0.2, 0.3, 0.4}));
  EXPECT_FALSE(o.require_input_size);
  // learned.threads = 0 follows run.threads.
  const io::Config follow =
      io::LoadConfigFromString("run:\n  threads: 1\n", "test.yaml", io::DfoSchema());
  EXPECT_EQ(apps::LearnedModelOptionsFromConfig(follow).num_threads, 1);
}

// "learned" is accepted by the schema and by FrontendOptions for both sources, in any mix; other
// names and out-of-range learned values are configuration errors.
TEST(LearnedConfig, LearnedSourcesAreValidNames) {
  for (const auto& [features, depth] : std::vector<std::pair<std::string, std::string>>{
           {"learned", "gt"}, {"handmade", "learned"}, {"learned", "learned"}}) {
    const io::Config config = io::LoadConfigFromString(
        "frontend:\n  features: " + features + "\n  depth: " + depth + "\n", "test.yaml",
        io::DfoSchema());
    const FrontendOptions o = apps::FrontendOptionsFromConfig(config);
    EXPECT_EQ(o.features, features);
    EXPECT_EQ(o.depth, depth);
    EXPECT_TRUE(apps::UsesLearnedSources(o));
  }
  EXPECT_FALSE(apps::UsesLearnedSources(FrontendOptions{}));
  EXPECT_THROW(
      io::LoadConfigFromString("frontend:\n  depth: network\n", "test.yaml", io::DfoSchema()),
      ConfigError);
  EXPECT_THROW(
      io::LoadConfigFromString("learned:\n  rho: [0.5, 1.5]\n", "test.yaml", io::DfoSchema()),
      ConfigError);
  EXPECT_THROW(io::LoadConfigFromString("learned:\n  threads: -1\n", "test.yaml", io::DfoSchema()),
               ConfigError);
  EXPECT_THROW(
      io::LoadConfigFromString("learned:\n  num_levels: 7\n", "test.yaml", io::DfoSchema()),
      ConfigError);
}

}  // namespace
}  // namespace dfo
