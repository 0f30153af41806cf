// The figures users are told, as test bounds, in one place. Each bound is the measured value
// plus a margin for the spread of slightly perturbed runs (thread count, float rounding), so that
// a change that really degrades a figure fails `make test`. A change that moves a figure updates
// its measured value and bound here in the same commit, saying why in the commit message.
#ifndef DFO_TESTS_SUPPORT_MEASURED_FIGURES_H_
#define DFO_TESTS_SUPPORT_MEASURED_FIGURES_H_

namespace dfo::test {

// The committed models/default.dfo on the first 20 frames of the held-out synthetic seed 1
// (never trained on), median-scaled AbsRel of its depth:
//   build/apps/dfo_synth --output D --sequence 01 --seed 1 --frames 20
//   build/apps/dfo_train --config configs/train_default.yaml --output X --write-depth P
//     --sequence D/sequences/01 --model models/default.dfo
//   build/apps/dfo_eval depth --gt D/sequences/01/depth_0 --pred P --median-scaling
// Measured 0.167 (inference is deterministic; the margin covers other CPUs' float rounding).
constexpr double kDefaultModelHeldOutAbsRel = 0.167;
constexpr double kDefaultModelHeldOutAbsRelBound = 0.180;

// The demo (`make demo`'s first run): the default synthetic sequence (dfo_synth defaults: seed 1,
// 500 frames, 416 x 128) through configs/demo.yaml, Sim3 ATE RMSE in metres:
//   build/apps/dfo_synth --output D && build/apps/dfo_run --config configs/demo.yaml
//     --set dataset.path=D --output OUT      (summary.json frontend / windowed ate_rmse)
// Measured 0.2012 frontend-only and 0.1304 windowed, identical with run.threads 1 and 2
// (run.deterministic); the bounds leave ~25 % for other CPUs' rounding, which moves windowed
// runs (docs/tracking_against_the_window.md: single windowed runs scatter).
constexpr double kDemoFrontendAte = 0.2012;
constexpr double kDemoFrontendAteBound = 0.25;
constexpr double kDemoWindowedAte = 0.1304;
constexpr double kDemoWindowedAteBound = 0.165;

// configs/kitti.yaml on the real KITTI frames of ../shared/data with the command of issue 15
// (windowed Sim3 ATE RMSE in metres, KITTI t_rel in %):
//   build/apps/dfo_run --config configs/kitti.yaml --set dataset.path=../shared/data/kitti
//     --set dataset.sequence=06 --set dataset.last=50 --set frontend.depth=learned
//     --set dataset.image_width=208 --set dataset.image_height=64 --output OUT
//   (and dataset.sequence=03 without dataset.last: all 801 frames)
// Measured 0.176 m with 0 lost on KITTI 06 frames 0-50, 2.459 m and 2.06 % on KITTI 03, the same
// with run.threads 1 and 2 and the backend thread. The bounds are the targets; from start
// frames 1-3 KITTI 03 gives 2.51 / 2.66 / 1.66 m (docs/window.md), so a change that costs more than
// single runs scatter fails.
constexpr double kKitti06WindowedAte = 0.176;
constexpr double kKitti06WindowedAteBound = 0.30;
constexpr double kKitti03WindowedAte = 2.459;
constexpr double kKitti03WindowedAteBound = 3.0;
constexpr double kKitti03WindowedTRelPct = 2.06;
constexpr double kKitti03WindowedTRelPctBound = 3.0;

}  // namespace dfo::test

#endif  // DFO_TESTS_SUPPORT_MEASURED_FIGURES_H_
