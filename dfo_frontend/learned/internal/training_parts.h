// The trainer's parts that its files share (training.cc, training_data.cc, training_step.cc,
// training_checkpoint.cc, training_losses.cc); not part of the trainer's interface.
#ifndef DFO_FRONTEND_LEARNED_INTERNAL_TRAINING_PARTS_H_
#define DFO_FRONTEND_LEARNED_INTERNAL_TRAINING_PARTS_H_

#include <cstdint>
#include <vector>

#include "dfo_frontend/learned/internal/training.h"

namespace dfo::learned {

// Decorrelated seeds for (run seed, iteration, purpose): SplitMix64 of their mix. Purpose 0 draws
// the batch, 1 the masks' Gumbel noise.
uint64_t StepSeed(uint64_t seed, int iteration, uint64_t purpose);

// Checks `data` against `options` (InputError naming the sequence and frame: images RGB of the
// camera's size, one pose or depth-target list per image or none, finite positive targets,
// ground-truth poses when gn.pose_source asks for them), resizes images and targets to the
// training size, and lists the 3-frame snippets whose target moved relative to both neighbours
// (train.static_threshold); InputError when there is none.
void PrepareTrainingData(const TrainingOptions& options, std::vector<TrainingSequence>* data,
                         std::vector<Snippet>* snippets);

}  // namespace dfo::learned

#endif  // DFO_FRONTEND_LEARNED_INTERNAL_TRAINING_PARTS_H_
