// Stub (replaced below in this session).
#include "dfo_frontend/frontend.h"
namespace dfo {
struct Frontend::State {};
Frontend::Frontend(const FrontendOptions& options) : options_(options), tracker_(options.tracker) {
  options_.Check();
  features_ = MakeFeatureSource(options_.features, options_.handmade);
  depth_ = MakeDepthSource(options_.depth);
  state_ = std::make_unique<State>();
}
Frontend::~Frontend() = default;
TrackedFrame Frontend::Process(const Frame& frame) {
  TrackedFrame out;
  out.index = frame.index;
  out.timestamp_ns = frame.timestamp_ns;
  return out;
}
const FrontendTimings& Frontend::last_timings() const { return timings_; }
void Frontend::Reset() {}
const FrontendOptions& Frontend::options() const { return options_; }
}  // namespace dfo
