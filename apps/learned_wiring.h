// The learned sources in the Torch applications (dfo_run, dfo_bench): the configuration section
// `learned` as LearnedModelOptions, and the frontend's sources made from ONE loaded model when
// frontend.features or frontend.depth is "learned":
//
//   const FrontendOptions frontend_options = apps::FrontendOptionsFromConfig(config);
//   apps::FrontendSources sources =
//       apps::MakeFrontendSources(frontend_options, apps::LearnedModelOptionsFromConfig(config));
//   Frontend frontend(frontend_options, std::move(sources.features), std::move(sources.depth));
//
// Header-only on purpose: apps/common (dfo_apps_common) does not link dfo::learned, so that
// dfo_eval and dfo_synth neither link nor load LibTorch; only the executables that link
// dfo::learned (compile definition DFO_HAVE_LEARNED) get MakeFrontendSources. The configuration
// part (LearnedModelOptionsFromConfig, UsesLearnedSources) uses no dfo::learned symbol, so the
// app tests can check the schema's defaults against LearnedModelOptions{} without linking Torch.
#ifndef DFO_APPS_LEARNED_WIRING_H_
#define DFO_APPS_LEARNED_WIRING_H_

#include <memory>
#include <string>
#include <vector>

#include "apps/common/frontend_config.h"
#include "dfo_core/error.h"
#include "dfo_frontend/depth_source.h"
#include "dfo_frontend/feature_source.h"
#include "dfo_frontend/frontend.h"
#include "dfo_frontend/learned/learned_sources.h"
#include "dfo_io/config.h"

namespace dfo::apps {

// The `learned` section of an io::DfoSchema() Config as LearnedModelOptions (not checked; the
// model's loading checks them): learned.model -> model_path, learned.threads -> num_threads
// (0 = run.threads, see ThreadsFromConfig), num_levels, channels, rho, require_input_size,
// depth_at_model_size, device.
inline LearnedModelOptions LearnedModelOptionsFromConfig(const io::Config& config) {
  LearnedModelOptions o;
  o.model_path = config.GetString("learned.model");
  const int threads = config.GetInt("learned.threads");
  o.num_threads = threads > 0 ? threads : ThreadsFromConfig(config);
  o.num_levels = config.GetInt("learned.num_levels");
  o.channels = config.GetIntList("learned.channels");
  o.rho = config.GetDoubleList("learned.rho");
  o.require_input_size = config.GetBool("learned.require_input_size");
  o.depth_at_model_size = config.GetBool("learned.depth_at_model_size");
  o.device = config.GetString("learned.device");
  return o;
}

// True when the options name a learned feature or depth source (then a model must be loaded).
inline bool UsesLearnedSources(const FrontendOptions& options) {
  return options.features == "learned" || options.depth == "learned";
}

// The sources to hand to the Frontend: the learned ones made from `model`, null for the others
// (the Frontend makes those by name).
struct FrontendSources {
  std::shared_ptr<LearnedModel> model;      // null when no source is learned
  std::unique_ptr<FeatureSource> features;  // non-null iff options.features == "learned"
  std::unique_ptr<DepthSource> depth;       // non-null iff options.depth == "learned"
};

#ifdef DFO_HAVE_LEARNED
// Loads the model once when `options` name a learned source and makes those sources; returns
// empty sources otherwise (the model file is then not read). Throws InputError when the model
// file is missing or bad (the message names the file, the frontend key that needs it and
// learned.model), ConfigError on bad learned.* values and when learned features have fewer
// levels than tracker.num_levels.
inline FrontendSources MakeFrontendSources(const FrontendOptions& options,
                                           const LearnedModelOptions& model_options) {
  FrontendSources sources;
  if (!UsesLearnedSources(options)) return sources;
  const std::string needed_by =
      options.features == "learned"
          ? (options.depth == "learned" ? "frontend.features and frontend.depth = learned"
                                        : "frontend.features = learned")
          : "frontend.depth = learned";
  try {
    sources.model = LoadLearnedModel(model_options);
  } catch (const InputError& e) {
    // One line: the loader names the file and what is wrong; say which key wanted it.
    throw InputError(std::string(e.what()) + " (learned.model, needed by " + needed_by + ")");
  }
  const LearnedModelInfo& info = sources.model->info();
  if (options.features == "learned" && info.num_levels < options.tracker.num_levels) {
    throw ConfigError("tracker.num_levels = " + std::to_string(options.tracker.num_levels) +
                      " violates <= the levels of the learned model " + info.path + " (" +
                      std::to_string(info.num_levels) + ") with frontend.features = learned");
  }
  if (options.features == "learned") sources.features = MakeLearnedFeatureSource(sources.model);
  if (options.depth == "learned") sources.depth = MakeLearnedDepthSource(sources.model);
  return sources;
}

// One line describing the loaded model for the start-up message: "model FILE (dfo, 416x128,
// 4 levels, channels 8/8/16/16)".
inline std::string DescribeLearnedModel(const LearnedModel& model) {
  const LearnedModelInfo& info = model.info();
  std::string channels;
  for (size_t i = 0; i < info.channels.size(); ++i) {
    channels += (i ? "/" : "") + std::to_string(info.channels[i]);
  }
  return "model " + info.path + " (" + info.kind + ", " + std::to_string(info.input_width) + "x" +
         std::to_string(info.input_height) + ", " + std::to_string(info.num_levels) +
         " levels, channels " + channels + ")";
}
#endif  // DFO_HAVE_LEARNED

}  // namespace dfo::apps

#endif  // DFO_APPS_LEARNED_WIRING_H_
