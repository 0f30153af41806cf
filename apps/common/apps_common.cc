// Shared by dfo apps (evaluation, configuration wiring); see apps/common/*.h.
namespace dfo::apps {}
