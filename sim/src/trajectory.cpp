#include "mapdelta/sim/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <set>

#include "mapdelta/common/error.hpp"
#include "mapdelta/common/log.hpp"
#include "mapdelta/sim/random.hpp"

namespace mapdelta::sim {

SplineTrajectory::SplineTrajectory(std::vector<Eigen::Vector3d> control, double knot_dt)
    : control_(std::move(control)), dt_(knot_dt) {
  if (control_.size() < 4 || !(dt_ > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "spline needs >= 4 control points and knot_dt > 0");
  }
}

double SplineTrajectory::duration() const { return static_cast<double>(control_.size() - 3) * dt_; }

MotionState SplineTrajectory::Evaluate(double t) const {
  // Uniform cubic B-spline: segment i uses control points i..i+3 with local parameter u.
  const double s = std::clamp(t / dt_, 0.0, static_cast<double>(control_.size() - 3));
  const size_t i = std::min(static_cast<size_t>(s), control_.size() - 4);
  const double u = s - static_cast<double>(i), u2 = u * u, u3 = u2 * u;
  const double b[4] = {(1 - u) * (1 - u) * (1 - u) / 6, (3 * u3 - 6 * u2 + 4) / 6,
                       (-3 * u3 + 3 * u2 + 3 * u + 1) / 6, u3 / 6};
  const double db[4] = {-(1 - u) * (1 - u) / 2, (3 * u2 - 4 * u) / 2, (-3 * u2 + 2 * u + 1) / 2,
                        u2 / 2};
  const double ddb[4] = {1 - u, 3 * u - 2, -3 * u + 1, u};
  MotionState m;
  for (int k = 0; k < 4; ++k) {
    m.p_map += b[k] * control_[i + k];
    m.v_map += db[k] / dt_ * control_[i + k];
    m.a_map += ddb[k] / (dt_ * dt_) * control_[i + k];
  }
  // Heading follows the horizontal velocity; yaw rate = d/dt atan2(vy, vx).
  const double vx = m.v_map.x(), vy = m.v_map.y();
  const double vh2 = std::max(vx * vx + vy * vy, 1e-12);
  m.yaw = std::atan2(vy, vx);
  m.yaw_rate = (vx * m.a_map.y() - vy * m.a_map.x()) / vh2;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(m.yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m.T_map_body = SE3::Identity();
  m.T_map_body.linear() = R;
  m.T_map_body.translation() = m.p_map;
  m.omega_body = Eigen::Vector3d(0, 0, m.yaw_rate);
  m.f_body = R.transpose() * (m.a_map + Eigen::Vector3d(0, 0, kGravity));
  return m;
}

namespace {

using Node = std::pair<int, int>;

std::vector<Node> Neighbours(const StreetGrid& g, Node n) {
  std::vector<Node> out;
  const int nx = static_cast<int>(g.xs.size()), ny = static_cast<int>(g.ys.size());
  const Node cand[4] = {{n.first + 1, n.second},
                        {n.first - 1, n.second},
                        {n.first, n.second + 1},
                        {n.first, n.second - 1}};
  for (const Node& c : cand) {
    if (c.first >= 0 && c.first < nx && c.second >= 0 && c.second < ny) out.push_back(c);
  }
  return out;
}

double SegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                       const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double s = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (a + s * ab - p).norm();
}

// Shortest path (in edges) from `from` (arrived from `prev`) to `to`, never reversing
// direction; returns the nodes after `from`, ending at `to`.
std::vector<Node> PathNoUturn(const StreetGrid& g, Node prev, Node from, Node to) {
  using State = std::pair<Node, Node>;  // (node, previous node)
  std::map<State, State> parent;
  std::deque<State> queue{{from, prev}};
  parent[{from, prev}] = {from, prev};
  while (!queue.empty()) {
    const State cur = queue.front();
    queue.pop_front();
    if (cur.first == to && cur.first != from) {
      std::vector<Node> path;
      for (State s = cur; !(s.first == from && s.second == prev); s = parent[s])
        path.push_back(s.first);
      std::reverse(path.begin(), path.end());
      return path;
    }
    for (const Node& n : Neighbours(g, cur.first)) {
      if (n == cur.second) continue;
      const State next{n, cur.first};
      if (parent.count(next)) continue;
      parent[next] = cur;
      queue.push_back(next);
    }
  }
  return {};
}

}  // namespace

std::vector<Eigen::Vector2d> PlanRoute(const StreetGrid& g,
                                       const std::vector<Eigen::Vector2d>& targets, double length_m,
                                       uint64_t seed) {
  if (g.xs.size() < 2 || g.ys.size() < 2)
    throw Error(ErrorCode::kInvalidArgument, "route needs a 2x2 street grid");
  Rng rng(HashCombine(seed, 0x70de));
  // 1. For each target, the street segment closest to it.
  std::vector<std::pair<Node, Node>> segments;
  for (const Eigen::Vector2d& t : targets) {
    double best = 1e18;
    std::pair<Node, Node> seg;
    for (int i = 0; i < static_cast<int>(g.xs.size()); ++i) {
      for (int j = 0; j < static_cast<int>(g.ys.size()); ++j) {
        for (const Node& n : Neighbours(g, {i, j})) {
          const double d = SegmentDistance(t, g.Node(i, j), g.Node(n.first, n.second));
          if (d < best - 1e-9) {
            best = d;
            seg = {{i, j}, n};
          }
        }
      }
    }
    segments.push_back(seg);
  }
  // 2. Start one edge before the first segment, preferably in line with it.
  std::vector<Node> nodes;
  Node a = segments.empty() ? Node{0, 0} : segments[0].first;
  Node b = segments.empty() ? Neighbours(g, a)[0] : segments[0].second;
  Node lead{2 * a.first - b.first, 2 * a.second - b.second};
  const auto na = Neighbours(g, a);
  if (std::find(na.begin(), na.end(), lead) == na.end()) {
    lead = *std::find_if(na.begin(), na.end(), [&](const Node& n) { return n != b; });
  }
  nodes = {lead, a, b};
  // 3. Visit the remaining target segments in order (either direction).
  for (size_t k = 1; k < segments.size(); ++k) {
    const auto& [s0, s1] = segments[k];
    const Node cur = nodes.back(), prev = nodes[nodes.size() - 2];
    if ((prev == s0 && cur == s1) || (prev == s1 && cur == s0)) continue;
    std::vector<Node> p0 = PathNoUturn(g, prev, cur, s0);
    std::vector<Node> p1 = PathNoUturn(g, prev, cur, s1);
    // Reach one end, then traverse the segment to the other end.
    const bool via0 = !p0.empty() && (p1.empty() || p0.size() <= p1.size());
    std::vector<Node> path = via0 ? p0 : p1;
    // The node the path arrives from: `cur` itself when the end is its neighbour. Arriving
    // from the segment's other end means the segment was just flown; going back would be a
    // U-turn, which the spline turns into a 180 degree heading flip at zero speed.
    const Node arrived_from = path.size() >= 2 ? path[path.size() - 2] : cur;
    const Node other_end = via0 ? s1 : s0;
    if (arrived_from != other_end) path.push_back(other_end);
    nodes.insert(nodes.end(), path.begin(), path.end());
  }
  // 4. Random walk without U-turns, preferring streets not flown yet, until long enough.
  auto length = [&] {
    double l = 0;
    for (size_t i = 1; i < nodes.size(); ++i)
      l += (g.Node(nodes[i].first, nodes[i].second) -
            g.Node(nodes[i - 1].first, nodes[i - 1].second))
               .norm();
    return l;
  };
  std::set<std::pair<Node, Node>> flown;
  for (size_t i = 1; i < nodes.size(); ++i) flown.insert(std::minmax(nodes[i - 1], nodes[i]));
  while (length() < length_m) {
    const Node cur = nodes.back(), prev = nodes[nodes.size() - 2];
    std::vector<Node> options, fresh;
    for (const Node& n : Neighbours(g, cur)) {
      if (n == prev) continue;
      options.push_back(n);
      if (!flown.count(std::minmax(cur, n))) fresh.push_back(n);
    }
    const auto& pool = fresh.empty() ? options : fresh;
    const Node next = pool[static_cast<size_t>(rng.Int(0, static_cast<int>(pool.size()) - 1))];
    flown.insert(std::minmax(cur, next));
    nodes.push_back(next);
  }
  for (size_t i = 2; i < nodes.size(); ++i) {
    if (nodes[i] == nodes[i - 2])
      throw Error(ErrorCode::kInternal, "route planner produced a U-turn");
  }
  std::vector<Eigen::Vector2d> route;
  for (const Node& n : nodes) route.push_back(g.Node(n.first, n.second));
  return route;
}

SplineTrajectory MakeTrajectory(const std::vector<Eigen::Vector2d>& route, double height,
                                double spacing, double speed) {
  if (route.size() < 2 || !(spacing > 0) || !(speed > 0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "trajectory needs a route of >= 2 points, spacing > 0, speed > 0");
  }
  std::vector<Eigen::Vector3d> control;
  double along = 0, next = 0;
  const double amplitude = 0.1 * height, wavelength = 45.0;
  for (size_t i = 1; i < route.size(); ++i) {
    const Eigen::Vector2d a = route[i - 1], b = route[i];
    const double len = (b - a).norm();
    while (next <= along + len) {
      const Eigen::Vector2d p = a + (b - a) * ((next - along) / len);
      const double z = height + amplitude * std::sin(2 * M_PI * next / wavelength);
      control.emplace_back(p.x(), p.y(), z);
      next += spacing;
    }
    along += len;
  }
  return SplineTrajectory(std::move(control), spacing / speed);
}

}  // namespace mapdelta::sim
