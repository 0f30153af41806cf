#include "dfo_core/alignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "dfo_core/error.h"
#include "dfo_core/metrics.h"

namespace dfo {
namespace {

// A wandering trajectory with random rotations and 1 s spacing (fixed seed).
Trajectory RandomTrajectory(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  Trajectory t;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    p += Eigen::Vector3d(1.0 + 0.3 * noise(rng), 0.5 * noise(rng), 0.8 * noise(rng));
    const SO3d R = SO3d::Exp(Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    t.Add(static_cast<int64_t>(i) * 1000000000LL, SE3d(R, p));
  }
  return t;
}

SimilarityTransform KnownSim3() {
  SimilarityTransform s;
  s.scale = 2.7;
  s.rotation = SO3d::Exp(Eigen::Vector3d(0.3, -1.1, 0.7)).Matrix();
  s.translation = Eigen::Vector3d(5.0, -3.0, 12.5);
  return s;
}

TEST(Alignment, ParsesTypesAndRejectsUnknown) {
  EXPECT_EQ(ParseAlignmentType("none"), AlignmentType::kNone);
  EXPECT_EQ(ParseAlignmentType("se3"), AlignmentType::kSe3);
  EXPECT_EQ(ParseAlignmentType("sim3"), AlignmentType::kSim3);
  EXPECT_EQ(AlignmentTypeName(AlignmentType::kSim3), "sim3");
  try {
    ParseAlignmentType("SE3x");
    FAIL() << "no throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("SE3x"), std::string::npos) << e.what();
  }
}

TEST(Alignment, UmeyamaRecoversKnownSim3AndSe3) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  Eigen::Matrix3Xd source(3, 50);
  for (int i = 0; i < 50; ++i) source.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  const SimilarityTransform truth = KnownSim3();
  Eigen::Matrix3Xd target(3, 50);
  for (int i = 0; i < 50; ++i) target.col(i) = truth.Apply(Eigen::Vector3d(source.col(i)));

  const SimilarityTransform sim3 = UmeyamaAlignment(source, target, /*with_scale=*/true);
  EXPECT_NEAR(sim3.scale, truth.scale, 1e-12);
  EXPECT_LT((sim3.rotation - truth.rotation).norm(), 1e-12);
  EXPECT_LT((sim3.translation - truth.translation).norm(), 1e-10);

  // Without scale on rigidly moved points: exact too, and the scale is reported as 1.
  SimilarityTransform rigid = truth;
  rigid.scale = 1.0;
  for (int i = 0; i < 50; ++i) target.col(i) = rigid.Apply(Eigen::Vector3d(source.col(i)));
  const SimilarityTransform se3 = UmeyamaAlignment(source, target, /*with_scale=*/false);
  EXPECT_EQ(se3.scale, 1.0);
  EXPECT_LT((se3.rotation - rigid.rotation).norm(), 1e-12);
  EXPECT_LT((se3.translation - rigid.translation).norm(), 1e-10);
}

TEST(Alignment, UmeyamaNeverReturnsAReflection) {
  // Target = source mirrored in z: the best proper rotation is returned (evo's S matrix),
  // never the reflection that would fit exactly.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Matrix3Xd source(3, 20);
  for (int i = 0; i < 20; ++i) source.col(i) = Eigen::Vector3d(u(rng), u(rng), 5.0 * u(rng));
  Eigen::Matrix3Xd target = source;
  target.row(2) *= -1.0;
  const SimilarityTransform s = UmeyamaAlignment(source, target, true);
  EXPECT_NEAR(s.rotation.determinant(), 1.0, 1e-12);
  EXPECT_LT((s.rotation.transpose() * s.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  EXPECT_GT(s.scale, 0.0);
}

TEST(Alignment, UmeyamaRejectsDegenerateInput) {
  Eigen::Matrix3Xd same(3, 10);
  same.colwise() = Eigen::Vector3d(1, 2, 3);
  EXPECT_THROW(UmeyamaAlignment(same, same, true), InputError);
  EXPECT_THROW(UmeyamaAlignment(Eigen::Matrix3Xd(3, 4), Eigen::Matrix3Xd(3, 5), true), InputError);
  EXPECT_THROW(UmeyamaAlignment(Eigen::Matrix3Xd::Zero(3, 1), Eigen::Matrix3Xd::Zero(3, 1), true),
               InputError);
}

// Expects an InputError whose message contains every fragment.
template <typename F>
void ExpectInputError(F f, const std::vector<std::string>& fragments) {
  try {
    f();
    ADD_FAILURE() << "no InputError; expected: " << fragments.front();
  } catch (const InputError& e) {
    for (const std::string& fragment : fragments) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos)
          << e.what() << "\n  missing: " << fragment;
    }
  }
}

// 50 random points and their image under KnownSim3.
void KnownPair(Eigen::Matrix3Xd* source, Eigen::Matrix3Xd* target) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-10.0, 10.0);
  source->resize(3, 50);
  target->resize(3, 50);
  for (int i = 0; i < 50; ++i) {
    source->col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
    target->col(i) = KnownSim3().Apply(Eigen::Vector3d(source->col(i)));
  }
}

// Coordinates of any finite magnitude: centring and power-of-two normalisation before anything is
// squared make the result exact (bit for bit the ordinary one, scaled) instead of a scale of 0
// from an overflowed variance (1e300^2 = inf).
TEST(Alignment, UmeyamaIsExactAtAnyMagnitude) {
  Eigen::Matrix3Xd source, target;
  KnownPair(&source, &target);
  const SimilarityTransform base = UmeyamaAlignment(source, target, true);
  for (const int e : {-1000, -600, 500, 600, 1000}) {
    const Eigen::Matrix3Xd big_source =
        source.unaryExpr([e](double v) { return std::ldexp(v, e); });
    const SimilarityTransform s = UmeyamaAlignment(big_source, target, true);
    EXPECT_EQ(s.scale, std::ldexp(base.scale, -e)) << e;
    EXPECT_EQ(s.rotation, base.rotation) << e;
    EXPECT_LT((s.translation - base.translation).norm(), 1e-10) << e;
    const Eigen::Matrix3Xd big_target =
        target.unaryExpr([e](double v) { return std::ldexp(v, e); });
    const SimilarityTransform t = UmeyamaAlignment(source, big_target, true);
    EXPECT_EQ(t.scale, std::ldexp(base.scale, e)) << e;
    EXPECT_EQ(t.rotation, base.rotation) << e;
    EXPECT_TRUE(t.translation.allFinite()) << e;
    // Both huge (or tiny): the scale between them is the ordinary one.
    const SimilarityTransform both = UmeyamaAlignment(big_source, big_target, true);
    EXPECT_EQ(both.scale, base.scale) << e;
    EXPECT_EQ(both.rotation, base.rotation) << e;
  }
  // Decimal magnitudes, not exactly representable scalings: still right to rounding.
  const SimilarityTransform s300 = UmeyamaAlignment(source * 1e300, target, true);
  EXPECT_NEAR(s300.scale * 1e300, KnownSim3().scale, 1e-12);
  EXPECT_LT((s300.rotation - KnownSim3().rotation).norm(), 1e-12);
  const SimilarityTransform s150 = UmeyamaAlignment(source, target * 1e150, true);
  EXPECT_NEAR(s150.scale / 1e150, KnownSim3().scale, 1e-12);
  // Far from the origin (UTM-like), moving by metres: the centring keeps the metres.
  Eigen::Matrix3Xd far = source;
  far.colwise() += Eigen::Vector3d(4.0e6, 5.0e6, 100.0);
  const SimilarityTransform s_far = UmeyamaAlignment(far, target, true);
  EXPECT_NEAR(s_far.scale, KnownSim3().scale, 1e-9);
  EXPECT_LT((s_far.rotation - KnownSim3().rotation).norm(), 1e-9);
}

// Inputs for which no alignment means anything: one InputError naming the point set and the
// reason, never a result with a scale of 0, inf or NaN.
TEST(Alignment, UmeyamaRejectsNumericallyMeaninglessInput) {
  Eigen::Matrix3Xd source, target;
  KnownPair(&source, &target);
  const double inf = std::numeric_limits<double>::infinity();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const double bad : {inf, -inf, nan}) {
    Eigen::Matrix3Xd s = source;
    s(1, 3) = bad;
    ExpectInputError([&] { UmeyamaAlignment(s, target, true, "estimate", "ground-truth"); },
                     {"estimate position 3 is not finite"});
    ExpectInputError([&] { UmeyamaAlignment(target, s, true, "estimate", "ground-truth"); },
                     {"ground-truth position 3 is not finite"});
  }
  // All identical, also at 1e300 and up to the last bits of the coordinates.
  for (const double magnitude : {1.0, 1e300, 1e-300}) {
    Eigen::Matrix3Xd same(3, 10);
    same.colwise() = magnitude * Eigen::Vector3d(1, 2, 3);
    ExpectInputError([&] { UmeyamaAlignment(same, source.leftCols(10), true); },
                     {"all 10 source positions are identical", "positions that move"});
  }
  Eigen::Matrix3Xd rounding(3, 10);
  for (int i = 0; i < 10; ++i) {
    rounding.col(i) = Eigen::Vector3d(1e16 + 2.0 * (i % 2), 3e16, -5e16 + 8.0 * (i % 3));
  }
  ExpectInputError([&] { UmeyamaAlignment(source.leftCols(10), rounding, false); },
                   {"all 10 target positions are identical up to rounding"});
  // Collinear: exactly, and within double precision (one coordinate of 1e300 among metres).
  Eigen::Matrix3Xd line(3, 20);
  for (int i = 0; i < 20; ++i) line.col(i) = Eigen::Vector3d(0.1, 0.2, 0.3) * i + source.col(0);
  ExpectInputError([&] { UmeyamaAlignment(line, source.leftCols(20), true); },
                   {"the 20 source positions lie on one line", "span a plane"});
  Eigen::Matrix3Xd outlier = source.leftCols(20);
  outlier(0, 7) = 1e300;
  ExpectInputError([&] { UmeyamaAlignment(source.leftCols(20), outlier, true); },
                   {"the 20 target positions lie on one line", "e+299 from their mean"});
  // Two points always lie on one line.
  ExpectInputError([&] { UmeyamaAlignment(source.leftCols(2), target.leftCols(2), false); },
                   {"at least 3 point pairs", "got 2"});
  // Planar sets whose motions are uncorrelated: the covariance is 0.
  Eigen::Matrix3Xd x(3, 6), y(3, 6);
  x << 1, -1, 0, 0, 1, -1,  //
      0, 0, 1, -1, 1, -1,   //
      0, 0, 0, 0, 0, 0;
  y << 1, 1, -1, -1, 0, 0,  //
      0, 0, 0, 0, 1, 1,     //
      0, 0, 0, 0, 0, 0;
  ExpectInputError([&] { UmeyamaAlignment(x, y, true); },
                   {"degenerate covariance rank 0", "uncorrelated"});
  // A scale beyond the double range (1e-300 to 1e300 sized trajectories).
  ExpectInputError(
      [&] { UmeyamaAlignment(source * 1e-300, target * 1e300, true, "estimate", "ground-truth"); },
      {"Sim3 scale from the estimate to the ground-truth positions is about 1e600"});
  ExpectInputError([&] { UmeyamaAlignment(source * 1e300, target * 1e-300, true); },
                   {"is about 1e-600"});
}

// AlignTrajectory names the estimate and the ground truth; every pose it returns is finite.
TEST(Alignment, AlignTrajectoryNamesTheTrajectoryAndStaysFinite) {
  const Trajectory gt = RandomTrajectory(30, 4);
  Trajectory est;
  for (const auto& p : gt)
    est.Add(p.timestamp_ns, SE3d(p.world_from_cam.so3(), Eigen::Vector3d(1, 2, 3)));
  TrajectoryAlignmentOptions options;
  options.type = AlignmentType::kSim3;
  ExpectInputError([&] { AlignTrajectory(est, gt, options); },
                   {"all 30 estimate positions are identical"});
  ExpectInputError([&] { AlignTrajectory(gt, est, options); },
                   {"all 30 ground-truth positions are identical"});
  // Fitted on the first 10 poses, a later pose of 1e300 cannot be mapped by a scale of 1e10.
  Trajectory huge_tail = TransformTrajectory(gt, [] {
    SimilarityTransform s;
    s.scale = 1e-10;
    return s;
  }());
  huge_tail[25].world_from_cam.translation() = Eigen::Vector3d(1e300, 0, 0);
  options.num_poses_to_align = 10;
  ExpectInputError([&] { AlignTrajectory(huge_tail, gt, options); },
                   {"estimate pose 25", "not representable"});
  // A trajectory scaled by 1e300 is aligned back exactly (scale 1e-300, ATE ~ 0).
  options.num_poses_to_align = 0;
  SimilarityTransform up;
  up.scale = 1e300;
  const TrajectoryAlignment a = AlignTrajectory(TransformTrajectory(gt, up), gt, options);
  EXPECT_NEAR(a.transform.scale * 1e300, 1.0, 1e-12);
  EXPECT_LT(ComputeAte(gt, a.aligned_estimate).stats.max, 1e-10);
}

TEST(Alignment, KnownSim3OnTrajectoryIsRecoveredWithZeroAte) {
  const Trajectory gt = RandomTrajectory(200, 11);
  const SimilarityTransform truth = KnownSim3();
  // est = truth^-1 applied to gt, so aligning est onto gt must give back `truth`.
  SimilarityTransform inverse;
  inverse.scale = 1.0 / truth.scale;
  inverse.rotation = truth.rotation.transpose();
  inverse.translation = -(inverse.scale * (inverse.rotation * truth.translation));
  const Trajectory est = TransformTrajectory(gt, inverse);

  TrajectoryAlignmentOptions options;
  options.type = AlignmentType::kSim3;
  const TrajectoryAlignment a = AlignTrajectory(est, gt, options);
  EXPECT_NEAR(a.transform.scale, truth.scale, 1e-10);
  EXPECT_LT((a.transform.rotation - truth.rotation).norm(), 1e-10);
  EXPECT_LT((a.transform.translation - truth.translation).norm(), 1e-8);
  EXPECT_EQ(a.num_poses_used, 200u);
  const AteResult ate = ComputeAte(gt, a.aligned_estimate);
  EXPECT_LT(ate.stats.max, 1e-8);
  // Orientations come back too (R_out = R R_in).
  for (size_t i = 0; i < gt.size(); ++i) {
    EXPECT_LT(
        ((gt[i].world_from_cam.Inverse() * a.aligned_estimate[i].world_from_cam).so3()).Angle(),
        1e-9);
    EXPECT_EQ(a.aligned_estimate[i].timestamp_ns, gt[i].timestamp_ns);
  }
  // SE3 alignment cannot absorb the scale: clearly non-zero ATE, scale reported as 1.
  options.type = AlignmentType::kSe3;
  const TrajectoryAlignment rigid = AlignTrajectory(est, gt, options);
  EXPECT_EQ(rigid.transform.scale, 1.0);
  EXPECT_GT(ComputeAte(gt, rigid.aligned_estimate).stats.rmse, 1.0);
}

TEST(Alignment, IdentityAndNoneGiveZeroAndUnchangedEstimate) {
  const Trajectory gt = RandomTrajectory(50, 5);
  for (AlignmentType type : {AlignmentType::kNone, AlignmentType::kSe3, AlignmentType::kSim3}) {
    TrajectoryAlignmentOptions options;
    options.type = type;
    const TrajectoryAlignment a = AlignTrajectory(gt, gt, options);
    EXPECT_NEAR(a.transform.scale, 1.0, 1e-12);
    EXPECT_LT((a.transform.rotation - Eigen::Matrix3d::Identity()).norm(), 1e-12);
    EXPECT_LT(a.transform.translation.norm(), 1e-10);
    EXPECT_LT(ComputeAte(gt, a.aligned_estimate).stats.max, 1e-10);
  }
}

TEST(Alignment, FitsOnTheFirstPosesOnlyWhenAsked) {
  const Trajectory gt = RandomTrajectory(100, 9);
  Trajectory est = gt;
  // Corrupt the tail: aligning on the first 40 poses must ignore it and recover identity.
  for (size_t i = 40; i < est.size(); ++i) {
    est[i].world_from_cam.translation() += Eigen::Vector3d(50.0, -20.0, 3.0);
  }
  TrajectoryAlignmentOptions options;
  options.type = AlignmentType::kSim3;
  options.num_poses_to_align = 40;
  const TrajectoryAlignment a = AlignTrajectory(est, gt, options);
  EXPECT_EQ(a.num_poses_used, 40u);
  EXPECT_NEAR(a.transform.scale, 1.0, 1e-12);
  EXPECT_LT(a.transform.translation.norm(), 1e-9);
  options.num_poses_to_align = -1;
  EXPECT_THROW(AlignTrajectory(est, gt, options), ConfigError);
}

TEST(Alignment, RejectsDifferentSizesAndEmpty) {
  const Trajectory gt = RandomTrajectory(10, 1);
  const Trajectory est = RandomTrajectory(9, 1);
  EXPECT_THROW(AlignTrajectory(est, gt), InputError);
  EXPECT_THROW(AlignTrajectory(Trajectory(), Trajectory()), InputError);
}

Trajectory Stamps(const std::vector<int64_t>& stamps) {
  Trajectory t;
  for (int64_t s : stamps) t.Add(s, SE3d());
  return t;
}

TEST(Association, IteratesTheShorterTrajectoryAndKeepsWithinMaxDiff) {
  const Trajectory a = Stamps({0, 100, 200, 300, 400, 500});
  const Trajectory b = Stamps({95, 260, 520});
  // b is shorter: for each b stamp the nearest a stamp; 260 is 40 from 300, beyond max 30.
  const auto pairs = AssociateByTimestamp(a, b, 30);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0], std::make_pair(size_t{1}, size_t{0}));
  EXPECT_EQ(pairs[1], std::make_pair(size_t{5}, size_t{2}));
  // Same with the roles swapped: pairs stay (index in a, index in b).
  const auto swapped = AssociateByTimestamp(b, a, 30);
  ASSERT_EQ(swapped.size(), 2u);
  EXPECT_EQ(swapped[0], std::make_pair(size_t{0}, size_t{1}));
  EXPECT_EQ(swapped[1], std::make_pair(size_t{2}, size_t{5}));
  // The limit is inclusive (evo: diff <= max_diff).
  EXPECT_EQ(AssociateByTimestamp(a, b, 40).size(), 3u);
  EXPECT_EQ(AssociateByTimestamp(a, b, 39).size(), 2u);
}

TEST(Association, EqualLengthsIterateTheSecondAndTiesPickTheFirst) {
  // Equal sizes: evo treats the second as the short one. Both a stamps are 50 from b's 150:
  // argmin returns the first, index 1.
  const Trajectory a = Stamps({0, 100, 200});
  const Trajectory b = Stamps({150, 1000, 2000});
  const auto pairs = AssociateByTimestamp(a, b, 60);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0], std::make_pair(size_t{1}, size_t{0}));
  // An index of the longer trajectory can be used twice, as in evo.
  const auto twice = AssociateByTimestamp(Stamps({0, 1000, 2000, 3000}), Stamps({990, 1010}), 20);
  ASSERT_EQ(twice.size(), 2u);
  EXPECT_EQ(twice[0].first, 1u);
  EXPECT_EQ(twice[1].first, 1u);
}

TEST(Association, UnsortedStampsGiveTheSameAnswerAsArgmin) {
  const Trajectory a = Stamps({500, 100, 300, 0, 400, 200});
  const Trajectory b = Stamps({95, 310});
  const auto pairs = AssociateByTimestamp(a, b, 20);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0], std::make_pair(size_t{1}, size_t{0}));
  EXPECT_EQ(pairs[1], std::make_pair(size_t{2}, size_t{1}));
  EXPECT_TRUE(AssociateByTimestamp(a, Trajectory(), 20).empty());

  Trajectory a_out, b_out;
  ApplyAssociation(pairs, a, b, &a_out, &b_out);
  ASSERT_EQ(a_out.size(), 2u);
  EXPECT_EQ(a_out[1].timestamp_ns, 300);
  EXPECT_EQ(b_out[1].timestamp_ns, 310);
}

}  // namespace
}  // namespace dfo
