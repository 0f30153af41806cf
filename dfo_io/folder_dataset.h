// A plain folder of images with a camera description.
//
//   <path>/camera.yaml   intrinsics, image size and lens (dfo_io/camera_yaml.h), optional fps or
//                        timestamps file; dataset.camera names another file
//   <path>/*.png|jpg|... the images, in the order of their sorted file names
//   <path>/times.txt     optional, used when camera.yaml names no timestamps file: one time in
//                        seconds per image (as KITTI's times.txt)
//
// Timestamps: camera.yaml's `timestamps` file, else times.txt when present, else frame i at
// i / fps seconds (camera.yaml's `fps`, 1 frame per second when absent). A timestamps file must
// have one line per image and increase strictly. Images of a lens with distortion are undistorted
// (dfo_io/lens.h). No depth and no ground truth.
#ifndef DFO_IO_FOLDER_DATASET_H_
#define DFO_IO_FOLDER_DATASET_H_

#include "dfo_io/dataset.h"

namespace dfo::io {

// Opens an image folder (see the file comment) as a Sequence.
Sequence OpenFolderSequence(const DatasetOptions& options);

}  // namespace dfo::io

#endif  // DFO_IO_FOLDER_DATASET_H_
