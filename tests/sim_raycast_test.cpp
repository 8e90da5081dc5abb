// Ray casting against analytic distances, and the acceleration grid against brute force.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "mm4mm/sim/raycaster.hpp"
#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {
namespace {

World boxRoom() {
  World world;
  world.name = "room";
  world.floor_xy = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(20, 10));
  world.ceiling_height_m = 3.0;
  world.solids.push_back(boxSolid({20, 0}, {20.5, 10}, 0.0, 3.0));  // east wall
  world.solids.push_back(boxSolid({5, 4}, {6, 6}, 0.0, 2.0));       // a low box
  world.solids.push_back(regularPrism({12, 5}, 0.5, 8, 0.0, 3.0));  // octagonal pillar
  return world;
}

TEST(Raycaster, HitsWallFloorCeilingAtAnalyticDistances) {
  const World world = boxRoom();
  const Raycaster caster(world);
  const Eigen::Vector3d origin(1.0, 2.0, 1.0);
  // Straight east at y = 2 misses the box and the pillar and meets the wall at x = 20.
  EXPECT_NEAR(*caster.cast(origin, Eigen::Vector3d::UnitX(), 100.0), 19.0, 1e-9);
  // Down 30 degrees: floor at 1 / sin(30°) = 2 m.
  const double a = 30.0 * M_PI / 180.0;
  EXPECT_NEAR(*caster.cast(origin, Eigen::Vector3d(std::cos(a), 0, -std::sin(a)), 100.0), 2.0,
              1e-9);
  // Up 45 degrees: ceiling at 2 / sin(45°).
  const double b = M_PI / 4;
  EXPECT_NEAR(*caster.cast(origin, Eigen::Vector3d(std::cos(b), 0, std::sin(b)), 100.0),
              2.0 / std::sin(b), 1e-9);
  // Towards the box's west face (x = 5) at y = 5.
  EXPECT_NEAR(*caster.cast({1.0, 5.0, 1.0}, Eigen::Vector3d::UnitX(), 100.0), 4.0, 1e-9);
  // Over the low box (z = 2.5) it reaches the pillar's flat west face: the octagon's apothem.
  const double apothem = 0.5 * std::cos(M_PI / 8);
  EXPECT_NEAR(*caster.cast({1.0, 5.0, 2.5}, Eigen::Vector3d::UnitX(), 100.0), 11.0 - apothem, 1e-9);
  // Out of range returns nothing.
  EXPECT_FALSE(caster.cast(origin, Eigen::Vector3d::UnitX(), 10.0).has_value());
}

TEST(Raycaster, GridAgreesWithBruteForceInTheWarehouse) {
  SimulationConfig config;
  const World world = buildWorld(config, 1);
  const Raycaster caster(world);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> ux(1.0, 84.0), uy(1.0, 74.0), uz(0.3, 2.0),
      angle(-M_PI, M_PI), elevation(-0.5, 0.2);
  int compared = 0;
  for (int i = 0; i < 3000; ++i) {
    const Eigen::Vector3d origin(ux(rng), uy(rng), uz(rng));
    bool inside = false;
    for (const Solid& s : world.solids) inside |= s.contains(origin);
    if (inside) continue;
    const double yaw = angle(rng), el = elevation(rng);
    const Eigen::Vector3d dir(std::cos(el) * std::cos(yaw), std::cos(el) * std::sin(yaw),
                              std::sin(el));
    double brute = std::numeric_limits<double>::infinity();
    for (const Solid& s : world.solids) {
      const double t = s.intersect(origin, dir, 0.0, 1e9);
      if (t >= 0.0) brute = std::min(brute, t);
    }
    if (dir.z() < 0) brute = std::min(brute, -origin.z() / dir.z());
    if (dir.z() > 0) brute = std::min(brute, (world.ceiling_height_m - origin.z()) / dir.z());
    const auto fast = caster.cast(origin, dir, 200.0);
    ASSERT_TRUE(fast.has_value());
    EXPECT_NEAR(*fast, brute, 1e-9) << "ray " << i;
    ++compared;
  }
  EXPECT_GT(compared, 2000);
}

TEST(Solid, ContainsAndPlanDistance) {
  const Solid box = boxSolid({0, 0}, {2, 1}, 0.0, 1.0);
  EXPECT_TRUE(box.contains({1.0, 0.5, 0.5}));
  EXPECT_FALSE(box.contains({1.0, 0.5, 1.5}));
  EXPECT_DOUBLE_EQ(box.planDistance({1.0, 0.5}), 0.0);
  EXPECT_NEAR(box.planDistance({3.0, 0.5}), 1.0, 1e-12);
  EXPECT_NEAR(box.planDistance({3.0, 2.0}), std::sqrt(2.0), 1e-12);
}

TEST(LaneGraph, WarehouseAndCorridorLanesClearTheSensorBar) {
  for (const std::string name : {"warehouse", "corridor"}) {
    SimulationConfig config;
    config.world = name;
    const World world = buildWorld(config, 1);
    const Raycaster caster(world);
    ASSERT_GT(world.lanes.nodes.size(), 8u) << name;
    // Every point of every lane edge keeps the 3 m sensor bar (1.5 m half-width) off the solids.
    for (std::size_t a = 0; a < world.lanes.nodes.size(); ++a)
      for (int b : world.lanes.neighbours[a])
        for (double s = 0.0; s <= 1.0; s += 0.02) {
          const Eigen::Vector2d p = (1 - s) * world.lanes.nodes[a] + s * world.lanes.nodes[b];
          EXPECT_GT(caster.clearance(p, 0.0, 1.0, 5.0), 1.6) << name << " at " << p.transpose();
        }
  }
}

}  // namespace
}  // namespace mm4mm::sim
