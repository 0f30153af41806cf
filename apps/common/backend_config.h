// The configuration sections `keyframe`, `window` and `backend` and the key `run.mode` as the
// backend's option structs. The schema lives in dfo_io/config_schema.cc, which cannot see the
// backend's structs; tests/apps/backend_config_test.cc keeps the schema's defaults equal to
// KeyframeOptions{} and WindowOptions{}.
#ifndef DFO_APPS_COMMON_BACKEND_CONFIG_H_
#define DFO_APPS_COMMON_BACKEND_CONFIG_H_

#include <string>

#include "dfo_backend/keyframe_manager.h"
#include "dfo_backend/odometry.h"
#include "dfo_backend/window_optimizer.h"
#include "dfo_io/config.h"

namespace dfo::apps {

// What dfo_run estimates from its one frontend pass (run.mode): kFrontend writes the
// frontend-only trajectory (frontend_*.txt), kWindowed the sliding-window bundle-adjusted one
// (windowed_*.txt, keyframes_tum.txt), kBoth both side by side.
using RunMode = OdometryMode;

// "frontend", "windowed", "both".
const char* RunModeName(RunMode mode);
// Parses run.mode; throws ConfigError naming the key and the known values otherwise.
RunMode ParseRunMode(const std::string& value);
// run.mode of a Config of io::DfoSchema().
RunMode RunModeFromConfig(const io::Config& config);

// The keyframe.* keys (except decided_by) as KeyframeOptions, checked (KeyframeOptions::Check
// throws ConfigError on contradictions such as min_interval > max_interval).
KeyframeOptions KeyframeOptionsFromConfig(const io::Config& config);

// The window.* and backend.* keys as WindowOptions, num_threads from run.threads (0 = all
// hardware threads); checked (WindowOptions::Check throws ConfigError naming the key). With
// run.deterministic = true: num_threads = 1 and max_solver_time_s = kDeterministicSolverTimeS
// (a wall-clock limit would make the result depend on the machine's load), so that Ceres gives
// byte-identical results run to run; window.max_iterations still bounds each solve.
constexpr double kDeterministicSolverTimeS = 1e6;
WindowOptions WindowOptionsFromConfig(const io::Config& config);

// keyframe.decided_by = manager: the frontend runs with reference.policy "external" and the
// keyframe manager switches it; = frontend: the frontend's own rule ("internal").
std::string ReferencePolicyFromConfig(const io::Config& config);

// tracker.depth, tracker.depth_fill, tracker.min_window_points, tracker.splat_radius_px and
// window.initial_depth_scale, window.source_scale as TrackingDepthOptions, checked.
TrackingDepthOptions TrackingDepthOptionsFromConfig(const io::Config& config);

// stereo.* as KeyframeStereoOptions, checked.
KeyframeStereoOptions KeyframeStereoOptionsFromConfig(const io::Config& config);

// The whole OdometryOptions of a configuration (run.mode, keyframe.*, window.*, backend.*, the
// tracking depth, run.backend_thread unless run.deterministic), checked.
OdometryOptions OdometryOptionsFromConfig(const io::Config& config);

}  // namespace dfo::apps

#endif  // DFO_APPS_COMMON_BACKEND_CONFIG_H_
