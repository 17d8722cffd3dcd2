// Every Ceres factor's Jacobian against central differences in the tangent space
// (pose: p + dp, q * Exp(dtheta)), marginalization against a full solve, and the gauge
// (position and yaw) that the window keeps out of its prior.
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <memory>
#include <random>

#include "mapdelta/vio/factors.hpp"
#include "mapdelta/vio/gauge.hpp"
#include "mapdelta/vio/marginalization.hpp"

using namespace mapdelta;
using namespace mapdelta::vio;

namespace {

using Blocks = std::vector<std::vector<double>>;

std::vector<double> PlusTangent(const std::vector<double>& x, int k, double h) {
  std::vector<double> out = x;
  if (x.size() == 7) {
    double delta[6] = {0, 0, 0, 0, 0, 0};
    delta[k] = h;
    PoseManifold().Plus(x.data(), delta, out.data());
  } else {
    out[k] += h;
  }
  return out;
}

// Max abs difference between analytic and numeric tangent Jacobians.
double JacobianError(const ceres::CostFunction& cost, Blocks blocks) {
  const int nr = cost.num_residuals();
  const auto& sizes = cost.parameter_block_sizes();
  std::vector<const double*> ptrs;
  for (auto& b : blocks) ptrs.push_back(b.data());
  std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
      blocks.size());
  std::vector<double*> jptrs;
  for (size_t k = 0; k < blocks.size(); ++k) {
    J[k].resize(nr, sizes[k]);
    jptrs.push_back(J[k].data());
  }
  Eigen::VectorXd r(nr);
  EXPECT_TRUE(cost.Evaluate(ptrs.data(), r.data(), jptrs.data()));
  double worst = 0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    const Eigen::MatrixXd Jt = ToTangentJacobian(blocks[k].data(), sizes[k], J[k]);
    for (int d = 0; d < Jt.cols(); ++d) {
      const double h = 1e-6;
      Blocks plus = blocks, minus = blocks;
      plus[k] = PlusTangent(blocks[k], d, h);
      minus[k] = PlusTangent(blocks[k], d, -h);
      std::vector<const double*> pp, pm;
      for (size_t q = 0; q < blocks.size(); ++q) {
        pp.push_back(plus[q].data());
        pm.push_back(minus[q].data());
      }
      Eigen::VectorXd rp(nr), rm(nr);
      cost.Evaluate(pp.data(), rp.data(), nullptr);
      cost.Evaluate(pm.data(), rm.data(), nullptr);
      const Eigen::VectorXd numeric = (rp - rm) / (2 * h);
      const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
      worst = std::max(worst, (numeric - Jt.col(d)).cwiseAbs().maxCoeff() / scale);
    }
  }
  return worst;
}

std::vector<double> RandomPose(std::mt19937& rng, double spread) {
  std::normal_distribution<double> n(0, 1);
  SE3 T = MakeSE3(ExpQuaternion(Eigen::Vector3d(n(rng), n(rng), n(rng)) * 0.5),
                  Eigen::Vector3d(n(rng), n(rng), n(rng)) * spread);
  std::vector<double> p(7);
  PoseToArray(T, p.data());
  return p;
}

std::vector<double> RandomVector(std::mt19937& rng, int size, double scale) {
  std::normal_distribution<double> n(0, scale);
  std::vector<double> v(size);
  for (double& x : v) x = n(rng);
  return v;
}

ImuPreintegration SomePreintegration() {
  ImuNoiseDensities noise;
  noise.gyroscope_noise_density = 4e-4;
  noise.accelerometer_noise_density = 3e-3;
  noise.gyroscope_random_walk = 4e-5;
  noise.accelerometer_random_walk = 3e-4;
  ImuPreintegration pre(noise, Eigen::Vector3d(0.01, 0, -0.01), Eigen::Vector3d(0.05, 0.02, 0));
  for (int k = 0; k <= 40; ++k) {
    ImuSample s;
    s.t_ns = k * 5000000LL;
    s.gyro = Eigen::Vector3d(0.2, -0.3 + 0.01 * k, 0.1);
    s.accel = Eigen::Vector3d(0.5, 0.1 * std::sin(k), 9.8);
    pre.Add(s);
  }
  return pre;
}

CameraExtrinsics Cam(const Eigen::Vector3d& rot, const Eigen::Vector3d& t) {
  CameraExtrinsics c;
  c.q_body_cam = ExpQuaternion(rot);
  c.t_body_cam = t;
  return c;
}

}  // namespace

TEST(Factors, ImuFactorJacobianMatchesNumeric) {
  std::mt19937 rng(1);
  const auto pre = SomePreintegration();
  std::unique_ptr<ceres::CostFunction> cost(ImuFactor::Create(pre, Eigen::Vector3d(0, 0, -9.81)));
  for (int trial = 0; trial < 3; ++trial) {
    Blocks blocks = {RandomPose(rng, 1.0), RandomVector(rng, 9, 0.1), RandomPose(rng, 1.0),
                     RandomVector(rng, 9, 0.1)};
    EXPECT_LT(JacobianError(*cost, blocks), 1e-6);
  }
}

TEST(Factors, ReprojectionAndStereoJacobiansMatchNumeric) {
  std::mt19937 rng(2);
  const auto cam0 = Cam({-1.2, 0.0, -1.2}, {0.1, 0.05, 0.0});
  const auto cam1 = Cam({-1.2, 0.0, -1.2}, {0.1, -0.95, 0.0});
  std::unique_ptr<ceres::CostFunction> reproj(ReprojectionFactor::Create(
      Eigen::Vector2d(0.1, -0.2), Eigen::Vector2d(0.05, 0.1), cam0, cam1, 400.0));
  std::unique_ptr<ceres::CostFunction> stereo(StereoFactor::Create(
      Eigen::Vector2d(0.1, -0.2), Eigen::Vector2d(-0.1, -0.2), cam0, cam1, 400.0));
  for (int trial = 0; trial < 3; ++trial) {
    Blocks blocks = {RandomPose(rng, 0.3), RandomPose(rng, 0.3), {0.2}};
    EXPECT_LT(JacobianError(*reproj, blocks), 1e-5);
    EXPECT_LT(JacobianError(*stereo, {{0.2}}), 1e-6);
  }
}

// The closed-form reprojection Jacobians against numeric differentiation and against the
// autodiff of the same residual, over random poses, both cameras and near/far depths.
TEST(Factors, AnalyticReprojectionMatchesNumericAndAutodiff) {
  std::mt19937 rng(7);
  const auto cam0 = Cam({-1.2, 0.0, -1.2}, {0.1, 0.05, 0.0});
  const auto cam1 = Cam({-1.2, 0.0, -1.2}, {0.1, -0.95, 0.0});
  for (const auto* cam_j : {&cam0, &cam1}) {
    std::unique_ptr<ceres::CostFunction> analytic(ReprojectionFactor::Create(
        Eigen::Vector2d(0.1, -0.2), Eigen::Vector2d(0.05, 0.1), cam0, *cam_j, 400.0, true));
    std::unique_ptr<ceres::CostFunction> autodiff(ReprojectionFactor::Create(
        Eigen::Vector2d(0.1, -0.2), Eigen::Vector2d(0.05, 0.1), cam0, *cam_j, 400.0, false));
    for (double rho : {0.5, 0.2, 0.01}) {
      Blocks blocks = {RandomPose(rng, 0.3), RandomPose(rng, 0.3), {rho}};
      EXPECT_LT(JacobianError(*analytic, blocks), 1e-5);
      std::vector<const double*> ptrs = {blocks[0].data(), blocks[1].data(), blocks[2].data()};
      double ra[2], rb[2], Ja[3][14], Jb[3][14];
      double* ja[3] = {Ja[0], Ja[1], Ja[2]};
      double* jb[3] = {Jb[0], Jb[1], Jb[2]};
      ASSERT_TRUE(analytic->Evaluate(ptrs.data(), ra, ja));
      ASSERT_TRUE(autodiff->Evaluate(ptrs.data(), rb, jb));
      EXPECT_NEAR(ra[0], rb[0], 1e-9);
      EXPECT_NEAR(ra[1], rb[1], 1e-9);
      // Ambient quaternion columns may differ (only J_q M is defined); compare tangents.
      for (int k = 0; k < 2; ++k) {
        const Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> A(Ja[k]), B(Jb[k]);
        const Eigen::MatrixXd ta = ToTangentJacobian(blocks[k].data(), 7, A);
        const Eigen::MatrixXd tb = ToTangentJacobian(blocks[k].data(), 7, B);
        EXPECT_LT((ta - tb).cwiseAbs().maxCoeff(), 1e-8 * (1 + tb.cwiseAbs().maxCoeff()));
      }
      EXPECT_NEAR(Ja[2][0], Jb[2][0], 1e-8 * (1 + std::abs(Jb[2][0])));
      EXPECT_NEAR(Ja[2][1], Jb[2][1], 1e-8 * (1 + std::abs(Jb[2][1])));
    }
  }
}

TEST(Factors, MarginalizationFactorJacobianMatchesNumeric) {
  std::mt19937 rng(3);
  auto marg = std::make_shared<Marginalizer>();
  std::vector<double> pose_a = RandomPose(rng, 1), sb_a = RandomVector(rng, 9, 0.1);
  std::vector<double> pose_b = RandomPose(rng, 1), sb_b = RandomVector(rng, 9, 0.1);
  marg->AddResidualBlock(ImuFactor::Create(SomePreintegration(), Eigen::Vector3d(0, 0, -9.81)),
                         nullptr, {pose_a.data(), sb_a.data(), pose_b.data(), sb_b.data()});
  marg->Drop(pose_a.data());
  marg->Drop(sb_a.data());
  ASSERT_TRUE(marg->Marginalize());
  MarginalizationFactor prior(marg);
  // Evaluate away from the linearization point so the rotation term is non-trivial.
  Blocks blocks;
  for (size_t k = 0; k < marg->kept_blocks().size(); ++k) {
    std::vector<double> x(marg->kept_blocks()[k], marg->kept_blocks()[k] + marg->kept_sizes()[k]);
    for (int d = 0; d < TangentSizeOf(x.size()); ++d) x = PlusTangent(x, d, 0.05 * (d + 1));
    blocks.push_back(x);
  }
  EXPECT_LT(JacobianError(prior, blocks), 1e-6);
}

namespace {

// Linear residual A * x + B * y - c (weighted), 3-vectors.
struct LinearPair {
  Eigen::Matrix3d A, B;
  Eigen::Vector3d c;
  template <typename T>
  bool operator()(const T* x, const T* y, T* r) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> X(x), Y(y);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> R(r);
    R = A.cast<T>() * X + B.cast<T>() * Y - c.cast<T>();
    return true;
  }
};

ceres::CostFunction* MakePair(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  auto* f = new LinearPair;
  f->A = Eigen::Matrix3d::NullaryExpr([&]() { return n(rng); }) + 3 * Eigen::Matrix3d::Identity();
  f->B = Eigen::Matrix3d::NullaryExpr([&]() { return n(rng); });
  f->c = Eigen::Vector3d::NullaryExpr([&]() { return n(rng); });
  return new ceres::AutoDiffCostFunction<LinearPair, 3, 3, 3>(f);
}

}  // namespace

// A chain x0 - x1 - x2 - x3 of linear factors: eliminating x0 by Schur complement and solving
// the rest with the prior must reproduce the full solve exactly (the problem is linear, so
// the linearization point does not matter).
TEST(Marginalization, MatchesFullSolveOnLinearChain) {
  std::mt19937 rng(4);
  std::vector<ceres::CostFunction*> costs;
  for (int k = 0; k < 5; ++k) costs.push_back(MakePair(rng));
  // pairs: (0,1) (1,2) (2,3) (0,2) (3,3-anchor via pair with x1)
  const int pairs[5][2] = {{0, 1}, {1, 2}, {2, 3}, {0, 2}, {3, 1}};
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.function_tolerance = options.gradient_tolerance = options.parameter_tolerance = 1e-16;
  ceres::Solver::Summary summary;

  std::vector<std::vector<double>> full(4, std::vector<double>(3, 0.0));
  ceres::Problem::Options keep;
  keep.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  {
    ceres::Problem problem(keep);
    for (int k = 0; k < 5; ++k) {
      problem.AddResidualBlock(costs[k], nullptr, full[pairs[k][0]].data(),
                               full[pairs[k][1]].data());
    }
    ceres::Solve(options, &problem, &summary);
  }

  std::vector<std::vector<double>> x(4, std::vector<double>(3, 0.5));  // arbitrary point
  auto marg = std::make_shared<Marginalizer>();
  std::mt19937 rng2(4);  // same factors again, owned by the marginalizer
  std::vector<ceres::CostFunction*> copies;
  for (int k = 0; k < 5; ++k) copies.push_back(MakePair(rng2));
  for (int k = 0; k < 5; ++k) {
    if (pairs[k][0] == 0 || pairs[k][1] == 0) {
      marg->AddResidualBlock(copies[k], nullptr, {x[pairs[k][0]].data(), x[pairs[k][1]].data()});
    } else {
      delete copies[k];
    }
  }
  marg->Drop(x[0].data());
  ASSERT_TRUE(marg->Marginalize());
  ceres::Problem reduced(keep);
  for (int k = 0; k < 5; ++k) {
    if (pairs[k][0] != 0 && pairs[k][1] != 0) {
      reduced.AddResidualBlock(costs[k], nullptr, x[pairs[k][0]].data(), x[pairs[k][1]].data());
    }
  }
  auto* prior = new MarginalizationFactor(marg);
  reduced.AddResidualBlock(prior, nullptr, marg->kept_blocks());
  ceres::Solve(options, &reduced, &summary);
  delete prior;
  for (int b = 1; b < 4; ++b) {
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(x[b][d], full[b][d], 1e-8) << b << "," << d;
  }
  for (auto* c : costs) delete c;
}

namespace {

// Linear residual A * x + b * p - c with a 3-vector x and a scalar p (a "landmark").
struct LinearPoint {
  Eigen::Matrix3d A;
  Eigen::Vector3d b, c;
  template <typename T>
  bool operator()(const T* x, const T* p, T* r) const {
    Eigen::Map<const Eigen::Matrix<T, 3, 1>> X(x);
    Eigen::Map<Eigen::Matrix<T, 3, 1>> R(r);
    R = A.cast<T>() * X + b.cast<T>() * p[0] - c.cast<T>();
    return true;
  }
};

ceres::CostFunction* MakePoint(std::mt19937& rng) {
  std::normal_distribution<double> n(0, 1);
  auto* f = new LinearPoint;
  f->A = Eigen::Matrix3d::NullaryExpr([&]() { return n(rng); });
  f->b = Eigen::Vector3d::NullaryExpr([&]() { return n(rng); });
  f->c = Eigen::Vector3d::NullaryExpr([&]() { return n(rng); });
  return new ceres::AutoDiffCostFunction<LinearPoint, 3, 3, 1>(f);
}

}  // namespace

// Scalar blocks take the sparse first elimination stage: states x0..x2, points p0..p3 each
// seen by two states; dropping x0 and p0, p1 must reproduce the full solve for x1, x2, p2, p3
// (to the solvers' convergence, ~1e-8; a wrong elimination is off by O(0.1)).
TEST(Marginalization, EliminatesScalarBlocksExactly) {
  const int obs[8][2] = {{0, 0}, {1, 0}, {0, 1}, {2, 1}, {1, 2}, {2, 2}, {0, 3}, {2, 3}};
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.function_tolerance = options.gradient_tolerance = options.parameter_tolerance = 1e-16;
  ceres::Solver::Summary summary;
  ceres::Problem::Options keep;
  keep.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;

  std::mt19937 rng(5);
  std::vector<ceres::CostFunction*> costs;
  for (int k = 0; k < 8; ++k) costs.push_back(MakePoint(rng));
  std::vector<std::vector<double>> xs(3, std::vector<double>(3, 0.0));
  std::vector<double> ps(4, 0.0);
  {
    ceres::Problem problem(keep);
    for (int k = 0; k < 8; ++k)
      problem.AddResidualBlock(costs[k], nullptr, xs[obs[k][0]].data(), &ps[obs[k][1]]);
    ceres::Solve(options, &problem, &summary);
  }

  std::vector<std::vector<double>> x(3, std::vector<double>(3, 0.3));
  std::vector<double> p(4, 0.7);
  auto marg = std::make_shared<Marginalizer>();
  std::mt19937 rng2(5);
  std::vector<ceres::CostFunction*> copies;
  for (int k = 0; k < 8; ++k) copies.push_back(MakePoint(rng2));
  auto touches_dropped = [&](int k) { return obs[k][0] == 0 || obs[k][1] <= 1; };
  for (int k = 0; k < 8; ++k) {
    if (touches_dropped(k)) {
      marg->AddResidualBlock(copies[k], nullptr, {x[obs[k][0]].data(), &p[obs[k][1]]});
    } else {
      delete copies[k];
    }
  }
  marg->Drop(x[0].data());
  marg->Drop(&p[0]);
  marg->Drop(&p[1]);
  ASSERT_TRUE(marg->Marginalize());
  ceres::Problem reduced(keep);
  for (int k = 0; k < 8; ++k) {
    if (!touches_dropped(k))
      reduced.AddResidualBlock(costs[k], nullptr, x[obs[k][0]].data(), &p[obs[k][1]]);
  }
  auto* prior = new MarginalizationFactor(marg);
  reduced.AddResidualBlock(prior, nullptr, marg->kept_blocks());
  ceres::Solve(options, &reduced, &summary);
  delete prior;
  for (int b = 1; b < 3; ++b) {
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(x[b][d], xs[b][d], 1e-6) << b << "," << d;
  }
  EXPECT_NEAR(p[2], ps[2], 1e-6);
  EXPECT_NEAR(p[3], ps[3], 1e-6);
  for (auto* c : costs) delete c;
}

namespace {

// Tangent Jacobian of a cost function at `blocks`, all blocks side by side.
Eigen::MatrixXd TangentJacobian(const ceres::CostFunction& cost, const Blocks& blocks) {
  const int nr = cost.num_residuals();
  const auto& sizes = cost.parameter_block_sizes();
  std::vector<const double*> ptrs;
  std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(
      blocks.size());
  std::vector<double*> jptrs;
  int cols = 0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    ptrs.push_back(blocks[k].data());
    J[k].resize(nr, sizes[k]);
    jptrs.push_back(J[k].data());
    cols += TangentSizeOf(sizes[k]);
  }
  Eigen::VectorXd r(nr);
  EXPECT_TRUE(cost.Evaluate(ptrs.data(), r.data(), jptrs.data()));
  Eigen::MatrixXd out(nr, cols);
  int o = 0;
  for (size_t k = 0; k < blocks.size(); ++k) {
    const Eigen::MatrixXd Jt = ToTangentJacobian(blocks[k].data(), sizes[k], J[k]);
    out.middleCols(o, Jt.cols()) = Jt;
    o += static_cast<int>(Jt.cols());
  }
  return out;
}

Eigen::MatrixXd DirectionsOf(const Blocks& blocks) {
  std::vector<int> sizes;
  std::vector<Eigen::VectorXd> x0;
  for (const auto& b : blocks) {
    sizes.push_back(static_cast<int>(b.size()));
    x0.push_back(Eigen::Map<const Eigen::VectorXd>(b.data(), static_cast<Eigen::Index>(b.size())));
  }
  return GaugeDirections(sizes, x0);
}

// Moves every block along the gauge direction `c` (translation x/y/z, yaw) in tangent steps.
Blocks MoveAlong(const Blocks& blocks, const Eigen::Vector4d& c) {
  const Eigen::VectorXd step = DirectionsOf(blocks) * c;
  Blocks out = blocks;
  int o = 0;
  for (auto& b : out) {
    const int t = TangentSizeOf(static_cast<int>(b.size()));
    if (b.size() == 7) {
      std::vector<double> moved(7);
      PoseManifold().Plus(b.data(), step.data() + o, moved.data());
      b = moved;
    } else {
      for (int d = 0; d < t; ++d) b[static_cast<size_t>(d)] += step[o + d];
    }
    o += t;
  }
  return out;
}

}  // namespace

// The four gauge directions are null directions of the IMU and visual factors (what makes
// them unobservable): J * N = 0 at random states, far from any special configuration.
TEST(Gauge, DirectionsAreNullDirectionsOfImuAndReprojectionFactors) {
  std::mt19937 rng(11);
  std::unique_ptr<ceres::CostFunction> imu(
      ImuFactor::Create(SomePreintegration(), Eigen::Vector3d(0, 0, -9.81)));
  const auto cam0 = Cam({-1.2, 0.0, -1.2}, {0.1, 0.5, 0.05});
  std::unique_ptr<ceres::CostFunction> reproj(ReprojectionFactor::Create(
      Eigen::Vector2d(0.1, -0.2), Eigen::Vector2d(0.05, 0.1), cam0, cam0, 400.0));
  for (int trial = 0; trial < 3; ++trial) {
    const Blocks states = {RandomPose(rng, 5.0), RandomVector(rng, 9, 2.0), RandomPose(rng, 5.0),
                           RandomVector(rng, 9, 2.0)};
    const Eigen::MatrixXd Ji = TangentJacobian(*imu, states);
    EXPECT_LT((Ji * DirectionsOf(states)).cwiseAbs().maxCoeff(), 1e-7 * Ji.cwiseAbs().maxCoeff());
    const Blocks visual = {RandomPose(rng, 5.0), RandomPose(rng, 5.0), {0.2}};
    const Eigen::MatrixXd Jv = TangentJacobian(*reproj, visual);
    EXPECT_LT((Jv * DirectionsOf(visual)).cwiseAbs().maxCoeff(), 1e-7 * Jv.cwiseAbs().maxCoeff());
    // The yaw column really turns the states: not the zero vector.
    EXPECT_GT(DirectionsOf(states).col(3).norm(), 0.5);
  }
}

// A prior that knew the gauge (an anchor on the dropped frame's position and yaw) knows
// nothing of it after RemoveDirections: H N = 0, b N = 0, its residual no longer changes
// along N, and what it says about the rest is the Schur complement with N unknown.
TEST(Gauge, RemovedDirectionsCarryNoInformation) {
  std::mt19937 rng(12);
  Blocks x = {RandomPose(rng, 2.0), RandomVector(rng, 9, 0.5), RandomPose(rng, 2.0),
              RandomVector(rng, 9, 0.5)};
  auto marg = std::make_shared<Marginalizer>();
  marg->AddResidualBlock(ImuFactor::Create(SomePreintegration(), Eigen::Vector3d(0, 0, -9.81)),
                         nullptr, {x[0].data(), x[1].data(), x[2].data(), x[3].data()});
  marg->AddResidualBlock(CreateGaugeAnchor(x[0].data(), 1e-2), nullptr, {x[0].data()});
  marg->Drop(x[0].data());
  marg->Drop(x[1].data());
  ASSERT_TRUE(marg->Marginalize());
  Blocks kept;
  for (size_t k = 0; k < marg->kept_blocks().size(); ++k) {
    kept.emplace_back(marg->kept_blocks()[k], marg->kept_blocks()[k] + marg->kept_sizes()[k]);
  }
  const Eigen::MatrixXd N = DirectionsOf(kept);
  const Blocks moved = MoveAlong(kept, Eigen::Vector4d(0.3, -0.2, 0.1, 0.01));
  auto residual_change = [&](const std::shared_ptr<Marginalizer>& m) {
    MarginalizationFactor prior(m);
    auto residual = [&](const Blocks& at) {
      std::vector<const double*> ptrs;
      for (const auto& b : at) ptrs.push_back(b.data());
      Eigen::VectorXd r(prior.num_residuals());
      EXPECT_TRUE(prior.Evaluate(ptrs.data(), r.data(), nullptr));
      return r;
    };
    return (residual(moved) - residual(kept)).norm();
  };
  const double scale = marg->H().cwiseAbs().maxCoeff();
  ASSERT_GT((marg->H() * N).cwiseAbs().maxCoeff(), 1e-3 * scale);  // the anchor's information
  const double change_before = residual_change(marg);
  // Oracle: in coordinates [N | M] (M: an orthonormal complement of N), treating the N part
  // as unknown is the Schur complement onto M.
  const Eigen::MatrixXd Q = Eigen::HouseholderQR<Eigen::MatrixXd>(N).householderQ();
  const Eigen::MatrixXd M = Q.rightCols(N.rows() - 4);
  const Eigen::MatrixXd Hnn = N.transpose() * marg->H() * N, Hmn = M.transpose() * marg->H() * N;
  const Eigen::MatrixXd schur =
      M.transpose() * marg->H() * M - Hmn * Hnn.ldlt().solve(Hmn.transpose());
  ASSERT_GT(change_before, 1.0);

  marg->RemoveDirections(N);
  EXPECT_LT((marg->H() * N).cwiseAbs().maxCoeff(), 1e-9 * scale);
  EXPECT_LT((marg->b().transpose() * N).cwiseAbs().maxCoeff(), 1e-9 * scale);
  EXPECT_LT((M.transpose() * marg->H() * M - schur).cwiseAbs().maxCoeff(), 1e-9 * scale);
  EXPECT_LT(residual_change(marg), 1e-4 * change_before);
}
