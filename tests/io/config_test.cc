#include "dfo_io/config.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_io/config_schema.h"
#include "dfo_io/dataset.h"
#include "dfo_io/sweep_spec.h"
#include "dfo_io/train_schema.h"
#include "tests/support/test_support.h"

namespace dfo::io {
namespace {

namespace fs = std::filesystem;

// A small schema with every type, used by most tests (DfoSchema's keys change as modules grow).
ConfigSchema TestSchema() {
  ConfigSchema s;
  s.AddSection("keyframe", "Keyframe selection.");
  s.AddDouble("keyframe.translation_ratio", 0.1, "Translation over mean depth").GreaterThan(0);
  s.AddInt("keyframe.max_interval", 10, "Frames between keyframes at most").Min(1).Max(1000);
  s.AddBool("keyframe.enabled", true, "Whether keyframes are made");
  s.AddSection("tracker", "Frontend tracker.");
  s.AddString("tracker.mode", "gn", "Solver").OneOf({"gn", "lm"});
  s.AddString("tracker.name", "default", "Free text");
  s.AddIntList("tracker.iterations", {10, 5, 3}, "Iterations per level").Min(1);
  s.AddDoubleList("tracker.weights", {1.0, 0.5}, "Weights").Min(0);
  s.AddStringList("tracker.tags", {"a", "b"}, "Tags");
  s.AddSection("empty", "A section without keys.");
  return s;
}

std::string WriteFile(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// Runs `fn`, expects a ConfigError whose message contains every needle.
template <typename Fn>
void ExpectConfigError(Fn fn, const std::vector<std::string>& needles) {
  try {
    fn();
    FAIL() << "no ConfigError thrown";
  } catch (const ConfigError& e) {
    const std::string what = e.what();
    for (const auto& n : needles)
      EXPECT_NE(what.find(n), std::string::npos) << what << "\n  missing: " << n;
  }
}

TEST(Config, DefaultsAndSources) {
  const Config c(TestSchema());
  EXPECT_DOUBLE_EQ(c.GetDouble("keyframe.translation_ratio"), 0.1);
  EXPECT_EQ(c.GetInt("keyframe.max_interval"), 10);
  EXPECT_TRUE(c.GetBool("keyframe.enabled"));
  EXPECT_EQ(c.GetString("tracker.mode"), "gn");
  EXPECT_EQ(c.GetIntList("tracker.iterations"), (std::vector<int>{10, 5, 3}));
  EXPECT_EQ(c.GetDoubleList("tracker.weights"), (std::vector<double>{1.0, 0.5}));
  EXPECT_EQ(c.GetStringList("tracker.tags"), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(c.Source("keyframe.enabled"), "default");
  EXPECT_TRUE(c.IsDefault("tracker.mode"));
}

TEST(Config, FileValuesRecordFileAndLine) {
  const std::string yaml =
      "# comment\n"
      "keyframe:\n"
      "  translation_ratio: 0.25\n"
      "  enabled: false\n"
      "tracker:\n"
      "  iterations: [4, 4]\n"
      "  tags: []\n";
  const Config c = LoadConfigFromString(yaml, "my.yaml", TestSchema());
  EXPECT_DOUBLE_EQ(c.GetDouble("keyframe.translation_ratio"), 0.25);
  EXPECT_FALSE(c.GetBool("keyframe.enabled"));
  EXPECT_EQ(c.GetIntList("tracker.iterations"), (std::vector<int>{4, 4}));
  EXPECT_TRUE(c.GetStringList("tracker.tags").empty());
  EXPECT_EQ(c.Source("keyframe.translation_ratio"), "my.yaml:3");
  EXPECT_EQ(c.Source("tracker.iterations"), "my.yaml:6");
  EXPECT_EQ(c.Source("keyframe.max_interval"), "default");
}

TEST(Config, LoadsFromFileAndOverridesWin) {
  const std::string dir = test::MakeTempDir("config_override");
  const std::string path =
      WriteFile(dir, "c.yaml", "keyframe:\n  translation_ratio: 0.3\n  max_interval: 7\n");
  const Config c = LoadConfig(path, TestSchema(),
                              {"keyframe.translation_ratio=0.5", "tracker.iterations=[2, 1]",
                               "tracker.name=a b: #c", "keyframe.translation_ratio = 0.75"});
  EXPECT_DOUBLE_EQ(c.GetDouble("keyframe.translation_ratio"), 0.75);  // later --set wins
  EXPECT_EQ(c.Source("keyframe.translation_ratio"), "--set");
  EXPECT_EQ(c.GetInt("keyframe.max_interval"), 7);
  EXPECT_EQ(c.Source("keyframe.max_interval"), path + ":3");
  EXPECT_EQ(c.GetIntList("tracker.iterations"), (std::vector<int>{2, 1}));
  EXPECT_EQ(c.GetString("tracker.name"), "a b: #c");  // unquoted strings verbatim
}

TEST(Config, EmptyFileAndEmptySectionsGiveDefaults) {
  EXPECT_NO_THROW(LoadConfigFromString("", "e.yaml", TestSchema()));
  EXPECT_NO_THROW(LoadConfigFromString("# only a comment\n", "e.yaml", TestSchema()));
  const Config c = LoadConfigFromString("keyframe:\nempty: {}\n", "e.yaml", TestSchema());
  EXPECT_TRUE(c.IsDefault("keyframe.translation_ratio"));
}

TEST(ConfigErrors, UnknownSectionSuggestsClosest) {
  ExpectConfigError(
      [] { LoadConfigFromString("a: 1\nkeyfrme:\n  x: 1\n", "s.yaml", TestSchema()); },
      {"s.yaml:1", "unknown section 'a'"});
  ExpectConfigError(
      [] { LoadConfigFromString("keyfrme:\n  enabled: true\n", "s.yaml", TestSchema()); },
      {"s.yaml:1", "unknown section 'keyfrme'", "did you mean 'keyframe'"});
}

TEST(ConfigErrors, UnknownKeySuggestsClosest) {
  ExpectConfigError(
      [] {
        LoadConfigFromString("keyframe:\n  enabled: true\n  translaton_ratio: 0.2\n", "k.yaml",
                             TestSchema());
      },
      {"k.yaml:3", "unknown key 'keyframe.translaton_ratio'",
       "did you mean 'keyframe.translation_ratio'"});
}

TEST(ConfigErrors, WrongTypeNamesExpectationAndFoundText) {
  ExpectConfigError(
      [] { LoadConfigFromString("keyframe:\n  translation_ratio: abc\n", "t.yaml", TestSchema()); },
      {"t.yaml:2", "keyframe.translation_ratio", "expected a number, found 'abc'"});
  ExpectConfigError(
      [] { LoadConfigFromString("keyframe:\n  max_interval: 1.5\n", "t.yaml", TestSchema()); },
      {"t.yaml:2", "keyframe.max_interval", "expected an integer, found '1.5'"});
  ExpectConfigError(
      [] { LoadConfigFromString("keyframe:\n  enabled: maybe\n", "t.yaml", TestSchema()); },
      {"t.yaml:2", "expected a boolean", "'maybe'"});
  ExpectConfigError(
      [] { LoadConfigFromString("tracker:\n  iterations: 3\n", "t.yaml", TestSchema()); },
      {"t.yaml:2", "tracker.iterations", "expected a list of integers"});
  ExpectConfigError(
      [] { LoadConfigFromString("tracker:\n\n  iterations: [1, x]\n", "t.yaml", TestSchema()); },
      {"t.yaml:3", "'x' as element 1"});
  ExpectConfigError(
      [] { LoadConfigFromString("tracker:\n  mode: [gn]\n", "t.yaml", TestSchema()); },
      {"t.yaml:2", "expected a string, found a list"});
  ExpectConfigError(
      [] { LoadConfigFromString("keyframe:\n  max_interval:\n", "t.yaml", TestSchema()); },
      {"t.yaml:2", "expected an integer, found nothing"});
}

TEST(ConfigErrors, OutOfRangeNamesKeyValueAndRule) {
  ExpectConfigError(
      [] {
        LoadConfigFromString("keyframe:\n  enabled: true\n  translation_ratio: -0.1\n", "r.yaml",
                             TestSchema());
      },
      {"r.yaml:3", "keyframe.translation_ratio = -0.1 violates > 0"});
  ExpectConfigError(
      [] { LoadConfigFromString("keyframe:\n  max_interval: 5000\n", "r.yaml", TestSchema()); },
      {"r.yaml:2", "keyframe.max_interval = 5000 violates >= 1, <= 1000"});
  ExpectConfigError(
      [] { LoadConfigFromString("tracker:\n  mode: newton\n", "r.yaml", TestSchema()); },
      {"r.yaml:2", "tracker.mode = \"newton\" violates one of gn|lm"});
  ExpectConfigError(
      [] { LoadConfigFromString("tracker:\n  iterations: [3, 0]\n", "r.yaml", TestSchema()); },
      {"r.yaml:2", "tracker.iterations = [3, 0] violates >= 1"});
}

TEST(ConfigErrors, MalformedYamlNamesFileAndLine) {
  const std::string dir = test::MakeTempDir("config_malformed");
  const std::string path =
      WriteFile(dir, "bad.yaml", "keyframe:\n  enabled: true\n  max_interval: [1, 2\n");
  ExpectConfigError([&] { LoadConfig(path, TestSchema()); }, {path + ":", "malformed YAML"});
  ExpectConfigError(
      [] { LoadConfigFromString("keyframe:\n  a: b\n c: d\n", "m.yaml", TestSchema()); },
      {"m.yaml:3", "malformed YAML"});
}

TEST(ConfigErrors, StructureErrors) {
  ExpectConfigError([] { LoadConfigFromString("- 1\n- 2\n", "s.yaml", TestSchema()); },
                    {"s.yaml:1", "top level must be a mapping"});
  ExpectConfigError([] { LoadConfigFromString("keyframe: 3\n", "s.yaml", TestSchema()); },
                    {"s.yaml:1", "section 'keyframe' must be a mapping"});
  ExpectConfigError(
      [] {
        LoadConfigFromString("keyframe:\n  enabled: true\n  enabled: false\n", "s.yaml",
                             TestSchema());
      },
      {"s.yaml:3", "'keyframe.enabled' appears twice"});
}

TEST(ConfigErrors, MissingFileIsInputError) {
  EXPECT_THROW(LoadConfig("/nonexistent/dfo.yaml", TestSchema()), InputError);
  const std::string dir = test::MakeTempDir("config_folder");
  try {
    LoadConfig(dir, TestSchema());
    FAIL() << "a folder was accepted as a configuration file";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(dir + " is a folder"), std::string::npos) << e.what();
  }
}

TEST(ConfigErrors, IntegerBeyondTheIntRangeNamesWhereItCameFrom) {
  ConfigSchema schema = TestSchema();
  schema.AddInt("keyframe.count", 1, "Any integer");
  const Config file = LoadConfigFromString("keyframe:\n  count: 99999999999\n", "big.yaml", schema);
  ExpectConfigError([&] { file.GetInt("keyframe.count"); },
                    {"big.yaml:2", "keyframe.count = 99999999999", "integer range"});
  EXPECT_EQ(file.GetInt64("keyframe.count"), 99999999999);  // 64-bit keys (seeds) keep it
  const Config set =
      LoadConfigFromString("", "o.yaml", TestSchema(), {"tracker.iterations=[1, 99999999999]"});
  ExpectConfigError([&] { set.GetIntList("tracker.iterations"); },
                    {"--set", "tracker.iterations = 99999999999"});
}

TEST(ConfigErrors, BadOverrides) {
  ExpectConfigError([] { LoadConfigFromString("", "o.yaml", TestSchema(), {"keyframe.enabled"}); },
                    {"--set 'keyframe.enabled'", "no '='"});
  ExpectConfigError(
      [] { LoadConfigFromString("", "o.yaml", TestSchema(), {"keyframe.enabeld=true"}); },
      {"--set", "unknown configuration key 'keyframe.enabeld'", "did you mean 'keyframe.enabled'"});
  ExpectConfigError(
      [] { LoadConfigFromString("", "o.yaml", TestSchema(), {"keyframe.max_interval=abc"}); },
      {"--set 'keyframe.max_interval=abc'", "expected an integer, found 'abc'"});
  ExpectConfigError(
      [] { LoadConfigFromString("", "o.yaml", TestSchema(), {"keyframe.translation_ratio=-0.1"}); },
      {"--set 'keyframe.translation_ratio=-0.1'",
       "keyframe.translation_ratio = -0.1 violates > 0"});
}

TEST(Config, GettersOfWrongTypeOrUnknownKeyAreInternalErrors) {
  const Config c(TestSchema());
  EXPECT_THROW(c.GetInt("keyframe.translation_ratio"), InternalError);
  EXPECT_THROW(c.GetDouble("keyframe.max_interval"), InternalError);
  EXPECT_THROW(c.GetString("keyframe.enabled"), InternalError);
  EXPECT_THROW(c.GetBool("keyframe.nothing"), InternalError);
  EXPECT_THROW(c.Source("nothing.at_all"), InternalError);
}

TEST(Config, SchemaWithInvalidDefaultIsInternalError) {
  ConfigSchema s;
  s.AddSection("a", "");
  s.AddDouble("a.x", -1.0, "negative default").GreaterThan(0);
  EXPECT_THROW(Config{s}, InternalError);
  EXPECT_THROW(s.AddBool("b.y", true, "undeclared section"), InternalError);
  EXPECT_THROW(s.AddBool("a.x", true, "declared twice"), InternalError);
}

TEST(Config, ToYamlRoundTripsEveryValue) {
  Config c(TestSchema());
  c.Set("keyframe.translation_ratio", 0.1 + 0.2, "test");  // needs 17 digits
  c.Set("keyframe.max_interval", int64_t{999}, "test");
  c.Set("keyframe.enabled", false, "test");
  c.Set("tracker.name", std::string("quote \" backslash \\ colon: hash # tab\t"), "test");
  c.Set("tracker.iterations", std::vector<int64_t>{7}, "test");
  c.Set("tracker.weights", std::vector<double>{1e-9, 3.0, 123456.789}, "test");
  c.Set("tracker.tags", std::vector<std::string>{"x, y", "[z]", ""}, "test");
  const std::string text = c.ToYaml();
  EXPECT_NE(text.find("# Translation over mean depth [> 0]"), std::string::npos) << text;
  EXPECT_NE(text.find("# from test"), std::string::npos) << text;
  const Config back = LoadConfigFromString(text, "roundtrip.yaml", TestSchema());
  for (const auto& key : c.schema().keys()) {
    EXPECT_EQ(back.Get(key.path), c.Get(key.path)) << key.path;
  }
  // And the defaults alone.
  const Config defaults(TestSchema());
  const Config defaults_back =
      LoadConfigFromString(defaults.ToYaml(), "defaults.yaml", TestSchema());
  for (const auto& key : defaults.schema().keys()) {
    EXPECT_EQ(defaults_back.Get(key.path), key.default_value) << key.path;
    EXPECT_NE(defaults_back.Source(key.path), "default") << key.path << " not written";
  }
}

TEST(Config, WriteYamlThenLoadConfig) {
  const std::string dir = test::MakeTempDir("config_write");
  const Config c = LoadConfigFromString("", "x", TestSchema(), {"keyframe.max_interval=3"});
  const std::string path = dir + "/sub/config_effective.yaml";
  c.WriteYaml(path);
  EXPECT_EQ(LoadConfig(path, TestSchema()).GetInt("keyframe.max_interval"), 3);
}

TEST(Config, EditDistanceAndSuggestions) {
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3u);
  EXPECT_EQ(EditDistance("", "abc"), 3u);
  EXPECT_EQ(EditDistance("same", "same"), 0u);
  EXPECT_EQ(EditDistance("fsp", "fps"), 1u);  // a swap is one edit
  EXPECT_EQ(ClosestMatch("dataset.pth", {"dataset.path", "dataset.type"}), "dataset.path");
  EXPECT_EQ(ClosestMatch("zzzzzzzz", {"dataset.path"}), "");
}

// --- dfo's own schema and shipped files -------------------------------------------------------

TEST(DfoConfig, DefaultYamlEqualsSchemaDefaults) {
  const std::string path = test::SourceDir() + "/configs/default.yaml";
  const Config c = LoadConfig(path, DfoSchema());
  for (const auto& key : DfoSchema().keys()) {
    EXPECT_EQ(c.Get(key.path), key.default_value)
        << key.path << ": configs/default.yaml has " << FormatConfigValue(c.Get(key.path))
        << ", the schema " << FormatConfigValue(key.default_value);
    EXPECT_NE(c.Source(key.path), "default") << key.path << " is missing from configs/default.yaml";
  }
}

TEST(DfoConfig, LearnedDeviceIsCpuCudaOrCudaN) {
  for (const char* good : {"cpu", "cuda", "cuda:0", "cuda:12"}) {
    EXPECT_EQ(LoadConfigFromString("", "d.yaml", DfoSchema(),
                                   {std::string("learned.device=") + good})
                  .GetString("learned.device"),
              good);
  }
  // Refused when the file is read, before any model is loaded.
  for (const char* bad : {"gpu", "cuda:x", "cuda:", "CPU"}) {
    try {
      LoadConfigFromString("learned:\n  device: \"" + std::string(bad) + "\"\n", "d.yaml",
                           DfoSchema());
      ADD_FAILURE() << "accepted learned.device = " << bad;
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("d.yaml"), std::string::npos) << what;
      EXPECT_NE(what.find("learned.device"), std::string::npos) << what;
      EXPECT_NE(what.find("one of cpu, cuda, cuda:N"), std::string::npos) << what;
    }
  }
}

TEST(DfoConfig, EveryShippedYamlParses) {
  int count = 0;
  std::vector<fs::directory_entry> files;
  for (const char* dir : {"/configs", "/experiments"}) {
    for (const auto& entry : fs::directory_iterator(test::SourceDir() + dir))
      files.push_back(entry);
  }
  for (const auto& entry : files) {
    if (entry.path().extension() != ".yaml") continue;
    ++count;
    SCOPED_TRACE(entry.path().string());
    // train_*.yaml configure dfo_train (its own schema); every other file configures dfo_run.
    if (entry.path().filename().string().rfind("train_", 0) == 0) {
      EXPECT_NO_THROW(LoadConfig(entry.path().string(), TrainSchema()));
      continue;
    }
    // experiments/sweep_*.yaml are dfo_sweep files; their overrides are checked against dfo_run's
    // schema.
    if (entry.path().filename().string().rfind("sweep_", 0) == 0) {
      EXPECT_NO_THROW(ExpandSweep(LoadSweepSpec(entry.path().string())));
      continue;
    }
    const Config c = LoadConfig(entry.path().string(), DfoSchema());
    EXPECT_NO_THROW(DatasetOptionsFromConfig(c));
  }
  EXPECT_GE(count, 4);  // default, kitti, tum, synthetic
}

TEST(DfoConfig, DatasetDefaultsAgreeWithDatasetOptions) {
  const DatasetOptions from_config = DatasetOptionsFromConfig(Config(DfoSchema()));
  const DatasetOptions defaults;
  EXPECT_EQ(from_config.type, defaults.type);
  EXPECT_EQ(from_config.path, defaults.path);
  EXPECT_EQ(from_config.camera, defaults.camera);
  EXPECT_EQ(from_config.sequence, defaults.sequence);
  EXPECT_EQ(from_config.first, defaults.first);
  EXPECT_EQ(from_config.last, defaults.last);
  EXPECT_EQ(from_config.step, defaults.step);
  EXPECT_EQ(from_config.image_width, defaults.image_width);
  EXPECT_EQ(from_config.image_height, defaults.image_height);
  EXPECT_EQ(from_config.keep_native, defaults.keep_native);
  EXPECT_EQ(from_config.color, defaults.color);
  EXPECT_EQ(from_config.depth, defaults.depth);
  EXPECT_EQ(from_config.tum_max_depth_diff, defaults.tum_max_depth_diff);
  EXPECT_EQ(from_config.tum_gt_mode, defaults.tum_gt_mode);
  EXPECT_EQ(from_config.tum_max_gt_diff, defaults.tum_max_gt_diff);
  EXPECT_EQ(from_config.tum_max_gt_gap, defaults.tum_max_gt_gap);
}

TEST(DfoConfig, DatasetOptionsFromConfigAppliesValuesAndChecks) {
  const Config c = LoadConfigFromString(
      "dataset:\n  type: tum\n  path: /data/x\n  first: 3\n  last: 9\n  color: true\n", "d.yaml",
      DfoSchema());
  const DatasetOptions o = DatasetOptionsFromConfig(c);
  EXPECT_EQ(o.type, "tum");
  EXPECT_EQ(o.path, "/data/x");
  EXPECT_EQ(o.first, 3);
  EXPECT_EQ(o.last, 9);
  EXPECT_TRUE(o.color);
  const Config bad =
      LoadConfigFromString("dataset:\n  path: /x\n  first: 5\n  last: 2\n", "d.yaml", DfoSchema());
  ExpectConfigError([&] { DatasetOptionsFromConfig(bad); }, {"dataset.last = 2"});
}

TEST(DfoConfig, VideoTypeCameraAndStepFlowIntoDatasetOptions) {
  const Config c = LoadConfigFromString(
      "dataset:\n  type: video\n  path: /data/drive.mkv\n  camera: /data/cam.yaml\n  step: 3\n",
      "d.yaml", DfoSchema());
  const DatasetOptions o = DatasetOptionsFromConfig(c);
  EXPECT_EQ(o.type, "video");
  EXPECT_EQ(o.path, "/data/drive.mkv");
  EXPECT_EQ(o.camera, "/data/cam.yaml");
  EXPECT_EQ(o.step, 3);
  ExpectConfigError([] { LoadConfigFromString("dataset:\n  step: 0\n", "d.yaml", DfoSchema()); },
                    {"dataset.step", "0"});
  // KITTI's camera is its calib.txt.
  const Config kitti = LoadConfigFromString(
      "dataset:\n  type: kitti\n  path: /k\n  camera: /c.yaml\n", "d.yaml", DfoSchema());
  ExpectConfigError([&] { DatasetOptionsFromConfig(kitti); }, {"dataset.camera", "kitti"});
  DatasetOptions direct;
  direct.path = "/k";
  direct.step = 0;
  ExpectConfigError([&] { direct.Check(); }, {"dataset.step = 0 violates >= 1"});
}

}  // namespace
}  // namespace dfo::io
