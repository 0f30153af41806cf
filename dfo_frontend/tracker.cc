// Stub (replaced below in this session).
#include "dfo_frontend/tracker.h"
namespace dfo {
struct Tracker::Level {};
struct Tracker::LevelResult {};
Tracker::Tracker(const TrackerOptions& options) : options_(options) { options_.Check(); }
Tracker::~Tracker() = default;
Tracker::Tracker(Tracker&&) noexcept = default;
Tracker& Tracker::operator=(Tracker&&) noexcept = default;
int Tracker::SetReference(const FeaturePyramid&, const DepthPyramid&) { return 0; }
double Tracker::reference_mean_depth(int) const { return 0; }
int Tracker::num_reference_points(int) const { return 0; }
TrackResult Tracker::Track(const FeaturePyramid&, const std::vector<SE3d>&) { return {}; }
std::vector<SE3d> Tracker::MakeHypotheses(const SE3d&, const SE3d&) const { return {}; }
void Tracker::Linearize(const FeaturePyramid&, int, const SE3d&, Eigen::VectorXd*,
                        Eigen::MatrixXd*, std::vector<int>*) const {}
Eigen::VectorXd Tracker::InverseCompositionalResiduals(const FeaturePyramid&, int, const SE3d&,
                                                       const Vector6d&) const {
  return {};
}
double Tracker::OutlierThreshold(std::vector<double>) { return 0; }
}  // namespace dfo
