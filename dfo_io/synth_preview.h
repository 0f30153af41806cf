// A preview picture of a synthetic sequence: a few frames with their depth maps, and the drive
// seen from above with the buildings and parked cars, to check a generated sequence at a glance.
#ifndef DFO_IO_SYNTH_PREVIEW_H_
#define DFO_IO_SYNTH_PREVIEW_H_

#include <string>

#include "dfo_core/image.h"
#include "dfo_core/synthetic/synthetic_sequence.h"

namespace dfo::io {

// What the preview shows.
struct SynthPreviewOptions {
  // Frames shown (evenly spread over the sequence, first and last included), in [1, 12].
  int num_frames = 5;
  // Depth colour scale (logarithmic) in metres: near end, far end; 0 < near < far.
  double depth_near_m = 2.0;
  double depth_far_m = 150.0;
  // Threads used to render the shown frames, >= 1.
  int num_threads = 2;

  // Throws dfo::ConfigError naming the field, its value and the rule.
  void Check() const;
};

// The preview as an RGB image. Left: one row per shown frame, the colour image beside its depth
// map (log-scaled turbo colours, sky / no depth black) with a colour bar in metres below. Right:
// top view (world x-z plane, metres) of the street, the buildings' footprints, the parked cars,
// the path from the start marker to the end, and the shown frames' positions numbered.
ImageU8 RenderSyntheticPreview(const SyntheticSequence& sequence,
                               const SynthPreviewOptions& options = {});

// Renders the preview and writes it (PNG, or any format OpenCV knows from the extension).
// Throws dfo::InputError naming the path when it cannot be written.
void WriteSyntheticPreview(const std::string& path, const SyntheticSequence& sequence,
                           const SynthPreviewOptions& options = {});

}  // namespace dfo::io

#endif  // DFO_IO_SYNTH_PREVIEW_H_
