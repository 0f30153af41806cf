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
#include "dfo_frontend/learned/internal/zip_archive.h"
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
  EXPECT_TRUE(
      Contains(InputErrorOf([&] { LoadModel(dir); }), "is a folder, expected a model file"));
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

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

TEST(ZipArchiveTest, Crc32OfTheStandardCheckString) {
  EXPECT_EQ(Crc32(0, "123456789", 9), 0xCBF43926u);
  // Continued over two pieces: the same.
  EXPECT_EQ(Crc32(Crc32(0, "1234", 4), "56789", 5), 0xCBF43926u);
}

TEST(ZipArchiveTest, SavedModelsAndTheShippedOnesPass) {
  const std::string path = test::MakeTempDir("zip_intact") + "/model.dfo";
  Networks nets(SmallOptions(), 3);
  SaveModel(path, *nets);
  const ZipArchiveCheck check = CheckZipArchive(path, "model file " + path);
  EXPECT_TRUE(check.is_zip);
  EXPECT_GT(check.entries, 20);
  EXPECT_GT(check.checked_bytes, 10000);
  for (const char* model : {"models/default.dfo", "models/kitti.dfo"}) {
    const std::string shipped = test::SourceDir() + "/" + model;
    const ZipArchiveCheck c = CheckZipArchive(shipped, shipped);
    EXPECT_TRUE(c.is_zip) << model;
    EXPECT_GT(c.checked_bytes, 4000000) << model;  // every weight's bytes
  }
  // No ZIP archive at all: nothing checked, nothing thrown (LoadModel says what it expected).
  const std::string text = test::MakeTempDir("zip_text") + "/notes.txt";
  WriteBytes(text, "not an archive\n");
  EXPECT_FALSE(CheckZipArchive(text, text).is_zip);
}

// A model whose weights were changed in place after it was written (its archive's CRC-32 then
// disagrees), or cut short, is refused naming the file and the damaged entry.
TEST(ModelFileTest, DamagedOrTruncatedArchiveIsRefusedNamingTheEntry) {
  const std::string dir = test::MakeTempDir("model_damaged");
  const std::string path = dir + "/model.dfo";
  Networks nets(SmallOptions(), 4);
  SaveModel(path, *nets);
  const std::string intact = ReadBytes(path);
  // The stored bytes of the first depth parameter, found in the file and changed by one bit.
  const torch::Tensor w = nets->depth->named_parameters()[0].value().contiguous();
  const std::string weight_bytes(reinterpret_cast<const char*>(w.data_ptr<float>()),
                                 sizeof(float) * 8);
  const size_t at = intact.find(weight_bytes);
  ASSERT_NE(at, std::string::npos);
  std::string damaged = intact;
  damaged[at + 5] = static_cast<char>(damaged[at + 5] ^ 0x10);
  const std::string changed = dir + "/changed.dfo";
  WriteBytes(changed, damaged);
  std::string msg = InputErrorOf([&] { LoadModel(changed); });
  EXPECT_TRUE(Contains(msg, changed)) << msg;
  EXPECT_TRUE(Contains(msg, "fails its CRC-32 check")) << msg;
  EXPECT_TRUE(Contains(msg, "entry '")) << msg;

  // A change anywhere (probed at 40 positions) is refused, or it fell into bytes that hold no
  // content (the padding LibTorch puts in local headers to align the data) and the model loads
  // with the very same weights.
  int refused = 0;
  for (int k = 1; k <= 40; ++k) {
    std::string copy = intact;
    const size_t pos = copy.size() * static_cast<size_t>(k) / 41;
    copy[pos] = static_cast<char>(copy[pos] ^ 0x5a);
    const std::string probe = dir + "/probe.dfo";
    WriteBytes(probe, copy);
    try {
      const LoadedModel loaded = LoadModel(probe);
      const auto a = nets->named_parameters(), b = loaded.networks->named_parameters();
      ASSERT_EQ(a.size(), b.size());
      for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_TRUE(torch::equal(a[i].value(), b[i].value()))
            << "byte " << pos << ": " << a[i].key();
      }
    } catch (const InputError& e) {
      EXPECT_TRUE(Contains(e.what(), probe)) << "byte " << pos << ": " << e.what();
      ++refused;
    }
  }
  EXPECT_GE(refused, 30);

  // Cut short: at half its size and without its last 10 bytes.
  for (const size_t keep : {intact.size() / 2, intact.size() - 10}) {
    const std::string cut = dir + "/cut.dfo";
    WriteBytes(cut, intact.substr(0, keep));
    msg = InputErrorOf([&] { LoadModel(cut); });
    EXPECT_TRUE(Contains(msg, cut)) << msg;
    EXPECT_TRUE(Contains(msg, "truncated")) << keep << ": " << msg;
  }
}

// Weights that are finite but no training leaves (1e30 written over a tensor, with a valid
// archive) are refused naming the parameter and the bound.
TEST(ModelFileTest, ImplausibleWeightsAreRefusedNamingTheParameter) {
  const std::string path = test::MakeTempDir("model_huge") + "/huge.dfo";
  Networks nets(SmallOptions(), 6);
  const std::string name = nets->feature->named_parameters()[2].key();
  {
    torch::NoGradGuard no_grad;
    nets->feature->named_parameters()[2].value().fill_(1e30f);
  }
  SaveModel(path, *nets);
  const std::string msg = InputErrorOf([&] { LoadModel(path); });
  EXPECT_TRUE(Contains(msg, path)) << msg;
  EXPECT_TRUE(Contains(msg, "parameter feature." + name)) << msg;
  EXPECT_TRUE(Contains(msg, "implausible")) << msg;
  // Just below the bound still loads.
  {
    torch::NoGradGuard no_grad;
    nets->feature->named_parameters()[2].value().fill_(
        static_cast<float>(0.5 * kMaxPlausibleWeight));
  }
  SaveModel(path, *nets);
  EXPECT_NO_THROW(LoadModel(path));
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
