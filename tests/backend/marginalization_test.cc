// Marginalisation: on a linear-Gaussian toy problem marginalise-then-solve equals the full solve;
// the prior has zero gradient at x0 when x0 is the optimum; its energy is invariant to a gauge
// transform of the kept poses; LinearPriorCost's Jacobians pass ceres::GradientChecker.
#include "dfo_backend/marginalization.h"

#include <ceres/gradient_checker.h>
#include <ceres/loss_function.h>
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/QR>
#include <cmath>
#include <random>

#include "dfo_backend/feature_metric_cost.h"
#include "dfo_backend/pose_manifold.h"

namespace dfo {
namespace {

// Linear toy: variables of the given sizes, factors r_f = sum_i A_fi x_i - c_f.
struct ToyProblem {
  std::vector<int> sizes;
  std::vector<int> offsets;
  int total = 0;
  struct Factor {
    std::vector<int> vars;
    std::vector<Eigen::MatrixXd> a;
    Eigen::VectorXd c;
  };
  std::vector<Factor> factors;

  explicit ToyProblem(std::vector<int> s) : sizes(std::move(s)) {
    for (int d : sizes) {
      offsets.push_back(total);
      total += d;
    }
  }
  void Add(std::vector<int> vars, int rows, std::mt19937* rng) {
    std::normal_distribution<double> n(0.0, 1.0);
    Factor f;
    f.vars = vars;
    for (int v : vars) {
      Eigen::MatrixXd a(rows, sizes[v]);
      for (int i = 0; i < a.size(); ++i) a.data()[i] = n(*rng);
      f.a.push_back(a);
    }
    f.c = Eigen::VectorXd(rows);
    for (int i = 0; i < rows; ++i) f.c(i) = n(*rng);
    factors.push_back(f);
  }
  // Minimiser of sum_f |r_f|^2 over all variables, with `fixed` ones held at `x`.
  Eigen::VectorXd Solve(const std::vector<int>& factor_ids, const LinearPrior* prior,
                        const Eigen::VectorXd& x_lin) const {
    // Normal equations in dx = x - x_lin.
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(total, total);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(total);
    auto add = [&](const Eigen::MatrixXd& j, const Eigen::VectorXd& r) {
      h += j.transpose() * j;
      b += j.transpose() * r;
    };
    for (int id : factor_ids) {
      const Factor& f = factors[id];
      Eigen::MatrixXd j = Eigen::MatrixXd::Zero(f.c.size(), total);
      for (size_t k = 0; k < f.vars.size(); ++k)
        j.middleCols(offsets[f.vars[k]], sizes[f.vars[k]]) = f.a[k];
      add(j, j * x_lin - f.c);
    }
    if (prior) {
      Eigen::MatrixXd j = Eigen::MatrixXd::Zero(prior->rank(), total);
      for (size_t k = 0; k < prior->variables.size(); ++k) {
        const int v = prior->variables[k];
        j.middleCols(offsets[v], sizes[v]) =
            prior->jacobian.middleCols(prior->offsets[k], sizes[v]);
      }
      add(j, prior->residual);
    }
    // Variables touched by nothing (the marginalised ones) get an identity row to stay solvable.
    for (int i = 0; i < total; ++i) {
      if (h(i, i) == 0.0) h(i, i) = 1.0;
    }
    return x_lin - h.ldlt().solve(b);
  }
  LinearizedFactor Linearize(int id, const Eigen::VectorXd& x) const {
    const Factor& f = factors[id];
    LinearizedFactor lf;
    lf.residual = -f.c;
    for (size_t k = 0; k < f.vars.size(); ++k) {
      lf.residual += f.a[k] * x.segment(offsets[f.vars[k]], sizes[f.vars[k]]);
      lf.variables.push_back(f.vars[k]);
      lf.jacobians.push_back(f.a[k]);
    }
    return lf;
  }
};

// Variables: 0..2 kept "poses" (3, 3, 2), 3 a marginalised "pose" (3), 4..7 marginalised
// "points" (1 each, coupled only to poses), 8 a kept point.
ToyProblem MakeToy(std::mt19937* rng) {
  ToyProblem toy({3, 3, 2, 3, 1, 1, 1, 1, 1});
  for (int p = 4; p <= 7; ++p) {
    toy.Add({3, p, 0}, 2, rng);
    toy.Add({p, 1}, 2, rng);
    toy.Add({p, 2, 3}, 1, rng);
  }
  toy.Add({3}, 2, rng);  // absolute information on the leaving pose
  toy.Add({0, 1}, 3, rng);
  toy.Add({1, 2}, 3, rng);
  toy.Add({2, 8}, 2, rng);
  toy.Add({8, 0}, 2, rng);
  toy.Add({0}, 2, rng);
  return toy;
}

TEST(MarginalizationTest, MarginalizeThenSolveEqualsFullSolve) {
  for (int seed = 0; seed < 5; ++seed) {
    std::mt19937 rng(seed);
    const ToyProblem toy = MakeToy(&rng);
    std::vector<int> all(toy.factors.size());
    for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
    // Linearise somewhere away from the optimum (the problem is linear, so it must not matter).
    Eigen::VectorXd x_lin(toy.total);
    std::normal_distribution<double> n(0.0, 1.0);
    for (int i = 0; i < toy.total; ++i) x_lin(i) = n(rng);
    const Eigen::VectorXd full = toy.Solve(all, nullptr, x_lin);

    std::vector<MarginalizationVariable> vars;
    for (size_t v = 0; v < toy.sizes.size(); ++v) vars.push_back({toy.sizes[v], v >= 3 && v <= 7});
    std::vector<LinearizedFactor> marg_factors;
    std::vector<int> rest;
    for (size_t f = 0; f < toy.factors.size(); ++f) {
      bool touches = false;
      for (int v : toy.factors[f].vars) touches = touches || vars[v].marginalize;
      if (touches) {
        marg_factors.push_back(toy.Linearize(static_cast<int>(f), x_lin));
      } else {
        rest.push_back(static_cast<int>(f));
      }
    }
    LinearPrior prior;
    std::string why;
    ASSERT_TRUE(Marginalize(vars, marg_factors, MarginalizationOptions(), &prior, &why)) << why;
    EXPECT_EQ(prior.variables, (std::vector<int>{0, 1, 2}));
    const Eigen::VectorXd reduced = toy.Solve(rest, &prior, x_lin);
    for (int v : {0, 1, 2, 8}) {
      const Eigen::VectorXd a = full.segment(toy.offsets[v], toy.sizes[v]);
      const Eigen::VectorXd b = reduced.segment(toy.offsets[v], toy.sizes[v]);
      EXPECT_LT((a - b).cwiseAbs().maxCoeff(), 1e-9 * (1.0 + a.cwiseAbs().maxCoeff()))
          << "seed " << seed << " variable " << v;
    }
  }
}

TEST(MarginalizationTest, PriorHasZeroGradientAtTheOptimum) {
  std::mt19937 rng(7);
  const ToyProblem toy = MakeToy(&rng);
  std::vector<int> all(toy.factors.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  const Eigen::VectorXd x_opt = toy.Solve(all, nullptr, Eigen::VectorXd::Zero(toy.total));
  std::vector<MarginalizationVariable> vars;
  for (size_t v = 0; v < toy.sizes.size(); ++v) vars.push_back({toy.sizes[v], v >= 3 && v <= 7});
  std::vector<LinearizedFactor> factors;
  for (size_t f = 0; f < toy.factors.size(); ++f)
    factors.push_back(toy.Linearize(static_cast<int>(f), x_opt));
  LinearPrior prior;
  std::string why;
  ASSERT_TRUE(Marginalize(vars, factors, MarginalizationOptions(), &prior, &why)) << why;
  // Gradient of |r0 + J0 dx|^2 at dx = 0 is 2 J0^T r0.
  const Eigen::VectorXd gradient = 2.0 * prior.jacobian.transpose() * prior.residual;
  EXPECT_LT(gradient.cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_GT(prior.jacobian.cwiseAbs().maxCoeff(), 0.1);
}

TEST(MarginalizationTest, RejectsNonFiniteFactorsAndChecksOptions) {
  std::vector<MarginalizationVariable> vars = {{1, false}, {1, true}};
  LinearizedFactor f;
  f.residual = Eigen::VectorXd::Constant(1, std::nan(""));
  f.variables = {0, 1};
  f.jacobians = {Eigen::MatrixXd::Ones(1, 1), Eigen::MatrixXd::Ones(1, 1)};
  LinearPrior prior;
  std::string why;
  EXPECT_FALSE(Marginalize(vars, {f}, MarginalizationOptions(), &prior, &why));
  EXPECT_NE(why.find("not finite"), std::string::npos) << why;
  MarginalizationOptions bad;
  bad.relative_eigenvalue_floor = 2.0;
  EXPECT_THROW(bad.Check(), ConfigError);
}

TEST(MarginalizationTest, LossCorrectionScalesBySqrtRhoPrime) {
  ceres::HuberLoss huber(1.0);
  LinearizedFactor inlier, outlier;
  inlier.residual = Eigen::Vector2d(0.3, 0.4);
  inlier.variables = {0};
  inlier.jacobians = {Eigen::MatrixXd::Identity(2, 2)};
  outlier = inlier;
  outlier.residual = Eigen::Vector2d(3.0, 4.0);  // |r|^2 = 25, Huber rho' = 1 / 5
  ApplyLossCorrection(&huber, &inlier);
  ApplyLossCorrection(&huber, &outlier);
  EXPECT_NEAR(inlier.residual(0), 0.3, 1e-15);
  EXPECT_NEAR(outlier.residual(0), 3.0 / std::sqrt(5.0), 1e-12);
  EXPECT_NEAR(outlier.jacobians[0](1, 1), 1.0 / std::sqrt(5.0), 1e-12);
}

// Feature-metric factors between 4 random poses, points hosted in pose 0: marginalising pose 0
// and its points gives a prior on poses 1..3.
struct PosePriorFixture {
  FeatureLevel level;
  std::vector<std::array<double, 7>> poses;
  std::vector<double> depths;
  LinearPrior prior;

  PosePriorFixture() {
    const int w = 80, h = 60;
    level = FeatureLevel(w, h, 2, PinholeCamera(70.0, 70.0, 39.5, 29.5, w, h));
    for (int c = 0; c < 2; ++c) {
      for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
          level.Channel(c)[y * w + x] =
              static_cast<float>(std::sin(0.37 * x + 0.21 * y * (c + 1)) +
                                 0.6 * std::cos(0.29 * y - 0.13 * x * (2 - c)));
        }
      }
    }
    std::mt19937 rng(11);
    std::normal_distribution<double> n(0.0, 1.0);
    for (int i = 0; i < 4; ++i) {
      Vector6d xi;
      for (int k = 0; k < 3; ++k) xi(k) = (i == 0 ? 0.0 : 0.15) * n(rng) + (k == 2 ? 0.3 * i : 0.0);
      for (int k = 3; k < 6; ++k) xi(k) = 0.02 * n(rng);
      std::array<double, 7> p;
      PoseToParameters(SE3d::Exp(xi), p.data());
      poses.push_back(p);
    }
    std::vector<MarginalizationVariable> vars;
    for (int i = 0; i < 4; ++i) vars.push_back({6, i == 0});
    std::vector<LinearizedFactor> factors;
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (int k = 0; k < 40; ++k) {
      const int x = 20 + static_cast<int>(40 * u(rng)), y = 15 + static_cast<int>(30 * u(rng));
      const double rho = 1.0 / (4.0 + 4.0 * u(rng));
      depths.push_back(rho);
      const int point_var = static_cast<int>(vars.size());
      vars.push_back({1, true});
      auto patch = std::make_shared<const std::vector<double>>(SampleHostPatch(level, x, y, 3));
      for (int t = 1; t < 4; ++t) {
        FeatureMetricCost cost(&level, level.camera, Eigen::Vector2d(x, y), 3, patch);
        const int n_res = cost.num_residuals();
        LinearizedFactor f;
        f.residual.resize(n_res);
        RowMajorMatrixXd jh(n_res, 6), jt(n_res, 6);
        Eigen::VectorXd jr(n_res);
        cost.EvaluateTangent(poses[0].data(), poses[t].data(), rho, f.residual.data(), jh.data(),
                             jt.data(), jr.data());
        f.variables = {0, t, point_var};
        f.jacobians = {jh, jt, jr};
        factors.push_back(f);
      }
    }
    std::string why;
    EXPECT_TRUE(Marginalize(vars, factors, MarginalizationOptions(), &prior, &why)) << why;
  }
};

TEST(MarginalizationTest, PriorEnergyIsInvariantToAGaugeTransform) {
  PosePriorFixture fx;
  ASSERT_EQ(fx.prior.variables, (std::vector<int>{1, 2, 3}));
  std::vector<std::vector<double>> x0;
  for (int i = 1; i < 4; ++i) x0.emplace_back(fx.poses[i].begin(), fx.poses[i].end());
  LinearPriorCost cost(
      fx.prior, {PriorBlockKind::kPose, PriorBlockKind::kPose, PriorBlockKind::kPose}, x0, false);
  // Infinitesimal gauge: the same left tangent on every pose is in J0's null space.
  Vector6d xi;
  xi << 0.3, -0.2, 0.5, 0.1, 0.2, -0.15;
  Eigen::VectorXd stacked(18);
  for (int i = 0; i < 3; ++i) stacked.segment<6>(6 * i) = xi;
  EXPECT_LT((fx.prior.jacobian * stacked).norm(), 1e-6 * fx.prior.jacobian.norm() * stacked.norm());
  // Finite gauge G applied to x0: the energy stays |r0|^2.
  const SE3d g = SE3d::Exp(xi);
  std::vector<std::array<double, 7>> moved(3);
  for (int i = 0; i < 3; ++i)
    PoseToParameters(g * PoseFromParameters(x0[i].data()), moved[i].data());
  const double* params[] = {moved[0].data(), moved[1].data(), moved[2].data()};
  Eigen::VectorXd r(cost.num_residuals());
  ASSERT_TRUE(cost.Evaluate(params, r.data(), nullptr));
  const double e0 = fx.prior.residual.squaredNorm();
  EXPECT_NEAR(r.squaredNorm(), e0, 1e-6 * (1.0 + e0));
  // A non-gauge motion (one pose moved) does change it (x0 is not the optimum here, so the
  // energy may go either way).
  std::array<double, 7> shifted = fx.poses[2];
  shifted[6] += 0.1;
  const double* params2[] = {x0[0].data(), shifted.data(), x0[2].data()};
  ASSERT_TRUE(cost.Evaluate(params2, r.data(), nullptr));
  EXPECT_GT(std::abs(r.squaredNorm() - e0), 1e-3);
}

// A full-rank prior on two 3-vectors with random Jacobian and residual.
LinearPrior RandomPrior(unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  LinearPrior prior;
  prior.variables = {0, 1};
  prior.offsets = {0, 3};
  prior.jacobian = Eigen::MatrixXd(6, 6);
  prior.residual = Eigen::VectorXd(6);
  for (int i = 0; i < 36; ++i) prior.jacobian.data()[i] = n(rng);
  for (int i = 0; i < 6; ++i) prior.residual(i) = n(rng);
  return prior;
}

TEST(MarginalizationTest, ProjectOutNullspaceRemovesOnlyThoseDirections) {
  LinearPrior prior = RandomPrior(9);
  Eigen::MatrixXd nullspace = Eigen::MatrixXd::Zero(6, 2);
  nullspace.block<3, 1>(0, 0) = Eigen::Vector3d(1, 0, 0);
  nullspace.block<3, 1>(3, 0) = Eigen::Vector3d(1, 0, 0);
  nullspace(2, 1) = 1.0;
  const LinearPrior original = prior;
  ASSERT_TRUE(ProjectOutNullspace(nullspace, 1e-10, &prior));
  EXPECT_EQ(prior.rank(), 4);
  EXPECT_LT((prior.jacobian * nullspace).cwiseAbs().maxCoeff(), 1e-12);
  // On the complement the quadratic model is unchanged up to a constant: gradient and Hessian
  // of |r + J P dx|^2 equal the originals' projected ones.
  const Eigen::MatrixXd q =
      nullspace.householderQr().householderQ() * Eigen::MatrixXd::Identity(6, 2);
  const Eigen::MatrixXd p = Eigen::MatrixXd::Identity(6, 6) - q * q.transpose();
  const Eigen::MatrixXd h0 = p * original.jacobian.transpose() * original.jacobian * p;
  const Eigen::MatrixXd h1 = prior.jacobian.transpose() * prior.jacobian;
  EXPECT_LT((h0 - h1).cwiseAbs().maxCoeff(), 1e-10);
  const Eigen::VectorXd b0 = p * original.jacobian.transpose() * original.residual;
  const Eigen::VectorXd b1 = prior.jacobian.transpose() * prior.residual;
  EXPECT_LT((b0 - b1).cwiseAbs().maxCoeff(), 1e-10);
}

// last_column_kept k: the earlier columns' directions are removed as before, and the information
// along the last one (orthogonalised against them) is multiplied by k^2 instead of removed.
TEST(MarginalizationTest, ProjectOutNullspaceKeepsAFractionOfTheLastDirection) {
  const LinearPrior original = RandomPrior(11);
  Eigen::MatrixXd nullspace = Eigen::MatrixXd::Zero(6, 2);
  nullspace.block<3, 1>(0, 0) = Eigen::Vector3d(1, 0, 0);
  nullspace.block<3, 1>(3, 0) = Eigen::Vector3d(1, 0, 0);
  nullspace(2, 1) = 1.0;
  nullspace(0, 1) = 0.5;  // not orthogonal to the first column
  const Eigen::MatrixXd q =
      nullspace.householderQr().householderQ() * Eigen::MatrixXd::Identity(6, 2);
  const Eigen::VectorXd u = q.col(1);  // the last direction, orthogonal to the first
  const Eigen::VectorXd first = nullspace.col(0);
  const Eigen::MatrixXd h = original.jacobian.transpose() * original.jacobian;
  for (const double k : {0.0, 0.5, 1.0}) {
    LinearPrior prior = original;
    ASSERT_TRUE(ProjectOutNullspace(nullspace, 1e-12, &prior, k));
    const Eigen::MatrixXd h1 = prior.jacobian.transpose() * prior.jacobian;
    EXPECT_EQ(prior.rank(), k > 0.0 ? 5 : 4) << "k " << k;
    EXPECT_LT((prior.jacobian * first).cwiseAbs().maxCoeff(), 1e-10) << "k " << k;
    EXPECT_NEAR(u.dot(h1 * u), k * k * u.dot(h * u), 1e-9) << "k " << k;
  }
}

TEST(MarginalizationTest, PriorCostPassesGradientChecker) {
  PosePriorFixture fx;
  std::vector<std::vector<double>> x0;
  for (int i = 1; i < 4; ++i) x0.emplace_back(fx.poses[i].begin(), fx.poses[i].end());
  const std::vector<PriorBlockKind> kinds(3, PriorBlockKind::kPose);
  LinearPriorCost cost(fx.prior, kinds, x0, false);
  // Evaluate away from x0, where J_l^-1 matters.
  std::vector<std::array<double, 7>> x(3);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 0.2);
  for (int i = 0; i < 3; ++i) {
    Vector6d d;
    for (int k = 0; k < 6; ++k) d(k) = n(rng);
    PoseToParameters(SE3d::Exp(d) * PoseFromParameters(x0[i].data()), x[i].data());
  }
  SE3Manifold manifold;
  const std::vector<const ceres::Manifold*> manifolds(3, &manifold);
  ceres::NumericDiffOptions numeric;
  ceres::GradientChecker checker(&cost, &manifolds, numeric);
  const double* params[] = {x[0].data(), x[1].data(), x[2].data()};
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params, 1e-6, &results)) << results.error_log;
  // First-estimate Jacobians: the tangent Jacobian is J0 itself, wherever x is.
  LinearPriorCost fej(fx.prior, kinds, x0, true);
  const LinearizedFactor lin = fej.Linearize(params);
  EXPECT_LT((lin.jacobians[1] - fx.prior.jacobian.middleCols<6>(6)).cwiseAbs().maxCoeff(), 1e-15);
}

}  // namespace
}  // namespace dfo
