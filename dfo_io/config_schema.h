// dfo's configuration schema: every section and key the programs accept, with defaults, ranges and
// docs, in one place. configs/default.yaml is this schema's ToYaml() output (a test keeps them
// equal). Later modules add their sections (keyframe, window, backend, lcm) here.
//
// Sections known now:
//   dataset  which sequence to read and how to load it (DatasetOptions, dfo_io/dataset.h)
//   synth    the procedural synthetic sequence (dfo_core/synthetic/options.h)
//   frontend feature and depth sources, hand-made feature options (FrontendOptions)
//   learned  the model file of the learned sources and its overrides (LearnedModelOptions,
//            dfo_frontend/learned/learned_sources.h)
//   tracker  the direct feature-metric tracker (TrackerOptions, dfo_frontend/tracker.h)
//   reference the frontend's own reference-switch rule (ReferenceOptions,
//            dfo_frontend/reference_options.h), used when keyframe.decided_by = frontend
//   keyframe the keyframe manager (KeyframeOptions, dfo_backend/keyframe_manager.h)
//   window   the sliding-window bundle adjustment (WindowOptions, dfo_backend/window_optimizer.h)
//   backend  its solver, loss, priors and marginalisation (WindowOptions too)
//   run      mode (frontend, windowed, both), output folder, determinism, threads, progress, plot
//   lcm      LCM streaming and event log of dfo_run (apps/common/lcm_streaming.h)
#ifndef DFO_IO_CONFIG_SCHEMA_H_
#define DFO_IO_CONFIG_SCHEMA_H_

#include "dfo_io/config.h"
#include "dfo_io/dataset.h"

namespace dfo::io {

// The full schema of dfo's configuration.
const ConfigSchema& DfoSchema();

// The `dataset` section as DatasetOptions (then checked with DatasetOptions::Check, except that an
// empty dataset.path is allowed here: the caller decides whether it needs a dataset).
DatasetOptions DatasetOptionsFromConfig(const Config& config);

}  // namespace dfo::io

#endif  // DFO_IO_CONFIG_SCHEMA_H_
