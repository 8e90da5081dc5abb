#pragma once
// Routes through a world's lane graph: the robot drives along lane centre lines, which are
// free of geometry for the whole sensor bar by construction of the world.

#include <Eigen/Core>
#include <random>
#include <vector>

#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

/// A polyline to drive along, starting at `waypoints.front()` facing `start_yaw_rad`.
struct Route {
  std::vector<Eigen::Vector2d> waypoints;
  double start_yaw_rad = 0.0;

  double length() const;
};

/// Nodes a route may use; `allowed[i]` for node i.
using NodeMask = std::vector<bool>;

/// A random walk over allowed lane nodes from `start_node`, at least `length_m` long. The first
/// edge is the one closest to the start heading; later steps prefer lanes not yet driven and
/// going straight, and turn back only at dead ends.
Route randomWalkRoute(const LaneGraph& lanes, int start_node, const Eigen::Vector2d& start_position,
                      double start_yaw_rad, double length_m, const NodeMask& allowed,
                      std::mt19937_64* rng);

/// A lawnmower sweep over the lanes of a grid-like graph within x in [x_min, x_max]: along the
/// first lane (lowest y) forward, the next backward, and so on, crossing at the window's ends.
Route sweepRoute(const LaneGraph& lanes, double x_min, double x_max, const NodeMask& allowed);

}  // namespace mm4mm::sim
