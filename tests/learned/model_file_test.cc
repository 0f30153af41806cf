// Tests of dfo's model file (dfo_frontend/learned/internal/model_file.h): the save/load round
// trip and every bad-model error (missing file, other formats, bad metadata, shapes that disagree
// with the metadata or with the configuration).
#include "dfo_frontend/learned/internal/model_file.h"

#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <string>

#include "dfo_core/error.h"
#include "dfo_frontend/learned/learned_sources.h"
#include "tests/support/test_support.h"

namespace dfo::learned {
namespace {

NetworkOptions SmallOptions() {
  NetworkOptions o;
  o.input_width = 64;
  o.input_height = 32;
  o.depth_encoder_widths = {8, 8, 16, 16, 16};
  o.depth_decoder_widths = {4, 8, 8, 16, 16};
  o.feature_encoder_widths = {8, 8, 16, 16};
  o.feature_decoder_widths = {4, 8, 8, 16};
  o.channels = {4, 4, 8, 8};
  return o;
}

// The message of the InputError `fn` throws ("" and a test failure when it throws nothing).
std::string InputErrorOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const ConfigError& e) {
    ADD_FAILURE() << "expected an InputError that is not a ConfigError, got: " << e.what();
    return e.what();
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected InputError";
  return "";
}

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// Writes an archive like SaveModel but with metadata `meta` next to the weights of `nets` (to
// build broken files). `overrides` replaces a metadata field's value; a None value leaves the
// field out.
void WriteArchive(const std::string& path, const NetworkOptions& meta, NetworksImpl& nets,
                  const std::map<std::string, c10::IValue>& overrides = {},
                  bool with_depth = true) {
  auto ints = [](const std::vector<int>& v) { return std::vector<int64_t>(v.begin(), v.end()); };
  torch::serialize::OutputArchive a;
  auto write = [&](const std::string& key, const c10::IValue& value) {
    const auto it = overrides.find(key);
    if (it == overrides.end()) {
      a.write(key, value);
    } else if (!it->second.isNone()) {
      a.write(key, it->second);
    }
  };
  write("dfo_format", c10::IValue(std::string(kModelFormatTag)));
  write("dfo_version", c10::IValue(int64_t{kModelFileVersion}));
  write("input_width", c10::IValue(int64_t{meta.input_width}));
  write("input_height", c10::IValue(int64_t{meta.input_height}));
  write("num_levels", c10::IValue(int64_t{meta.num_levels}));
  write("channels", c10::IValue(ints(meta.channels)));
  write("patch_sizes", c10::IValue(ints(meta.patch_sizes)));
  write("rho", c10::IValue(meta.rho));
  write("input_mean", c10::IValue(meta.input_mean));
  write("input_std", c10::IValue(meta.input_std));
  write("depth_encoder_widths", c10::IValue(ints(meta.depth_encoder_widths)));
  write("depth_decoder_widths", c10::IValue(ints(meta.depth_decoder_widths)));
  write("feature_encoder_widths", c10::IValue(ints(meta.feature_encoder_widths)));
  write("feature_decoder_widths", c10::IValue(ints(meta.feature_decoder_widths)));
  write("reconstruction_width", c10::IValue(int64_t{meta.reconstruction_width}));
  torch::serialize::OutputArchive d, f;
  nets.depth->save(d);
  nets.feature->save(f);
  if (with_depth) a.write("depth", d);
  a.write("feature", f);
  a.save_to(path);
}

TEST(ModelFileTest, RoundTripGivesIdenticalOutputs) {
  const std::string dir = test::MakeTempDir("model_round_trip");
  const std::string path = dir + "/model.pt";
  const NetworkOptions o = SmallOptions();
  Networks nets(o, 17);
  SaveModel(path, *nets, "made by a test");
  LoadedModel loaded = LoadModel(path);
  ASSERT_EQ(loaded.kind, LoadedModel::Kind::kDfo);
  EXPECT_EQ(loaded.options, o);
  EXPECT_EQ(loaded.notes, "made by a test");
  const auto a = nets->named_parameters(), b = loaded.networks->named_parameters();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].key(), b[i].key());
    EXPECT_TRUE(torch::equal(a[i].value(), b[i].value())) << a[i].key();
  }
  nets->eval();
  torch::NoGradGuard no_grad;
  const torch::Tensor image = torch::rand({1, 3, o.input_height, o.input_width});
  const DepthNetOutput d1 = nets->depth->forward(image),
                       d2 = loaded.networks->depth->forward(image);
  const FeatureNetOutput f1 = nets->feature->forward(image);
  const FeatureNetOutput f2 = loaded.networks->feature->forward(image);
  for (int l = 0; l < o.num_levels; ++l) {
    EXPECT_TRUE(torch::equal(d1.depth[l], d2.depth[l])) << l;
    EXPECT_TRUE(torch::equal(f1.features[l], f2.features[l])) << l;
    EXPECT_TRUE(torch::equal(f1.mask_logits[l], f2.mask_logits[l])) << l;
  }
}

TEST(ModelFileTest, MissingFile) {
  const std::string path = test::MakeTempDir("model_missing") + "/nothing.pt";
  const std::string msg = InputErrorOf([&] { LoadModel(path); });
  EXPECT_TRUE(Contains(msg, path)) << msg;
  EXPECT_TRUE(Contains(msg, "not found")) << msg;
  const std::string dir = test::MakeTempDir("model_dir");
  EXPECT_TRUE(Contains(InputErrorOf([&] { LoadModel(dir); }), "not a regular file"));
}

TEST(ModelFileTest, FileOfAnotherFormat) {
  const std::string dir = test::MakeTempDir("model_png");
  // A PNG renamed to .pt (signature, IHDR chunk start, padding).
  const std::string png = dir + "/image.pt";
  {
    std::ofstream out(png, std::ios::binary);
    const unsigned char bytes[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n',
                                   0,    0,   0,   13,  'I',  'H',  'D',  'R'};
    out.write(reinterpret_cast<const char*>(bytes), sizeof(bytes));
    out << std::string(200, '\0');
  }
  std::string msg = InputErrorOf([&] { LoadModel(png); });
  EXPECT_TRUE(Contains(msg, png)) << msg;
  EXPECT_TRUE(Contains(msg, "not a dfo model or TorchScript archive")) << msg;

  // An empty file.
  const std::string empty = dir + "/empty.pt";
  std::ofstream(empty).close();
  EXPECT_TRUE(Contains(InputErrorOf([&] { LoadModel(empty); }), empty));

  // A torch file that is not a model: a tensor saved with torch::save.
  const std::string tensor = dir + "/tensor.pt";
  torch::save(torch::ones({3, 3}), tensor);
  msg = InputErrorOf([&] { LoadModel(tensor); });
  EXPECT_TRUE(Contains(msg, tensor)) << msg;
  EXPECT_TRUE(Contains(msg, "neither a dfo model")) << msg;
}

TEST(ModelFileTest, BadFormatTagVersionAndMissingField) {
  const std::string dir = test::MakeTempDir("model_bad_meta");
  const NetworkOptions o = SmallOptions();
  Networks nets(o, 1);
  const std::string tag = dir + "/tag.pt";
  WriteArchive(tag, o, *nets, {{"dfo_format", c10::IValue("other-model")}});
  std::string msg = InputErrorOf([&] { LoadModel(tag); });
  EXPECT_TRUE(Contains(msg, "field dfo_format = 'other-model'")) << msg;

  const std::string version = dir + "/version.pt";
  WriteArchive(version, o, *nets, {{"dfo_version", c10::IValue(int64_t{2})}});
  msg = InputErrorOf([&] { LoadModel(version); });
  EXPECT_TRUE(Contains(msg, version)) << msg;
  EXPECT_TRUE(Contains(msg, "field dfo_version = 2")) << msg;

  // A field of the wrong type.
  const std::string wrong_type = dir + "/wrong_type.pt";
  WriteArchive(wrong_type, o, *nets, {{"rho", c10::IValue("0.1")}});
  msg = InputErrorOf([&] { LoadModel(wrong_type); });
  EXPECT_TRUE(Contains(msg, "field rho has type String; expected a list of floats")) << msg;

  // A missing field.
  const std::string missing = dir + "/missing.pt";
  WriteArchive(missing, o, *nets, {{"channels", c10::IValue()}});
  msg = InputErrorOf([&] { LoadModel(missing); });
  EXPECT_TRUE(Contains(msg, "field channels is missing")) << msg;

  const std::string no_depth = dir + "/no_depth.pt";
  WriteArchive(no_depth, o, *nets, {}, /*with_depth=*/false);
  msg = InputErrorOf([&] { LoadModel(no_depth); });
  EXPECT_TRUE(Contains(msg, "module depth")) << msg;
}

TEST(ModelFileTest, InvalidMetadataNamesTheField) {
  const std::string dir = test::MakeTempDir("model_invalid_meta");
  NetworkOptions meta = SmallOptions();
  Networks nets(meta, 1);
  meta.rho = {0.1, 0.2, 0.3};  // 3 entries for 4 levels
  const std::string path = dir + "/rho.pt";
  WriteArchive(path, meta, *nets);
  const std::string msg = InputErrorOf([&] { LoadModel(path); });
  EXPECT_TRUE(Contains(msg, path)) << msg;
  EXPECT_TRUE(Contains(msg, "network.rho")) << msg;
}

TEST(ModelFileTest, WeightsThatDisagreeWithTheMetadata) {
  const std::string dir = test::MakeTempDir("model_shapes");
  const NetworkOptions o = SmallOptions();
  // Weights for channels {4, 4, 8, 8}, metadata claiming {4, 4, 8, 16}.
  Networks nets(o, 1);
  NetworkOptions meta = o;
  meta.channels = {4, 4, 8, 16};
  const std::string channels = dir + "/channels.pt";
  WriteArchive(channels, meta, *nets);
  std::string msg = InputErrorOf([&] { LoadModel(channels); });
  EXPECT_TRUE(Contains(msg, channels)) << msg;
  EXPECT_TRUE(Contains(msg, "parameter feature.heads.3.weight has shape [9, 16, 3, 3]")) << msg;

  // Weights of a 3-level network, metadata of a 4-level one: a parameter is missing.
  NetworkOptions three = o;
  three.num_levels = 3;
  three.channels = {4, 4, 8};
  three.patch_sizes = {3, 3, 3};
  three.rho = {0.1, 0.1, 0.1};
  three.feature_encoder_widths = {8, 8, 16};
  three.feature_decoder_widths = {4, 8, 8};
  Networks nets3(three, 1);
  const std::string levels = dir + "/levels.pt";
  WriteArchive(levels, o, *nets3);
  msg = InputErrorOf([&] { LoadModel(levels); });
  EXPECT_TRUE(Contains(msg, levels)) << msg;
  EXPECT_TRUE(Contains(msg, "parameter depth.")) << msg;
  EXPECT_TRUE(Contains(msg, "the file's metadata implies")) << msg;
}

TEST(ModelFileTest, NonFiniteWeightsAreRefusedNamingTheParameter) {
  const std::string dir = test::MakeTempDir("model_nan");
  const std::string path = dir + "/nan.dfo";
  Networks nets(SmallOptions(), 5);
  {
    torch::NoGradGuard no_grad;
    torch::Tensor w = nets->depth->named_parameters()[0].value();
    w.view({-1})[0] = std::numeric_limits<float>::quiet_NaN();
    w.view({-1})[1] = std::numeric_limits<float>::infinity();
  }
  SaveModel(path, *nets);
  const std::string msg = InputErrorOf([&] { LoadModel(path); });
  EXPECT_TRUE(Contains(msg, path)) << msg;
  EXPECT_TRUE(Contains(msg, "parameter depth." + nets->depth->named_parameters()[0].key() +
                                " holds 2 non-finite value(s)"))
      << msg;
}

TEST(ModelFileTest, ModelThatDisagreesWithTheConfiguration) {
  const std::string dir = test::MakeTempDir("model_config");
  NetworkOptions three = SmallOptions();
  three.num_levels = 3;
  three.channels = {4, 4, 8};
  three.patch_sizes = {3, 3, 3};
  three.rho = {0.1, 0.1, 0.1};
  three.feature_encoder_widths = {8, 8, 16};
  three.feature_decoder_widths = {4, 8, 8};
  const std::string path = dir + "/three.pt";
  WriteUntrainedModel(path, three, 1);

  LearnedModelOptions options;
  options.model_path = path;
  options.num_levels = 4;
  std::string msg = InputErrorOf([&] { LearnedModel model(options); });
  EXPECT_TRUE(Contains(msg, path)) << msg;
  EXPECT_TRUE(Contains(msg, "num_levels = 3")) << msg;
  EXPECT_TRUE(Contains(msg, "asks for 4")) << msg;

  options.num_levels = 3;
  options.channels = {4, 4, 16};
  msg = InputErrorOf([&] { LearnedModel model(options); });
  EXPECT_TRUE(Contains(msg, "channels = [4, 4, 8]")) << msg;

  options.channels = {4, 4, 8};
  EXPECT_NO_THROW(LearnedModel model(options));
  options.rho = {0.1, 0.2};  // the model has 3 levels
  EXPECT_THROW(LearnedModel model(options), ConfigError);
}

}  // namespace
}  // namespace dfo::learned
