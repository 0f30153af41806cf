// Configuration schema of dfo_train (configs/train_default.yaml): the training data, the networks'
// shapes, the losses, the augmentation, the differentiable Gauss-Newton alignment and the run.
// Kept apart from DfoSchema (dfo_run's): dfo_train reads only this one. The defaults mirror
// dfo::learned::TrainingOptions / NetworkOptions / LossOptions / AugmentOptions and, for `gn`, the
// training's short unroll of TrackerOptions; apps/dfo_train.cc maps keys to fields one by one.
//
// Sections:
//   data     KITTI-layout sequence folders to train on, frames per sequence
//   network  shapes and widths of DepthNet and FeatureNet (stored in the model file)
//   loss     weights and constants of the appearance, smoothness, sparsity and AE terms
//   augment  random scale/crop and photometric augmentation
//   gn       the differentiable alignment (tracker options for the unrolled Gauss-Newton)
//   train    schedule, optimiser, batch, seeds, threads, checkpoints, progress
#ifndef DFO_IO_TRAIN_SCHEMA_H_
#define DFO_IO_TRAIN_SCHEMA_H_

#include "dfo_io/config.h"

namespace dfo::io {

// The full schema of dfo_train's configuration.
const ConfigSchema& TrainSchema();

}  // namespace dfo::io

#endif  // DFO_IO_TRAIN_SCHEMA_H_
