// Feature and depth pyramids: where the frontend (which computes and tracks them) and the backend
// (which optimises keyframes with them) meet. Eigen and the standard library only.
//
// A FeaturePyramid holds, per level (level 0 = working resolution, each further level halves
// width and height as PinholeCamera::PyramidLevel), a C-channel float feature map stored planar
// (channel-major, C x H x W) with the level's camera and an optional selection mask. A
// DepthPyramid holds the depth (metres, 0 = invalid) aligned with the feature level of the same
// index.
#ifndef DFO_CORE_FEATURE_MAP_H_
#define DFO_CORE_FEATURE_MAP_H_

#include <cstddef>
#include <cstdint>
#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"

namespace dfo {

// One level of a feature pyramid.
struct FeatureLevel {
  int width = 0;     // pixels
  int height = 0;    // pixels
  int channels = 0;  // C >= 1
  // Planar features: value of channel c at pixel (x, y) is data[(c * height + y) * width + x].
  std::vector<float> data;
  // Intrinsics of this level (camera.width == width, camera.height == height).
  PinholeCamera camera;
  // Optional selection mask, width * height values row-major; non-zero = the pixel may be
  // selected as a patch centre. Empty = no mask (the tracker selects high-gradient pixels).
  std::vector<uint8_t> mask;
  // Optional, one value per channel: the order of the spatial derivative (in pixels) the channel
  // holds, 0 for intensity-like channels, 1 for gradients. A view that sees the surface s times
  // larger sees a first-derivative channel 1 / s as steep, so a consumer comparing views at
  // different zooms can rescale it (WindowOptions::zoom_scaled_gradients). Empty = unknown (every
  // channel treated as 0, e.g. learned features).
  std::vector<int> derivative_order;

  // Allocates width x height x channels zeros (mask left empty).
  FeatureLevel(int width, int height, int channels, const PinholeCamera& camera);
  FeatureLevel() = default;

  // Start of channel c (row-major width x height floats).
  float* Channel(int c) { return data.data() + static_cast<size_t>(c) * width * height; }
  const float* Channel(int c) const {
    return data.data() + static_cast<size_t>(c) * width * height;
  }
  // Value of channel c at integer pixel (x, y).
  float At(int c, int x, int y) const {
    return data[(static_cast<size_t>(c) * height + y) * width + x];
  }
  bool has_mask() const { return !mask.empty(); }

  // Normalises every channel to zero mean and unit standard deviation over the level (the DFO
  // paper's per-channel, per-level z-scoring); a constant channel becomes all zeros.
  void ZScore();
};

// Every channel of `level` blurred by dfo_core's separable Gaussian (GaussianBlur of
// image_pyramid.h: clamped borders, radius ceil(3 sigma)); sigma > 0. Camera and mask are kept.
FeatureLevel GaussianBlur(const FeatureLevel& level, double sigma);

// The levels of one frame's features, finest first.
struct FeaturePyramid {
  std::vector<FeatureLevel> levels;
  int num_levels() const { return static_cast<int>(levels.size()); }
};

// Depth maps of one frame, finest first; level l has size (width >> l) x (height >> l).
struct DepthPyramid {
  std::vector<ImageF> levels;  // metres, 0 = invalid (never NaN/inf: sources replace them by 0)
  int num_levels() const { return static_cast<int>(levels.size()); }
  // Mean of the valid (> 0) depths of level l; 0 when the level has none.
  double MeanDepth(int l) const;
  // Number of valid depths of level l.
  int NumValid(int l) const;
  // Multiplies every depth of every level by `factor` (invalid zeros stay zero).
  void Scale(double factor);
};

}  // namespace dfo

#endif  // DFO_CORE_FEATURE_MAP_H_
