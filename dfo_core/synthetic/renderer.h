// Ray-casting renderer of the synthetic street world: colour, grey, z-depth and surface classes.
//
// Per view: boxes behind the camera or out of range are culled, each remaining box gets its screen
// rectangle (the whole screen when it crosses the near plane) and is entered in the lists of the
// 16 x 16 pixel tiles it covers. A pixel's ray is tested against the road plane and the boxes of
// its tile only (slab test in box coordinates); the nearest hit is shaded with world-space
// procedural textures, filtered over the pixel's footprint (ray differentials), so the images do
// not alias. Pixels on silhouettes are supersampled 3 x 3 (SyntheticOptions::antialias_edges).
#ifndef DFO_CORE_SYNTHETIC_RENDERER_H_
#define DFO_CORE_SYNTHETIC_RENDERER_H_

#include <cstdint>

#include "dfo_core/camera.h"
#include "dfo_core/image.h"
#include "dfo_core/lie.h"
#include "dfo_core/synthetic/options.h"
#include "dfo_core/synthetic/world.h"

namespace dfo::synthetic {

// Class of the surface seen by a pixel (the `labels` image).
enum class SurfaceClass : uint8_t {
  kSky = 0,       // nothing hit: sky at infinity, no depth
  kRoad = 1,      // asphalt and its markings (parking lanes included)
  kSidewalk = 2,  // kerb and sidewalk
  kVerge = 3,     // ground beyond the sidewalks and away from the street
  kBuilding = 4,  // building facades and roofs
  kCar = 5,       // parked cars
};

// One rendered view.
struct RenderedView {
  ImageU8 rgb;     // 3 channels, RGB order
  ImageU8 gray;    // 0.299 R + 0.587 G + 0.114 B of the same (unquantised) colour
  ImageF depth;    // z-depth in metres along the optical axis; 0 = sky or beyond max_depth_m
  ImageU8 labels;  // SurfaceClass of the pixel centre
};

// Renders the view of `camera` at pose `map_from_cam` (map frame, see world.h) with `num_threads`
// threads (>= 1; rows are shared out, the result does not depend on the count).
RenderedView RenderView(const SyntheticWorld& world, const PinholeCamera& camera,
                        const SE3d& map_from_cam, const SyntheticOptions& options,
                        int num_threads = 1);

}  // namespace dfo::synthetic

#endif  // DFO_CORE_SYNTHETIC_RENDERER_H_
