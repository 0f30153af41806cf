// dfo_synth: renders dfo's procedural street sequence and writes it in the KITTI odometry layout
// (grey and colour images, 16-bit depth, calib.txt, times.txt, poses), optionally with a preview
// picture. Run `dfo_synth --help` for the flags.
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <limits>
#include <string>
#include <thread>

#include "apps/common/cli.h"
#include "dfo_core/error.h"
#include "dfo_core/synthetic/synthetic_sequence.h"
#include "dfo_io/synth_preview.h"
#include "dfo_io/synth_writer.h"

namespace {

constexpr const char* kUsage = R"(usage: dfo_synth --output DIR [options]

Renders dfo's procedural synthetic street sequence (a KITTI-like drive with ground truth) into
  DIR/sequences/NN/{image_0,image_2,depth_0}/NNNNNN.png, calib.txt, times.txt
  DIR/poses/NN.txt
depth_0 is 16-bit z-depth, metres = value / 256, 0 = no depth (sky or beyond 255 m).

options:
  --output DIR      root folder of the KITTI tree (required; created when missing)
  --sequence NN     sequence name (default 00)
  --seed N          world and path seed, a non-negative integer (default 1)
  --frames N        number of frames, >= 1 (default 500)
  --width W         image width in pixels (default 416)
  --height H        image height in pixels (default 128)
  --fov-deg F       horizontal field of view in degrees (default 80)
  --threads N       worker threads, >= 1 (default: hardware threads)
  --preview FILE    also write a preview picture (PNG): frames, depth maps, top view
  --help            print this text and exit
Flags take their value as the next argument or after '=' (--frames=100).
)";

using dfo::apps::UsageError;

struct Args {
  dfo::SyntheticOptions synth;
  dfo::io::SynthWriteOptions write;
  std::string preview;
  bool help = false;
};

Args ParseArgs(int argc, char** argv) {
  Args args;
  const unsigned hw = std::thread::hardware_concurrency();
  args.write.num_threads = hw > 0 ? static_cast<int>(hw) : 2;
  const double inf = std::numeric_limits<double>::infinity();
  dfo::apps::ArgParser parser;
  parser.Flag("--help", &args.help, "-h")
      .Value("--output", &args.write.output_dir)
      .Value("--sequence", &args.write.sequence)
      .Custom("--seed",
              [&](const std::string& v) {
                args.synth.seed = static_cast<uint64_t>(dfo::apps::ParseIntArgument(
                    "--seed", v, 0, std::numeric_limits<int64_t>::max()));
              })
      .Int("--frames", &args.synth.num_frames, 1, 1000000)
      .Int("--width", &args.synth.width, 16, 4096)
      .Int("--height", &args.synth.height, 16, 4096)
      .Number("--fov-deg", &args.synth.horizontal_fov_deg, -inf, inf)
      .Int("--threads", &args.write.num_threads, 1, 256)
      .Value("--preview", &args.preview);
  parser.Parse(argc, argv);
  if (!args.help && args.write.output_dir.empty()) {
    throw UsageError("--output DIR is required (see --help)");
  }
  return args;
}

}  // namespace

int main(int argc, char** argv) {
  return dfo::apps::RunMain(
      "dfo_synth",
      [&] {
        const Args args = ParseArgs(argc, argv);
        if (args.help) {
          std::cout << kUsage;
          return 0;
        }
        args.synth.Check();
        args.write.Check();
        const dfo::SyntheticSequence sequence(args.synth);
        const dfo::PinholeCamera& cam = sequence.camera();
        std::printf(
            "dfo_synth: seed %llu, %d frames of %dx%d, fx = fy = %.3f, cx = %.1f, cy = %.1f, "
            "%zu boxes, %d threads\n",
            static_cast<unsigned long long>(args.synth.seed), sequence.num_frames(), cam.width,
            cam.height, cam.fx, cam.cx, cam.cy, sequence.world().boxes.size(),
            args.write.num_threads);
        std::fflush(stdout);
        const auto summary = dfo::io::WriteSyntheticSequence(
            sequence, args.write, [](const dfo::io::SynthWriteProgress& p) {
              std::printf("dfo_synth: %d/%d frames, %.1f frames/s, elapsed %.1f s, ETA %.1f s\n",
                          p.frames_done, p.num_frames, p.frames_per_s, p.elapsed_s, p.eta_s);
              std::fflush(stdout);
            });
        std::printf(
            "dfo_synth: wrote %d frames to %s and %s in %.2f s (%.1f frames/s), path %.1f m\n",
            summary.num_frames, summary.sequence_dir.c_str(), summary.poses_path.c_str(),
            summary.seconds, summary.num_frames / std::max(summary.seconds, 1e-9),
            sequence.GroundTruth().PathLength());
        if (!args.preview.empty()) {
          dfo::io::SynthPreviewOptions preview;
          preview.num_threads = args.write.num_threads;
          dfo::io::WriteSyntheticPreview(args.preview, sequence, preview);
          std::printf("dfo_synth: preview written to %s\n", args.preview.c_str());
        }
        return 0;
      },
      /*hint_help=*/false);
}
