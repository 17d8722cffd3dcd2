// Trajectory smoothness and IMU exactness: integrating the generated (noise-free) IMU with RK4
// from the true initial state reproduces the ground-truth position within 1 cm over 10 s.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "mapdelta/sim/generator.hpp"
#include "mapdelta/sim/imu.hpp"
#include "mapdelta/sim/random.hpp"
#include "mapdelta/sim/trajectory.hpp"

namespace mapdelta::sim {
namespace {

SequencePlan TinyPlan(const std::string& name) {
  SimConfig c = PresetConfig("tiny");
  const Scenes scenes = BuildScenes(c);
  return PlanSequence(c, scenes, name);
}

struct State {
  Eigen::Quaterniond q;
  Eigen::Vector3d p, v;
};

// Derivative of (q, p, v) under body rate w and specific force f (map z up, gravity -z).
void Deriv(const State& s, const Eigen::Vector3d& w, const Eigen::Vector3d& f, Eigen::Vector4d* dq,
           Eigen::Vector3d* dp, Eigen::Vector3d* dv) {
  const Eigen::Quaterniond wq(0, w.x(), w.y(), w.z());
  const Eigen::Quaterniond qd = s.q * wq;
  *dq = 0.5 * Eigen::Vector4d(qd.w(), qd.x(), qd.y(), qd.z());
  *dp = s.v;
  *dv = s.q.normalized() * f - Eigen::Vector3d(0, 0, kGravity);
}

State Step(const State& s, double h, const Eigen::Vector3d& w0, const Eigen::Vector3d& f0,
           const Eigen::Vector3d& wm, const Eigen::Vector3d& fm, const Eigen::Vector3d& w1,
           const Eigen::Vector3d& f1) {
  auto add = [](const State& a, double k, const Eigen::Vector4d& dq, const Eigen::Vector3d& dp,
                const Eigen::Vector3d& dv) {
    State r;
    r.q = Eigen::Quaterniond(a.q.w() + k * dq[0], a.q.x() + k * dq[1], a.q.y() + k * dq[2],
                             a.q.z() + k * dq[3]);
    r.p = a.p + k * dp;
    r.v = a.v + k * dv;
    return r;
  };
  Eigen::Vector4d q1, q2, q3, q4;
  Eigen::Vector3d p1, p2, p3, p4, v1, v2, v3, v4;
  Deriv(s, w0, f0, &q1, &p1, &v1);
  Deriv(add(s, h / 2, q1, p1, v1), wm, fm, &q2, &p2, &v2);
  Deriv(add(s, h / 2, q2, p2, v2), wm, fm, &q3, &p3, &v3);
  Deriv(add(s, h, q3, p3, v3), w1, f1, &q4, &p4, &v4);
  State r = add(s, h / 6, q1 + 2 * q2 + 2 * q3 + q4, p1 + 2 * p2 + 2 * p3 + p4,
                v1 + 2 * v2 + 2 * v3 + v4);
  r.q.normalize();
  return r;
}

TEST(SimImu, Rk4IntegrationReproducesGroundTruthOver10s) {
  const SequencePlan plan = TinyPlan("S1_01");
  ASSERT_GE(plan.duration_s, 10.0);
  const double rate = 200.0;
  // A 10 s window around the sharpest turn, so rotation matters.
  double t_max = 0, w_max = 0;
  for (double t = 0; t < plan.duration_s; t += 0.05) {
    const double w = std::abs(plan.trajectory.Evaluate(t).yaw_rate);
    if (w > w_max) {
      w_max = w;
      t_max = t;
    }
  }
  const double t_start = std::floor(std::clamp(t_max - 5.0, 0.0, plan.duration_s - 10.0));
  const auto all =
      SimulateImu(plan.trajectory, 0, rate, plan.duration_s, NoiseFor(NoiseLevel::kNone), 7);
  const size_t k0 = static_cast<size_t>(t_start * rate);
  const std::vector<ImuSample> imu(all.begin() + static_cast<long>(k0),
                                   all.begin() + static_cast<long>(k0 + 2001));
  ASSERT_EQ(imu.size(), 2001u);
  const MotionState m0 = plan.trajectory.Evaluate(t_start);
  State s{Eigen::Quaterniond(m0.T_map_body.linear()), m0.p_map, m0.v_map};
  // RK4 with step 2/rate: the middle sample is the midpoint value.
  for (size_t k = 0; k + 2 < imu.size(); k += 2) {
    s = Step(s, 2.0 / rate, imu[k].gyro, imu[k].accel, imu[k + 1].gyro, imu[k + 1].accel,
             imu[k + 2].gyro, imu[k + 2].accel);
  }
  const MotionState m1 = plan.trajectory.Evaluate(t_start + 10.0);
  RecordProperty("position_error_m", std::to_string((s.p - m1.p_map).norm()));
  EXPECT_LT((s.p - m1.p_map).norm(), 0.01) << "position error after 10 s";
  EXPECT_LT((s.v - m1.v_map).norm(), 0.005);
  EXPECT_LT(Eigen::AngleAxisd(s.q.toRotationMatrix().transpose() * m1.T_map_body.linear()).angle(),
            1e-4);
  // And the ground truth actually moved and turned (not a trivially straight flight).
  EXPECT_GT((m1.p_map - m0.p_map).norm(), 20.0);
  double turned = 0;
  for (size_t k = 0; k < imu.size(); ++k) turned += std::abs(imu[k].gyro.z()) / rate;
  EXPECT_GT(turned, 1.0) << "the first 10 s should include a corner";
}

TEST(SimImu, SpecificForceMatchesFiniteDifferencesOfGroundTruth) {
  const SequencePlan plan = TinyPlan("S2_01");
  const double h = 1e-4;
  for (double t = 1.0; t < plan.duration_s - 1.0; t += 0.37) {
    const MotionState m = plan.trajectory.Evaluate(t);
    const Eigen::Vector3d a_fd = (plan.trajectory.Evaluate(t + h).p_map - 2 * m.p_map +
                                  plan.trajectory.Evaluate(t - h).p_map) /
                                 (h * h);
    const Eigen::Vector3d f_expected =
        m.T_map_body.linear().transpose() * (a_fd + Eigen::Vector3d(0, 0, kGravity));
    EXPECT_LT((m.f_body - f_expected).norm(), 1e-3) << "t=" << t;
    const Eigen::Matrix3d dR =
        m.T_map_body.linear().transpose() * plan.trajectory.Evaluate(t + h).T_map_body.linear();
    const Eigen::AngleAxisd aa(dR);
    EXPECT_NEAR(aa.angle() * aa.axis().z() / h, m.omega_body.z(), 1e-3) << "t=" << t;
  }
}

// Every sequence of the tiny and paper presets: the S2 routes used to reverse at a segment
// end (s0 -> s1 -> s0), which the spline flew as a stop and a 180 degree heading flip
// between two IMU samples with zero gyro rate.
TEST(SimTrajectory, ContinuousAccelerationAndBoundedRates) {
  for (const char* preset : {"tiny", "paper"}) {
    const SimConfig c = PresetConfig(preset);
    const Scenes scenes = BuildScenes(c);
    for (const std::string& seq : c.sequences) {
      const SequencePlan plan = PlanSequence(c, scenes, seq);
      const std::string name = std::string(preset) + " " + seq;
      const double knot =
          plan.trajectory.duration() / static_cast<double>(plan.trajectory.control().size() - 3);
      double max_rate = 0, min_speed = 1e9;
      for (double t = knot; t < plan.duration_s - knot; t += knot) {
        // Across each knot the acceleration changes by at most jerk * 2e-6 s.
        const MotionState a = plan.trajectory.Evaluate(t - 1e-6),
                          b = plan.trajectory.Evaluate(t + 1e-6);
        EXPECT_LT((a.a_map - b.a_map).norm(), 1e-3) << name << " t=" << t;
      }
      for (double t = 0; t <= plan.duration_s; t += 0.01) {
        const MotionState m = plan.trajectory.Evaluate(t);
        max_rate = std::max(max_rate, std::abs(m.yaw_rate));
        min_speed = std::min(min_speed, m.v_map.head<2>().norm());
      }
      EXPECT_LT(max_rate, 2.0) << name << ": yaw rate must stay bounded (rad/s)";
      EXPECT_GT(min_speed, 1.0) << name << ": the MAV never hovers (heading would be undefined)";
      EXPECT_GT(plan.length_m, 80.0);
    }
  }
}

// The planner on its own, over many seeds and target sets: no route ever goes back the way
// it came (consecutive edges a -> b -> a).
TEST(SimTrajectory, RoutesNeverReverse) {
  StreetGrid g;
  g.xs = {0, 40, 80, 120};
  g.ys = {0, 40, 80};
  int routes = 0;
  for (uint64_t seed = 1; seed <= 200; ++seed) {
    Rng rng(seed);
    std::vector<Eigen::Vector2d> targets;
    for (int k = 0; k < 3; ++k) targets.emplace_back(rng.Uniform(-10, 130), rng.Uniform(-10, 90));
    const std::vector<Eigen::Vector2d> route = PlanRoute(g, targets, 600.0, seed);
    ASSERT_GE(route.size(), 3u);
    for (size_t i = 2; i < route.size(); ++i) {
      ASSERT_GT((route[i] - route[i - 2]).norm(), 1e-9)
          << "seed " << seed << " reverses at node " << i - 1;
    }
    ++routes;
  }
  EXPECT_EQ(routes, 200);
}

}  // namespace
}  // namespace mapdelta::sim
