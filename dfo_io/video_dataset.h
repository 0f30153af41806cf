// A video file (dataset.type video) with a camera description.
//
//   <path>                 the video (mp4, mkv, avi, ...: whatever the installed FFmpeg reads,
//                          through FFmpeg's libraries, dfo_io/video_reader.h)
//   <folder>/camera.yaml   intrinsics, size and lens of the video's frames (dfo_io/camera_yaml.h),
//                          in the video's folder; dataset.camera names another file
//
// Frames are the video's decoded frames in order; when the sequence is opened they are decoded
// once to count them and read their times (up to dataset.last when it is set); the result is kept
// for the process, keyed by path, size and modification time, so opening the same video again
// costs nothing. The camera's width and height must equal the video's frame size. Damage found
// by the scan within the selected frames (and frames the container announces that the file does
// not hold) becomes the sequence's warnings (io::Sequence::warnings).
//
// Timestamps (VideoTimestampsNs):
//  - camera.yaml's `timestamps` file when it names one: one time in seconds per frame of the
//    video (all frames, as image folders), strictly increasing;
//  - else the container's time of each frame (CAP_PROP_POS_MSEC). The times are used from frame 0
//    for as long as they increase strictly; the frames after that run (all of them when the
//    container gives no times: every frame reports 0; the last few of H.264 streams with B-frames,
//    which OpenCV reports at 0 when the decoder is drained) continue from the last good time at
//    the nominal frame interval: 1 / camera.yaml's `fps`, else 1 / the container's frame rate;
//    InputError when neither gives one.
// Grey frames are converted from the decoded BGR frames with OpenCV's weights (cv::cvtColor),
// which may differ by 1 from the grey values OpenCV's PNG reader gives for a colour PNG. No depth
// and no ground truth.
#ifndef DFO_IO_VIDEO_DATASET_H_
#define DFO_IO_VIDEO_DATASET_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "dfo_io/dataset.h"

namespace dfo::io {

// Frame times in nanoseconds from the container's per-frame times (milliseconds) by the rule of
// the file comment; `fps` is camera.yaml's frame rate, `container_fps` the container's (0 = none).
// Throws InputError naming `what` when the rule needs a frame rate and has none.
std::vector<int64_t> VideoTimestampsNs(const std::vector<double>& container_ms,
                                       std::optional<double> fps, double container_fps,
                                       const std::string& what);

// Opens a video file (see the file comment) as a Sequence.
Sequence OpenVideoSequence(const DatasetOptions& options);

}  // namespace dfo::io

#endif  // DFO_IO_VIDEO_DATASET_H_
