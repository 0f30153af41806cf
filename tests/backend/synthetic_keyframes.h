// Test support for dfo_backend: KeyframeData from the synthetic sequence, rendered in memory, with
// simple hand-made features (dfo_backend may not use dfo_frontend, so its feature sources are not
// available here): per level, grey intensity and its two central-difference gradients, each
// channel z-scored over the level (the DFO paper's normalisation).
#ifndef DFO_TESTS_BACKEND_SYNTHETIC_KEYFRAMES_H_
#define DFO_TESTS_BACKEND_SYNTHETIC_KEYFRAMES_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "dfo_core/keyframe.h"
#include "dfo_core/synthetic/synthetic_sequence.h"

namespace dfo::test {

// Grey in [0, 1] halved by 2x2 averaging.
inline ImageF HalveGray(const ImageF& g) {
  ImageF out(g.width() / 2, g.height() / 2);
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) {
      out(x, y) = 0.25f * (g(2 * x, 2 * y) + g(2 * x + 1, 2 * y) + g(2 * x, 2 * y + 1) +
                           g(2 * x + 1, 2 * y + 1));
    }
  }
  return out;
}

// Depth halved by averaging the valid (> 0) values of each 2x2 block.
inline ImageF HalveDepth(const ImageF& d) {
  ImageF out(d.width() / 2, d.height() / 2);
  for (int y = 0; y < out.height(); ++y) {
    for (int x = 0; x < out.width(); ++x) {
      float sum = 0.0f;
      int n = 0;
      for (int dy = 0; dy < 2; ++dy) {
        for (int dx = 0; dx < 2; ++dx) {
          const float v = d(2 * x + dx, 2 * y + dy);
          if (std::isfinite(v) && v > 0.0f) {
            sum += v;
            ++n;
          }
        }
      }
      out(x, y) = n > 0 ? sum / n : 0.0f;
    }
  }
  return out;
}

// Intensity + x/y gradient features (3 channels), z-scored.
inline FeatureLevel GrayFeatures(const ImageF& g, const PinholeCamera& camera) {
  const int w = g.width(), h = g.height();
  FeatureLevel level(w, h, 3, camera);
  level.derivative_order = {0, 1, 1};  // intensity, x and y gradients (as the hand-made ones)
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int xm = std::max(x - 1, 0), xp = std::min(x + 1, w - 1);
      const int ym = std::max(y - 1, 0), yp = std::min(y + 1, h - 1);
      level.Channel(0)[y * w + x] = g(x, y);
      level.Channel(1)[y * w + x] = 0.5f * (g(xp, y) - g(xm, y));
      level.Channel(2)[y * w + x] = 0.5f * (g(x, yp) - g(x, ym));
    }
  }
  level.ZScore();
  return level;
}

// Keyframe of synthetic frame `index` (num_levels levels, pose = ground truth). With
// depth_noise > 0 every depth is multiplied by exp(N(0, depth_noise)) (seeded by the index).
inline KeyframeData MakeSyntheticKeyframe(const SyntheticSequence& sequence, int index,
                                          int num_levels = 2, double depth_noise = 0.0) {
  const SyntheticFrame frame = sequence.RenderFrame(index);
  KeyframeData kf;
  kf.frame_index = index;
  kf.timestamp_ns = frame.timestamp_ns;
  kf.world_from_cam = frame.world_from_cam;
  ImageF gray(frame.gray.width(), frame.gray.height());
  for (size_t i = 0; i < gray.size(); ++i) gray.vector()[i] = frame.gray.vector()[i] / 255.0f;
  ImageF depth = frame.depth;
  if (depth_noise > 0.0) {
    std::mt19937 rng(1000 + index);
    std::normal_distribution<double> noise(0.0, depth_noise);
    for (float& v : depth.vector()) {
      if (v > 0.0f) v = static_cast<float>(v * std::exp(noise(rng)));
    }
  }
  for (int l = 0; l < num_levels; ++l) {
    if (l > 0) {
      gray = HalveGray(gray);
      depth = HalveDepth(depth);
    }
    kf.features.levels.push_back(GrayFeatures(gray, sequence.camera().PyramidLevel(l)));
    kf.depth.levels.push_back(depth);
  }
  return kf;
}

}  // namespace dfo::test

#endif  // DFO_TESTS_BACKEND_SYNTHETIC_KEYFRAMES_H_
