#include "dfo_core/synthetic/synthetic_sequence.h"

#include "dfo_core/error.h"

namespace dfo {

SyntheticSequence::SyntheticSequence(const SyntheticOptions& options) : options_(options) {
  options_.Check();
  camera_ = options_.Camera();
  world_ = synthetic::SyntheticWorld::Build(options_);
  // World = first camera (KITTI): world_from_cam_k = (map_from_cam_0)^-1 * map_from_cam_k.
  map_from_world_ = world_.frames.front().map_from_cam;
  const SE3d world_from_map = map_from_world_.Inverse();
  world_from_cam_.reserve(world_.frames.size());
  for (const auto& f : world_.frames) world_from_cam_.push_back(world_from_map * f.map_from_cam);
  world_from_cam_.front() = SE3d();  // exactly the identity, not a round-off of it
}

const SE3d& SyntheticSequence::WorldFromCam(int i) const {
  DFO_CHECK(i >= 0 && i < num_frames()) << "frame " << i << " of " << num_frames();
  return world_from_cam_[i];
}

int64_t SyntheticSequence::TimestampNs(int i) const {
  return SecondsToNs(i * options_.frame_interval_s);
}

Trajectory SyntheticSequence::GroundTruth() const {
  Trajectory trajectory;
  for (int i = 0; i < num_frames(); ++i) trajectory.Add(TimestampNs(i), world_from_cam_[i]);
  return trajectory;
}

synthetic::RenderedView SyntheticSequence::RenderPose(const SE3d& world_from_cam,
                                                      int num_threads) const {
  return synthetic::RenderView(world_, camera_, map_from_world_ * world_from_cam, options_,
                               num_threads);
}

SyntheticFrame SyntheticSequence::RenderFrame(int i, int num_threads) const {
  DFO_CHECK(i >= 0 && i < num_frames()) << "frame " << i << " of " << num_frames();
  synthetic::RenderedView view =
      synthetic::RenderView(world_, camera_, world_.frames[i].map_from_cam, options_, num_threads);
  SyntheticFrame frame;
  frame.index = i;
  frame.timestamp_ns = TimestampNs(i);
  frame.world_from_cam = world_from_cam_[i];
  frame.gray = std::move(view.gray);
  frame.rgb = std::move(view.rgb);
  frame.depth = std::move(view.depth);
  frame.labels = std::move(view.labels);
  return frame;
}

}  // namespace dfo
