// Image pyramids for coarse-to-fine direct alignment: level 0 is the input image, each further
// level halves width and height by 2x2 averaging, and carries the matching pinhole camera
// (PinholeCamera::PyramidLevel), so that a 3D point projects at level l exactly where the level's
// pixels show it.
#ifndef DFO_CORE_IMAGE_PYRAMID_H_
#define DFO_CORE_IMAGE_PYRAMID_H_

#include <vector>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"

namespace dfo {

// How many levels to build and how small the coarsest may get.
struct ImagePyramidOptions {
  // Number of levels including level 0 (the input). >= 1. The DFO paper uses 4.
  int num_levels = 4;
  // The coarsest level must be at least this many pixels wide and high. >= 1. Direct alignment
  // needs a few pixels for gradients and patches; 416 x 128 with 4 levels gives 52 x 16.
  int min_level_size = 8;

  // Throws ConfigError naming the field, its value and the broken rule
  // ("pyramid.num_levels = 0 violates >= 1").
  void Check() const;
};

// Halves an image (any channel count) by 2x2 averaging: output pixel (i, j) is the mean of input
// pixels (2i, 2j), (2i+1, 2j), (2i, 2j+1), (2i+1, 2j+1); an odd last row or column is dropped.
// In continuous coordinates (pixel centres at integers) output u maps to input 2u + 0.5, the same
// mapping as PinholeCamera::PyramidLevel(1). Throws InputError when the image is smaller than 2x2.
ImageF DownsampleHalf(const ImageF& image);

// Halves a depth map by validity-aware 2x2 averaging: the output is the mean of the valid
// (finite, > 0) input depths of the 2x2 block, 0 when none is valid (an invalid 0 is never
// averaged in). Odd last row/column dropped as DownsampleHalf. Requires a 1-channel map >= 2x2.
ImageF DownsampleDepthHalf(const ImageF& depth_m);

// Separable Gaussian blur of a one-channel image with clamped borders, kernel radius
// ceil(3 sigma); sigma > 0.
ImageF GaussianBlur(const ImageF& image, double sigma);

// Horizontal and vertical derivatives of an image, same size and channel count as it, in
// intensity per pixel.
struct ImageGradients {
  ImageF gx;  // d I / d x (along a row)
  ImageF gy;  // d I / d y (down a column)
};

// Central differences (I(x+1) - I(x-1)) / 2 in the interior; one-sided differences
// I(1) - I(0) and I(w-1) - I(w-2) on the first and last column (row); zero along an axis of size 1.
// Exact for images linear in x and y, and in the interior for quadratics.
ImageGradients ComputeGradients(const ImageF& image);

// The levels of one image with their cameras. Level l has size (w >> l) x (h >> l) (sizes halved
// with truncation at each step) and camera camera.PyramidLevel(l).
class ImagePyramid {
 public:
  // An empty pyramid (num_levels() == 0).
  ImagePyramid() = default;

  // Builds the pyramid of `image` (float, any channel count; grey values keep their units) seen
  // by `camera`. Throws ConfigError from options.Check(), InputError when the image is empty,
  // when its size differs from the camera's, or when the coarsest level would be smaller than
  // options.min_level_size (the message gives the sizes and the number of levels that fit).
  ImagePyramid(const ImageF& image, const PinholeCamera& camera,
               const ImagePyramidOptions& options = ImagePyramidOptions());

  // Number of levels (0 for a default-constructed pyramid).
  int num_levels() const { return static_cast<int>(levels_.size()); }
  // Image of level l, 0 <= l < num_levels() (DFO_CHECK otherwise).
  const ImageF& level(int l) const;
  // Camera of level l, 0 <= l < num_levels() (DFO_CHECK otherwise).
  const PinholeCamera& camera(int l) const;
  // ComputeGradients(level(l)).
  ImageGradients Gradients(int l) const;

  // The largest number of levels (<= max_levels) whose coarsest level of a width x height image
  // is still at least min_level_size pixels wide and high (0 if even level 0 is smaller).
  static int MaxLevels(int width, int height, int min_level_size, int max_levels = 32);

 private:
  std::vector<ImageF> levels_;
  std::vector<PinholeCamera> cameras_;
};

}  // namespace dfo

#endif  // DFO_CORE_IMAGE_PYRAMID_H_
