#include "mm4mm/sim/route.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

#include "mm4mm/core/pose.hpp"

namespace mm4mm::sim {

double Route::length() const {
  double length = 0.0;
  for (std::size_t i = 1; i < waypoints.size(); ++i)
    length += (waypoints[i] - waypoints[i - 1]).norm();
  return length;
}

namespace {

double headingOf(const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
  const Eigen::Vector2d d = to - from;
  return std::atan2(d.y(), d.x());
}

std::vector<int> allowedNeighbours(const LaneGraph& lanes, int node, const NodeMask& allowed) {
  std::vector<int> result;
  for (int n : lanes.neighbours[node])
    if (allowed[n]) result.push_back(n);
  return result;
}

}  // namespace

Route randomWalkRoute(const LaneGraph& lanes, int start_node, const Eigen::Vector2d& start_position,
                      double start_yaw_rad, double length_m, const NodeMask& allowed,
                      std::mt19937_64* rng) {
  if (!allowed.at(start_node)) throw std::invalid_argument("random walk starts on a masked node");
  Route route;
  route.start_yaw_rad = start_yaw_rad;
  route.waypoints.push_back(start_position);
  if ((start_position - lanes.nodes[start_node]).norm() > 1e-9)
    route.waypoints.push_back(lanes.nodes[start_node]);

  std::set<std::pair<int, int>> driven;
  int previous = -1;
  int current = start_node;
  double heading = start_yaw_rad;
  while (route.length() < length_m) {
    std::vector<int> options = allowedNeighbours(lanes, current, allowed);
    if (options.empty()) throw std::invalid_argument("random walk start node has no allowed lane");
    if (options.size() > 1)
      options.erase(std::remove(options.begin(), options.end(), previous), options.end());
    std::vector<double> weights;
    for (int n : options) {
      const double turn =
          std::abs(wrapAngle(headingOf(lanes.nodes[current], lanes.nodes[n]) - heading));
      const bool new_lane = !driven.count({std::min(current, n), std::max(current, n)});
      // The first edge follows the start heading: sessions begin by driving the way they face.
      const double straight = previous < 0 ? std::exp(-4.0 * turn) : (turn < 0.1 ? 2.0 : 1.0);
      weights.push_back(straight * (new_lane ? 4.0 : 1.0));
    }
    std::discrete_distribution<int> pick(weights.begin(), weights.end());
    const int next = options[pick(*rng)];
    driven.insert({std::min(current, next), std::max(current, next)});
    heading = headingOf(lanes.nodes[current], lanes.nodes[next]);
    previous = current;
    current = next;
    route.waypoints.push_back(lanes.nodes[current]);
  }
  return route;
}

Route sweepRoute(const LaneGraph& lanes, double x_min, double x_max, const NodeMask& allowed) {
  // Lanes keyed by their y (rounded to cm); each lane's nodes inside the window sorted by x.
  std::map<long, std::vector<Eigen::Vector2d>> lanes_by_y;
  for (std::size_t i = 0; i < lanes.nodes.size(); ++i) {
    const Eigen::Vector2d& p = lanes.nodes[i];
    if (allowed[i] && p.x() >= x_min - 1e-9 && p.x() <= x_max + 1e-9)
      lanes_by_y[std::lround(p.y() * 100.0)].push_back(p);
  }
  Route route;
  bool forward = true;
  for (auto& [key, nodes] : lanes_by_y) {
    std::sort(nodes.begin(), nodes.end(),
              [](const auto& a, const auto& b) { return a.x() < b.x(); });
    if (nodes.size() < 2) continue;
    route.waypoints.push_back(forward ? nodes.front() : nodes.back());
    route.waypoints.push_back(forward ? nodes.back() : nodes.front());
    forward = !forward;
  }
  if (route.waypoints.size() < 2) throw std::invalid_argument("sweep window holds no lane");
  route.start_yaw_rad = headingOf(route.waypoints[0], route.waypoints[1]);
  return route;
}

}  // namespace mm4mm::sim
