// Depth maps as pictures: log-scaled turbo colours (near = warm), no depth black.
#ifndef DFO_IO_DEPTH_COLOUR_H_
#define DFO_IO_DEPTH_COLOUR_H_

#include "dfo_core/image.h"

namespace dfo::io {

// RGB picture of `depth` (metres, 0 or non-finite = no depth, black): depth d takes the turbo
// colour at log(d / near_m) / log(far_m / near_m), clamped to [0, 1]. Needs 0 < near_m < far_m.
ImageU8 ColourDepth(const ImageF& depth, double near_m, double far_m);

// The turbo colour (RGB) of position t in [0, 1] on the depth scale (0 = near).
void DepthScaleColour(double t, uint8_t rgb[3]);

}  // namespace dfo::io

#endif  // DFO_IO_DEPTH_COLOUR_H_
