#include "dfo_frontend/learned/internal/model_file.h"

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_frontend/learned/internal/zip_archive.h"

namespace dfo::learned {

namespace {

std::string Prefix(const std::string& path) { return "model file " + path + ": "; }

// First line of a LibTorch message (the rest is a C++ backtrace nobody wants to read).
std::string FirstLine(const std::exception& e) {
  std::string what = e.what();
  if (const auto* c10_error = dynamic_cast<const c10::Error*>(&e)) {
    what = c10_error->what_without_backtrace();
  }
  const size_t eol = what.find('\n');
  return eol == std::string::npos ? what : what.substr(0, eol);
}

template <typename T>
std::string ShapeString(const T& sizes) {
  std::ostringstream s;
  s << "[";
  for (size_t i = 0; i < sizes.size(); ++i) s << (i ? ", " : "") << sizes[i];
  s << "]";
  return s.str();
}

std::vector<int64_t> ToInt64(const std::vector<int>& v) { return {v.begin(), v.end()}; }

// ---- typed attribute readers: InputError naming the file and the field ----------------------

c10::IValue Attr(const torch::jit::Module& m, const std::string& key, const std::string& path,
                 const std::string& expected) {
  if (!m.hasattr(key)) {
    throw InputError(Prefix(path) + "field " + key + " is missing; expected " + expected);
  }
  return m.attr(key);
}

int GetInt(const torch::jit::Module& m, const std::string& key, const std::string& path) {
  const c10::IValue v = Attr(m, key, path, "an int");
  if (!v.isInt()) {
    throw InputError(Prefix(path) + "field " + key + " has type " + v.tagKind() +
                     "; expected an int");
  }
  return static_cast<int>(v.toInt());
}

std::vector<int> GetIntList(const torch::jit::Module& m, const std::string& key,
                            const std::string& path) {
  const c10::IValue v = Attr(m, key, path, "a list of ints");
  if (!v.isIntList()) {
    throw InputError(Prefix(path) + "field " + key + " has type " + v.tagKind() +
                     "; expected a list of ints");
  }
  std::vector<int> out;
  for (int64_t x : v.toIntVector()) out.push_back(static_cast<int>(x));
  return out;
}

std::vector<double> GetDoubleList(const torch::jit::Module& m, const std::string& key,
                                  const std::string& path) {
  const c10::IValue v = Attr(m, key, path, "a list of floats");
  if (!v.isDoubleList()) {
    throw InputError(Prefix(path) + "field " + key + " has type " + v.tagKind() +
                     "; expected a list of floats");
  }
  return v.toDoubleVector();
}

std::string GetString(const torch::jit::Module& m, const std::string& key,
                      const std::string& path) {
  const c10::IValue v = Attr(m, key, path, "a string");
  if (!v.isString()) {
    throw InputError(Prefix(path) + "field " + key + " has type " + v.tagKind() +
                     "; expected a string");
  }
  return v.toStringRef();
}

// A tensor of weights that no training leaves: non-finite values, or magnitudes beyond
// kMaxPlausibleWeight. dfo's trained models hold |w| <= 4.7 (models/default.dfo and kitti.dfo;
// their convolution weights below 0.5), so the bound leaves a margin of 2000; a float32 weight of
// 1e4 times a unit activation, summed over a 3 x 3 x 64 kernel, already takes the next layer
// beyond anything its activations recover from (a model overwritten with 1e30 runs with depth
// AbsRel 1.70 instead of 0.19).
void CheckPlausible(const torch::Tensor& t, const std::string& name, const std::string& path) {
  if (!t.is_floating_point() || t.numel() == 0) return;
  const torch::Tensor values = t.to(torch::kFloat64);
  const int64_t non_finite = (~torch::isfinite(values)).sum().item<int64_t>();
  if (non_finite > 0) {
    throw InputError(Prefix(path) + name + " holds " + std::to_string(non_finite) +
                     " non-finite value(s) (NaN or inf) of " + std::to_string(t.numel()) +
                     "; the file is unusable (a diverged training?)");
  }
  const double largest = values.abs().max().item<double>();
  if (largest > kMaxPlausibleWeight) {
    const int64_t beyond = (values.abs() > kMaxPlausibleWeight).sum().item<int64_t>();
    std::ostringstream s;
    s << Prefix(path) << name << " holds " << beyond << " of " << t.numel() << " values beyond "
      << kMaxPlausibleWeight << " in magnitude (largest " << largest
      << "); dfo takes such weights as implausible (its trained models stay below 10): the file "
         "is damaged or its training diverged";
    throw InputError(s.str());
  }
}

// Copies the file's parameters into `module`, walking both trees by name (the layout
// torch::nn::Module::save writes: parameters, then one nested archive per child). Shapes are
// compared first: InputArchive would silently resize a parameter.
void LoadParameters(torch::nn::Module& module, const torch::jit::Module& stored,
                    const std::string& prefix, const std::string& path) {
  for (auto& item : module.named_parameters(/*recurse=*/false)) {
    const std::string name = prefix + item.key();
    if (!stored.hasattr(item.key())) {
      throw InputError(Prefix(path) + "parameter " + name + " is missing; expected a tensor of " +
                       "shape " + ShapeString(item.value().sizes()) +
                       " (does the file belong to another network version?)");
    }
    const c10::IValue v = stored.attr(item.key());
    if (!v.isTensor()) {
      throw InputError(Prefix(path) + "parameter " + name + " has type " + v.tagKind() +
                       "; expected a tensor");
    }
    const torch::Tensor t = v.toTensor();
    if (t.sizes() != item.value().sizes()) {
      throw InputError(Prefix(path) + "parameter " + name + " has shape " + ShapeString(t.sizes()) +
                       "; the file's metadata implies " + ShapeString(item.value().sizes()));
    }
    CheckPlausible(t, "parameter " + name, path);
    torch::NoGradGuard no_grad;
    item.value().copy_(t.to(torch::kFloat32));
  }
  for (auto& child : module.named_children()) {
    const std::string name = prefix + child.key();
    if (!stored.hasattr(child.key()) || !stored.attr(child.key()).isModule()) {
      throw InputError(Prefix(path) + "module " + name +
                       " is missing (does the file belong to another network version?)");
    }
    LoadParameters(*child.value(), stored.attr(child.key()).toModule(), name + ".", path);
  }
}

LoadedModel LoadDfoModel(const torch::jit::Module& m, const std::string& path) {
  const std::string format = GetString(m, "dfo_format", path);
  if (format != kModelFormatTag) {
    throw InputError(Prefix(path) + "field dfo_format = '" + format + "'; expected '" +
                     kModelFormatTag + "'");
  }
  const int version = GetInt(m, "dfo_version", path);
  if (version != kModelFileVersion) {
    throw InputError(Prefix(path) + "field dfo_version = " + std::to_string(version) +
                     "; this dfo reads version " + std::to_string(kModelFileVersion));
  }
  LoadedModel out;
  out.kind = LoadedModel::Kind::kDfo;
  NetworkOptions& o = out.options;
  o.input_width = GetInt(m, "input_width", path);
  o.input_height = GetInt(m, "input_height", path);
  o.num_levels = GetInt(m, "num_levels", path);
  o.channels = GetIntList(m, "channels", path);
  o.patch_sizes = GetIntList(m, "patch_sizes", path);
  o.rho = GetDoubleList(m, "rho", path);
  o.input_mean = GetDoubleList(m, "input_mean", path);
  o.input_std = GetDoubleList(m, "input_std", path);
  o.depth_encoder_widths = GetIntList(m, "depth_encoder_widths", path);
  o.depth_decoder_widths = GetIntList(m, "depth_decoder_widths", path);
  o.feature_encoder_widths = GetIntList(m, "feature_encoder_widths", path);
  o.feature_decoder_widths = GetIntList(m, "feature_decoder_widths", path);
  o.reconstruction_width = GetInt(m, "reconstruction_width", path);
  if (m.hasattr("notes")) out.notes = GetString(m, "notes", path);
  try {
    o.Check();
  } catch (const ConfigError& e) {
    throw InputError(Prefix(path) + "invalid metadata: " + e.what());
  }
  out.networks = Networks(o, /*seed=*/0);
  for (const char* net : {"depth", "feature"}) {
    if (!m.hasattr(net) || !m.attr(net).isModule()) {
      throw InputError(Prefix(path) + "module " + net + " (the " + net +
                       " network's weights) is missing");
    }
  }
  LoadParameters(*out.networks->depth, m.attr("depth").toModule(), "depth.", path);
  LoadParameters(*out.networks->feature, m.attr("feature").toModule(), "feature.", path);
  out.networks->eval();
  return out;
}

LoadedModel LoadScriptModel(torch::jit::Module m, const std::string& path) {
  if (m.find_method("forward") == c10::nullopt) {
    throw InputError(Prefix(path) +
                     "neither a dfo model (no field dfo_format) nor a TorchScript module with a "
                     "forward method");
  }
  if (!m.hasattr("dfo_num_levels")) {
    throw InputError(Prefix(path) +
                     "a TorchScript module without the dfo contract: field dfo_num_levels is "
                     "missing (and it is no dfo model: no field dfo_format); see "
                     "dfo_frontend/learned/internal/model_file.h for the attributes it needs");
  }
  LoadedModel out;
  out.kind = LoadedModel::Kind::kTorchScript;
  NetworkOptions& o = out.options;
  o.input_width = GetInt(m, "dfo_input_width", path);
  o.input_height = GetInt(m, "dfo_input_height", path);
  o.num_levels = GetInt(m, "dfo_num_levels", path);
  o.channels = GetIntList(m, "dfo_channels", path);
  o.patch_sizes = GetIntList(m, "dfo_patch_sizes", path);
  o.rho = GetDoubleList(m, "dfo_rho", path);
  // The widths are dfo's own networks' business; give them valid sizes so Check() reports only
  // the contract's fields.
  if (o.num_levels >= 1 && o.num_levels <= 6) {
    const size_t levels = static_cast<size_t>(o.num_levels);
    o.depth_encoder_widths.assign(std::max<size_t>(levels, 5), 8);
    o.depth_decoder_widths.assign(o.depth_encoder_widths.size(), 8);
    o.feature_encoder_widths.assign(levels, 8);
    o.feature_decoder_widths.assign(levels, 8);
  }
  try {
    o.Check();
  } catch (const ConfigError& e) {
    // Name the contract's attribute (network.channels -> dfo_channels).
    std::string msg = e.what();
    const std::string from = "network.";
    if (msg.compare(0, from.size(), from) == 0) msg = "dfo_" + msg.substr(from.size());
    throw InputError(Prefix(path) + "invalid TorchScript metadata: " + msg);
  }
  for (const auto& parameter : m.named_parameters(/*recurse=*/true)) {
    CheckPlausible(parameter.value, "parameter " + parameter.name, path);
  }
  m.eval();
  c10::IValue output;
  try {
    c10::InferenceMode guard;
    output = m.forward({torch::full({1, 3, o.input_height, o.input_width}, 0.5f)});
  } catch (const std::exception& e) {
    throw InputError(Prefix(path) + "TorchScript forward on a 1 x 3 x " +
                     std::to_string(o.input_height) + " x " + std::to_string(o.input_width) +
                     " image failed: " + FirstLine(e));
  }
  CheckScriptOutputs(output, o, o.input_width, o.input_height, "model file " + path);
  out.script = std::move(m);
  return out;
}

std::vector<torch::Tensor> TensorList(const c10::IValue& v, const std::string& name,
                                      const std::string& what) {
  if (v.isTensorList()) return v.toTensorVector();
  if (v.isList()) {
    std::vector<torch::Tensor> out;
    for (const c10::IValue& e : v.toListRef()) {
      if (!e.isTensor()) {
        throw InputError(what + ": output " + name + " holds a " + e.tagKind() +
                         "; expected tensors");
      }
      out.push_back(e.toTensor());
    }
    return out;
  }
  throw InputError(what + ": output " + name + " is a " + v.tagKind() +
                   "; expected a list of tensors");
}

void CheckShape(const torch::Tensor& t, const std::vector<int64_t>& expected,
                const std::string& name, const std::string& what) {
  if (t.sizes() == c10::IntArrayRef(expected)) return;
  throw InputError(what + ": output " + name + " has shape " + ShapeString(t.sizes()) +
                   "; expected " + ShapeString(expected));
}

}  // namespace

ScriptOutputs CheckScriptOutputs(const c10::IValue& output, const NetworkOptions& options,
                                 int width, int height, const std::string& what) {
  if (!output.isTuple() || output.toTupleRef().elements().size() != 3) {
    throw InputError(
        what + ": forward returned a " + output.tagKind() +
        (output.isTuple()
             ? " of " + std::to_string(output.toTupleRef().elements().size()) + " elements"
             : std::string()) +
        "; expected a tuple (depth list, feature list, mask-logit list)");
  }
  const auto& elements = output.toTupleRef().elements();
  ScriptOutputs out;
  out.depth = TensorList(elements[0], "depth", what);
  out.features = TensorList(elements[1], "features", what);
  out.mask_logits = TensorList(elements[2], "mask_logits", what);
  const size_t levels = static_cast<size_t>(options.num_levels);
  const std::pair<const char*, const std::vector<torch::Tensor>*> lists[] = {
      {"depth", &out.depth}, {"features", &out.features}, {"mask_logits", &out.mask_logits}};
  for (const auto& [name, list] : lists) {
    if (list->size() != levels) {
      throw InputError(what + ": output " + name + " has " + std::to_string(list->size()) +
                       " levels; expected dfo_num_levels = " + std::to_string(levels));
    }
  }
  for (int l = 0; l < options.num_levels; ++l) {
    const int64_t h = height >> l, w = width >> l;
    const std::string index = "[" + std::to_string(l) + "]";
    CheckShape(out.depth[l], {1, 1, h, w}, "depth" + index, what);
    CheckShape(out.features[l], {1, options.channels[l], h, w}, "features" + index, what);
    CheckShape(out.mask_logits[l], {1, 1, h, w}, "mask_logits" + index, what);
  }
  return out;
}

void SaveModel(const std::string& path, NetworksImpl& networks, const std::string& notes) {
  const NetworkOptions& o = networks.options();
  // Model files hold CPU tensors whatever device the networks are on (e.g. trained on a GPU), so
  // that they load anywhere: networks elsewhere are saved through a CPU copy.
  bool on_cpu = true;
  for (const torch::Tensor& t : networks.parameters()) on_cpu = on_cpu && t.device().is_cpu();
  for (const torch::Tensor& t : networks.buffers()) on_cpu = on_cpu && t.device().is_cpu();
  if (!on_cpu) {
    Networks copy(o, /*seed=*/0);
    torch::NoGradGuard no_grad;
    const auto parameters = networks.named_parameters();
    for (auto& p : copy->named_parameters()) p.value().copy_(parameters[p.key()]);
    const auto buffers = networks.named_buffers();
    for (auto& b : copy->named_buffers()) b.value().copy_(buffers[b.key()]);
    SaveModel(path, *copy, notes);
    return;
  }
  torch::serialize::OutputArchive archive;
  archive.write("dfo_format", c10::IValue(std::string(kModelFormatTag)));
  archive.write("dfo_version", c10::IValue(int64_t{kModelFileVersion}));
  archive.write("input_width", c10::IValue(int64_t{o.input_width}));
  archive.write("input_height", c10::IValue(int64_t{o.input_height}));
  archive.write("num_levels", c10::IValue(int64_t{o.num_levels}));
  archive.write("channels", c10::IValue(ToInt64(o.channels)));
  archive.write("patch_sizes", c10::IValue(ToInt64(o.patch_sizes)));
  archive.write("rho", c10::IValue(o.rho));
  archive.write("input_mean", c10::IValue(o.input_mean));
  archive.write("input_std", c10::IValue(o.input_std));
  archive.write("depth_encoder_widths", c10::IValue(ToInt64(o.depth_encoder_widths)));
  archive.write("depth_decoder_widths", c10::IValue(ToInt64(o.depth_decoder_widths)));
  archive.write("feature_encoder_widths", c10::IValue(ToInt64(o.feature_encoder_widths)));
  archive.write("feature_decoder_widths", c10::IValue(ToInt64(o.feature_decoder_widths)));
  archive.write("reconstruction_width", c10::IValue(int64_t{o.reconstruction_width}));
  archive.write("notes", c10::IValue(notes));
  torch::serialize::OutputArchive depth_archive, feature_archive;
  networks.depth->save(depth_archive);
  networks.feature->save(feature_archive);
  archive.write("depth", depth_archive);
  archive.write("feature", feature_archive);
  try {
    archive.save_to(path);
  } catch (const std::exception& e) {
    throw InputError(Prefix(path) + "cannot write: " + FirstLine(e));
  }
}

LoadedModel LoadModel(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    throw InputError(Prefix(path) + "not found (expected a dfo model or a TorchScript file)");
  }
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(Prefix(path) + (std::filesystem::is_directory(path, ec)
                                         ? "is a folder, expected a model file (.dfo or .pt)"
                                         : "is not a regular file"));
  }
  // LibTorch reads the archive without checking its CRC-32s: a file changed after it was written
  // would load. A file that is no ZIP archive at all is left to LibTorch's message below.
  CheckZipArchive(path, "model file " + path);
  torch::jit::Module m;
  try {
    m = torch::jit::load(path, torch::kCPU);
  } catch (const std::exception& e) {
    throw InputError(
        Prefix(path) +
        "not a dfo model or TorchScript archive (LibTorch cannot read it: " + FirstLine(e) + ")");
  }
  if (m.hasattr("dfo_format")) return LoadDfoModel(m, path);
  return LoadScriptModel(std::move(m), path);
}

}  // namespace dfo::learned
