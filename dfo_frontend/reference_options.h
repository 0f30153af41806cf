// Who decides when the frontend switches its reference: the frontend's own simple rule
// (policy "internal", for frontend-only use) or a caller such as the backend's keyframe manager
// (policy "external": the caller calls Frontend::MakeLastFrameReference).
#ifndef DFO_FRONTEND_REFERENCE_OPTIONS_H_
#define DFO_FRONTEND_REFERENCE_OPTIONS_H_

#include <string>

namespace dfo {

// When a successfully tracked frame becomes the new reference (LSD-SLAM / DSO style rules; any
// one that fires switches). Lost tracking always restarts from a fresh reference.
struct ReferenceOptions {
  // Who switches the reference of a successfully tracked frame:
  //  "internal": the frontend itself, by the thresholds below (frontend-only use);
  //  "external": only the caller, through Frontend::MakeLastFrameReference (dfo_run's keyframe
  //              manager, dfo_backend/keyframe_manager.h); the thresholds below are unused.
  // In both modes the first frame and the frame after a loss become references by themselves
  // (status kReference).
  std::string policy = "internal";
  // Switch when |t_ref_cur| / parallax depth of the reference (1 / mean inverse depth of its
  // tracked points) exceeds this, > 0 (the backend's keyframe rule; larger keeps a reference
  // longer).
  double translation_ratio = 0.15;
  // Switch when the rotation from the reference exceeds this many degrees, > 0.
  double rotation_deg = 10.0;
  // Switch when the finest-level inlier ratio falls below this, in [0, 1].
  double min_inlier_ratio = 0.6;
  // Switch after this many frames tracked against the same reference, >= 1 (1 = frame to frame).
  int max_interval = 10;

  // Throws ConfigError naming the field ("reference.max_interval = 0 violates >= 1",
  // "reference.policy = x violates one of {internal, external}").
  void Check() const;
};

}  // namespace dfo

#endif  // DFO_FRONTEND_REFERENCE_OPTIONS_H_
