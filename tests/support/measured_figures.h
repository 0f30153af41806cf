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
// Measured 0.3088 frontend-only and 0.1583 windowed, identical with run.threads 1 and 2
// (run.deterministic); the bounds leave ~25 % for other CPUs' rounding, which moves windowed
// runs (single windowed runs scatter: with keyframe.translation_ratio 0.15 this sequence gives
// 0.148 / 0.055 m, synthetic seeds 2 and 3 go the other way, docs/window.md "Keyframe spacing on
// real video").
constexpr double kDemoFrontendAte = 0.3088;
constexpr double kDemoFrontendAteBound = 0.39;
constexpr double kDemoWindowedAte = 0.1583;
constexpr double kDemoWindowedAteBound = 0.20;

// configs/kitti.yaml as shipped (models/default.dfo, trained on none of these sequences) on the
// real KITTI frames of ../shared/data (windowed Sim3 ATE RMSE in metres, KITTI t_rel in %):
//   build/apps/dfo_run --config configs/kitti.yaml --set dataset.path=../shared/data/kitti
//     --set dataset.sequence=06 --set dataset.last=50 --output OUT
//   (dataset.sequence=00 with dataset.last=159; dataset.sequence=03 without dataset.last)
// Measured 0.095 m on KITTI 06 frames 0-50, 0.446 m on KITTI 00 frames 0-159, 2.566 m and 2.40 %
// on KITTI 03, 0 lost. From start frames 1-3 they give 0.093 / 0.122 / 0.046, 0.536 / 0.465 /
// 0.545 and 4.12 / 3.80 / 3.62 m (docs/window.md "The zoom bias on real video"); the bounds leave
// that scatter and fail a change that costs more.
constexpr double kKitti06WindowedAte = 0.095;
constexpr double kKitti06WindowedAteBound = 0.16;
constexpr double kKitti00WindowedAte = 0.446;
constexpr double kKitti00WindowedAteBound = 0.65;
constexpr double kKitti03WindowedAte = 2.566;
constexpr double kKitti03WindowedAteBound = 3.5;
constexpr double kKitti03WindowedTRelPct = 2.40;
constexpr double kKitti03WindowedTRelPctBound = 3.0;

}  // namespace dfo::test

#endif  // DFO_TESTS_SUPPORT_MEASURED_FIGURES_H_
