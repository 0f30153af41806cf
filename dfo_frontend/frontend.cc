// Placeholder until the tracker lands; replaced by the frontend sources.
namespace dfo {}
