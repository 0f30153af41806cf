// The configuration sections `frontend`, `tracker` and `reference` (and run.threads) as
// FrontendOptions. The schema lives in dfo_io/config_schema.cc, which cannot see the frontend's
// structs; a test keeps the schema's defaults equal to FrontendOptions{}.
#ifndef DFO_APPS_COMMON_FRONTEND_CONFIG_H_
#define DFO_APPS_COMMON_FRONTEND_CONFIG_H_

#include <functional>

#include "dfo_frontend/frontend.h"
#include "dfo_io/config.h"

namespace dfo::apps {

// Builds FrontendOptions from a Config of io::DfoSchema(): frontend.* -> features, depth and the
// hand-made feature options, tracker.* -> TrackerOptions, reference.* -> ReferenceOptions,
// run.threads -> num_threads (0 = std::thread::hardware_concurrency(), at least 1). Then checks
// the result (FrontendOptions::Check) and throws ConfigError on a rule the schema cannot express
// (e.g. an even tracker.patch_size).
// frontend.depth = auto becomes "gt" when `dataset_has_depth` (the dataset has depth maps), else
// "learned".
FrontendOptions FrontendOptionsFromConfig(const io::Config& config, bool dataset_has_depth = true);

// Runs an options struct's `check` (its Check()); a ConfigError it throws is rethrown with the key
// as the configuration spells it (the library's "frontend.tracker.max_rmse_ok" is the key
// tracker.max_rmse_ok) and where the value came from: "(--set)", "(configs/my.yaml:12)" or
// "(default)".
void CheckInConfigTerms(const io::Config& config, const std::function<void()>& check);

// The thread count `run.threads` asks for (0 = all hardware threads, at least 1).
int ThreadsFromConfig(const io::Config& config);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_FRONTEND_CONFIG_H_
