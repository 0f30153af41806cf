// dfo_train's configuration schema: the shipped training YAML files load against it, the default
// file lists every key, and mistakes are named.
#include "dfo_io/train_schema.h"

#include <gtest/gtest.h>

#include "dfo_core/error.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

TEST(TrainSchemaTest, ShippedTrainingConfigsLoad) {
  for (const char* name : {"train_default.yaml", "train_tiny.yaml"}) {
    const std::string path = test::SourceDir() + "/configs/" + name;
    const Config config = LoadConfig(path, TrainSchema());
    EXPECT_EQ(config.GetInt("network.num_levels"), 4) << name;
    EXPECT_EQ(config.GetIntList("network.channels").size(), 4u) << name;
  }
}

TEST(TrainSchemaTest, DefaultFileSetsOnlyTheDataAndKeepsTheSchemaDefaults) {
  const Config config =
      LoadConfig(test::SourceDir() + "/configs/train_default.yaml", TrainSchema());
  EXPECT_EQ(config.GetStringList("data.sequences").size(), 4u);
  for (const std::string& key : TrainSchema().KeyPaths()) {
    // The file lists every key (its header says so; dfo_train --print-config writes the same).
    EXPECT_NE(config.Source(key), "default") << key << " is missing from train_default.yaml";
    if (key == "data.sequences") continue;
    EXPECT_EQ(FormatConfigValue(config.Get(key)), FormatConfigValue(Config(TrainSchema()).Get(key)))
        << key;
  }
}

TEST(TrainSchemaTest, DeviceIsCpuCudaOrCudaN) {
  EXPECT_EQ(Config(TrainSchema()).GetString("train.device"), "cpu");
  for (const char* good : {"cpu", "cuda", "cuda:0", "cuda:12"}) {
    EXPECT_EQ(
        LoadConfigFromString("", "t.yaml", TrainSchema(), {std::string("train.device=") + good})
            .GetString("train.device"),
        good);
  }
  for (const char* bad : {"gpu", "cuda:x", "cuda:", "CPU", "cuda:1234", ""}) {
    try {
      LoadConfigFromString("", "t.yaml", TrainSchema(), {std::string("train.device=") + bad});
      ADD_FAILURE() << "accepted train.device = " << bad;
    } catch (const ConfigError& e) {
      // learned.device's wording: the key, the value and the rule.
      EXPECT_NE(std::string(e.what()).find("train.device = \"" + std::string(bad) +
                                           "\" violates one of cpu, cuda, cuda:N"),
                std::string::npos)
          << e.what();
    }
  }
  // In a file, too (the message names the file and the key).
  try {
    LoadConfigFromString("train:\n  device: gpu\n", "t.yaml", TrainSchema());
    ADD_FAILURE() << "accepted train.device: gpu in a file";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("train.device"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("one of cpu, cuda, cuda:N"), std::string::npos)
        << e.what();
  }
}

TEST(TrainSchemaTest, TyposAndRangesAreNamed) {
  try {
    LoadConfigFromString("train:\n  batch_sise: 4\n", "t.yaml", TrainSchema());
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("batch_size"), std::string::npos) << e.what();
  }
  EXPECT_THROW(LoadConfigFromString("loss:\n  ssim_weight: 1.5\n", "t.yaml", TrainSchema()),
               ConfigError);
  EXPECT_THROW(LoadConfigFromString("", "t.yaml", TrainSchema(), {"train.iterations=0"}),
               ConfigError);
}

}  // namespace
}  // namespace dfo::io
