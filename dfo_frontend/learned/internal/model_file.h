// Model files (internal: includes LibTorch). Two kinds are read, one is written.
//
// 1. dfo's own model file ("dfo-model", written by SaveModel): ONE torch::serialize archive (a
//    TorchScript-format zip, as torch::save writes) holding both networks' weights and the
//    metadata as typed attributes:
//      dfo_format            str        "dfo-model"
//      dfo_version           int        kModelFileVersion (1)
//      input_width, input_height, num_levels, reconstruction_width                  int
//      channels, patch_sizes, depth_encoder_widths, depth_decoder_widths,
//      feature_encoder_widths, feature_decoder_widths                               List[int]
//      rho, input_mean, input_std                                                   List[float]
//      notes                 str        free text (how the model was made)
//      depth, feature        nested archives: DepthNet / FeatureNet parameters by name
//    The metadata fields are exactly NetworkOptions (network_options.h); the normalisation
//    (input_mean/input_std) is applied inside the networks, which take RGB in [0, 1].
//
// 2. A TorchScript module trained elsewhere (torch.jit.script/trace + torch.jit.save). Contract:
//      attributes  dfo_input_width: int, dfo_input_height: int, dfo_num_levels: int (L),
//                  dfo_channels: List[int] (C_l, L entries), dfo_patch_sizes: List[int] (L, odd),
//                  dfo_rho: List[float] (L entries in (0, 1])
//      forward(image: Tensor) -> Tuple[List[Tensor], List[Tensor], List[Tensor]]
//        image:  1 x 3 x H x W float32 RGB in [0, 1] (H = dfo_input_height, W = dfo_input_width;
//                any normalisation happens inside the module)
//        returns (depth, features, mask_logits), each a list of L tensors, finest first, level l
//                of size H_l = H >> l, W_l = W >> l:
//                depth[l]        1 x 1 x H_l x W_l   metres (> 0; <= 0 or non-finite = invalid)
//                features[l]     1 x C_l x H_l x W_l (any real values; dfo z-scores them)
//                mask_logits[l]  1 x 1 x H_l x W_l   larger = more selectable; dfo keeps the top
//                                                    rho_l fraction of each level
//    Loading checks the attributes and runs forward once on a grey image of the declared size
//    to check every output shape.
//
// Every failure throws InputError naming the file and the field (or parameter) with what was
// found and what was expected.
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_MODEL_FILE_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_MODEL_FILE_H_

#include <torch/script.h>
#include <torch/torch.h>

#include <string>

#include "dfo_frontend/learned/internal/networks.h"
#include "dfo_frontend/learned/network_options.h"

namespace dfo::learned {

constexpr const char* kModelFormatTag = "dfo-model";
constexpr int kModelFileVersion = 1;
// Weights beyond this magnitude make LoadModel refuse the file (model_file.cc, CheckPlausible).
constexpr double kMaxPlausibleWeight = 1e4;

// Writes both networks and their options to `path` (format 1 above), overwriting it. `notes`
// (e.g. the training command and config) is stored verbatim. The file holds CPU tensors also
// when the networks are on a GPU. Throws InputError when the file cannot be written.
void SaveModel(const std::string& path, NetworksImpl& networks, const std::string& notes = "");

// What a model file held.
struct LoadedModel {
  enum class Kind { kDfo, kTorchScript };
  Kind kind = Kind::kDfo;
  // For kDfo every field; for kTorchScript input size, num_levels, channels, patch_sizes and rho
  // (the other fields keep their defaults and are meaningless).
  NetworkOptions options;
  std::string notes;           // kDfo only
  Networks networks{nullptr};  // kDfo: both networks with the file's weights, eval mode
  torch::jit::Module script;   // kTorchScript: the (eval-mode) module
};

// Reads a model file of either kind. Throws InputError naming `path` and the field: missing or
// unreadable file, not a torch archive (e.g. a PNG), a torch file that is neither format (e.g. a
// torch.save'd tensor or a TorchScript module without the contract's attributes), unsupported
// version, invalid metadata (NetworkOptions::Check), a parameter missing or of another shape than
// the metadata implies, TorchScript outputs of the wrong structure or shape, an archive entry whose
// CRC-32 or size does not match (the file was changed after it was written; CheckZipArchive),
// a weight that is non-finite or beyond kMaxPlausibleWeight in magnitude (named with its tensor).
LoadedModel LoadModel(const std::string& path);

// Checks the structure and shapes of one TorchScript forward output for an input of
// width x height: throws InputError "<what>: <field> ..." (what = e.g. "model m.pt, frame 12").
// Returns (depth, features, mask_logits) as tensor lists.
struct ScriptOutputs {
  std::vector<torch::Tensor> depth, features, mask_logits;
};
ScriptOutputs CheckScriptOutputs(const c10::IValue& output, const NetworkOptions& options,
                                 int width, int height, const std::string& what);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_MODEL_FILE_H_
