#pragma once
// Simulated worlds: solid geometry for the LiDAR, steel dipoles for the magnetic field, and the
// free lanes a robot may drive along. World frame: z up, floor at z = 0, metres.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::sim {

/// A vertical extrusion of a convex polygon between two heights. Walls, pillars, shelf uprights,
/// boards and goods are all solids of this kind, which keeps ray casting exact and simple.
struct Solid {
  std::vector<Eigen::Vector2d> polygon;  ///< convex, counter-clockwise, world x-y (m)
  double z_min_m = 0.0;
  double z_max_m = 0.0;

  Eigen::AlignedBox2d planBounds() const;
  bool contains(const Eigen::Vector3d& point) const;
  /// Distance in plan from `point` to the polygon (0 inside).
  double planDistance(const Eigen::Vector2d& point) const;
  /// Ray parameter of the first entry into the solid along origin + t * direction with
  /// t in [t_min, t_max], or a negative value when the ray misses it there.
  double intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_min,
                   double t_max) const;
};

/// Axis-aligned box solid.
Solid boxSolid(const Eigen::Vector2d& min_xy, const Eigen::Vector2d& max_xy, double z_min_m,
               double z_max_m);
/// Regular polygonal prism (for example an octagonal pillar) with circumradius `radius_m`.
Solid regularPrism(const Eigen::Vector2d& centre, double radius_m, int sides, double z_min_m,
                   double z_max_m);

/// A point magnetic dipole: moment in A·m² at a position in metres.
struct MagneticDipole {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d moment_Am2 = Eigen::Vector3d::Zero();
};

/// A magnetic point charge (A·m): the end of a bar magnetised along its axis, whose field is
/// B = μ0/(4π) · q r̂ / |r|² (floor reinforcement, simulation_config.hpp FloorMeshConfig).
struct MagneticCharge {
  Eigen::Vector3d position_m = Eigen::Vector3d::Zero();
  double charge_Am = 0.0;
};

/// A stretch where the scans constrain nothing along `axis` (unit, world x-y): a LiDAR odometry
/// drifts along it there.
struct DegenerateRegion {
  Eigen::AlignedBox2d area;
  Eigen::Vector2d axis = Eigen::Vector2d::UnitX();
};

/// Centre lines of the free lanes: nodes at lane crossings, edges along lanes. Any point within a
/// lane's clearance of an edge is free space for the robot and its sensor bar.
struct LaneGraph {
  std::vector<Eigen::Vector2d> nodes;
  std::vector<std::vector<int>> neighbours;

  int addNode(const Eigen::Vector2d& position);
  void connect(int a, int b);
};

struct World {
  std::string name;
  Eigen::AlignedBox2d floor_xy;  ///< interior of the walls
  double ceiling_height_m = 0.0;
  std::vector<Solid> solids;
  std::vector<MagneticDipole> dipoles;
  std::vector<MagneticCharge> charges;  ///< bar ends of the floor's reinforcement mesh
  std::vector<DegenerateRegion> degenerate_regions;
  LaneGraph lanes;
  /// The plan axis (0 x, 1 y) along which a disjoint session is kept apart from the others.
  int split_axis = 1;

  /// The axis along which the odometry is unconstrained at `position` (world x-y), if any.
  std::optional<Eigen::Vector2d> degenerateAxisAt(const Eigen::Vector2d& position) const;
};

/// Builds the world named by `config.world`. Geometry depends only on the config; the steel's
/// magnetic moments are drawn from `seed`.
World buildWorld(const SimulationConfig& config, std::uint64_t seed);

}  // namespace mm4mm::sim
