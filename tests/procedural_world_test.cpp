// Procedural buildings: every type builds, its lanes keep the rig clear of every solid, the seed
// decides the building, and sessions simulated in it cover it and overlap.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>
#include <vector>

#include "mm4mm/sim/simulator.hpp"

namespace mm4mm::sim {
namespace {

SimulationConfig proceduralConfig(const std::string& building, const std::string& rig) {
  SimulationConfig config;
  config.world = "procedural";
  config.procedural.building = building;
  applyRigPreset(rig, &config);
  config.lidar.azimuth_step_deg = 3.0;
  config.layout.route_length_m = 80.0;
  return config;
}

// Every point of every lane edge, 0.25 m apart.
std::vector<Eigen::Vector2d> lanePoints(const LaneGraph& lanes) {
  std::vector<Eigen::Vector2d> points;
  for (std::size_t a = 0; a < lanes.nodes.size(); ++a)
    for (int b : lanes.neighbours[a]) {
      if (b < static_cast<int>(a)) continue;
      const Eigen::Vector2d from = lanes.nodes[a], to = lanes.nodes[b];
      const int steps = std::max(1, static_cast<int>(std::ceil((to - from).norm() / 0.25)));
      for (int k = 0; k <= steps; ++k)
        points.push_back(from + (to - from) * (static_cast<double>(k) / steps));
    }
  return points;
}

bool connected(const LaneGraph& lanes) {
  std::vector<bool> seen(lanes.nodes.size(), false);
  std::vector<int> stack{0};
  seen[0] = true;
  while (!stack.empty()) {
    const int n = stack.back();
    stack.pop_back();
    for (int m : lanes.neighbours[n])
      if (!seen[m]) seen[m] = true, stack.push_back(m);
  }
  return std::all_of(seen.begin(), seen.end(), [](bool s) { return s; });
}

// The seven-magnetometer bar is 3 m wide: every lane of every type keeps it (half of it plus a
// margin) clear of every solid up to the bar's height, over several seeds, and the lanes form
// one connected graph inside the floor.
TEST(ProceduralWorld, EveryBuildingsLanesKeepTheWidestRigClearAndConnected) {
  for (const std::string& building : proceduralBuildings())
    for (std::uint64_t seed : {1, 2, 3}) {
      const SimulationConfig config = proceduralConfig(building, "array7");
      const SimulatedWorld simulated(config, seed);
      const World& world = simulated.world;
      EXPECT_EQ(world.name, building);
      ASSERT_GE(world.lanes.nodes.size(), 4u) << building << " seed " << seed;
      EXPECT_TRUE(connected(world.lanes)) << building << " seed " << seed;
      EXPECT_FALSE(world.dipoles.empty());
      const double half_bar = 1.5;
      double tightest = 1e9;
      for (const Eigen::Vector2d& p : lanePoints(world.lanes)) {
        EXPECT_TRUE(world.floor_xy.contains(p)) << building << " seed " << seed;
        tightest = std::min(tightest, simulated.raycaster.clearance(p, 0.0, 0.5, 5.0));
      }
      EXPECT_GT(tightest, half_bar + 0.05) << building << " seed " << seed;
      EXPECT_LT(tightest, 5.0) << building << " seed " << seed;  // lanes pass near things
    }
}

// The seed decides the building: "any" draws every type over tuning seeds 1-20, and the same type
// at two seeds has other dimensions.
TEST(ProceduralWorld, TheSeedDrawsTheBuildingItsPlanAndItsSteel) {
  std::set<std::string> types;
  for (std::uint64_t seed = 1; seed <= 20; ++seed)
    types.insert(SimulatedWorld(proceduralConfig("any", "imu"), seed).world.name);
  EXPECT_EQ(types.size(), proceduralBuildings().size());

  const SimulationConfig config = proceduralConfig("garage", "imu");
  const SimulatedWorld a(config, 5), b(config, 5), c(config, 6);
  EXPECT_EQ(a.world.solids.size(), b.world.solids.size());
  ASSERT_EQ(a.world.dipoles.size(), b.world.dipoles.size());
  for (std::size_t i = 0; i < a.world.dipoles.size(); ++i)
    EXPECT_EQ(a.world.dipoles[i].moment_Am2, b.world.dipoles[i].moment_Am2);
  EXPECT_FALSE(a.world.floor_xy.isApprox(c.world.floor_xy));
}

// Sessions in a procedural building: magnetometers never inside a solid, readings of the Earth's
// order.
TEST(ProceduralWorld, SessionsDriveTheLanesAndADisjointOneKeepsAway) {
  for (const std::string& building : proceduralBuildings()) {
    SCOPED_TRACE(building);
    SimulationConfig config = proceduralConfig(building, "husky3");
    config.layout.disjoint_session = true;
    const SimulatedWorld simulated(config, 4);
    const auto routes = planSessionRoutes(simulated.world, config, 3, 4);
    ASSERT_EQ(routes.size(), 3u);
    const Session s = simulateSession(simulated, routes[0], config, "s0", deriveSeed(4, 100));
    ASSERT_FALSE(s.magnetometer.empty());
    for (const StampedPose& g : *s.ground_truth)
      for (const Eigen::Vector3d& m : s.rig.magnetometers_body)
        EXPECT_GT(simulated.raycaster.clearance((g.T_frame_body * m).head<2>(), 0.0, 1.0, 2.0), 0.1)
            << building;
    // Typical readings of the Earth's order; close to floor steel a few reach several times it
    // (300 µT within a few decimetres of a strong slab anchor), never the full scale of a common
    // magnetometer (±800 µT, PNI RM3100, MEMSIC MMC5983MA).
    std::vector<double> norms;
    for (const MagnetometerSample& m : s.magnetometer) norms.push_back(m.field_body_uT.norm());
    std::sort(norms.begin(), norms.end());
    const double median = norms[norms.size() / 2];
    const double p99 = norms[norms.size() * 99 / 100];
    EXPECT_GT(median, 25.0) << building;
    EXPECT_LT(median, 100.0) << building;
    EXPECT_LT(p99, 250.0) << building;
    EXPECT_LT(norms.back(), 800.0) << building;
  }
}

// Every building at every tuning seed has room for a disjoint session, and the disjoint route
// stays at least 5 m beyond the shared ones along the split axis.
TEST(ProceduralWorld, EveryBuildingKeepsADisjointSessionApart) {
  for (const std::string& building : proceduralBuildings())
    for (std::uint64_t seed = 1; seed <= 40; ++seed) {
      SimulationConfig config = proceduralConfig(building, seed % 2 ? "imu" : "array7");
      config.layout.disjoint_session = true;
      const World world = buildWorld(config, seed);
      std::vector<Route> routes;
      ASSERT_NO_THROW(routes = planSessionRoutes(world, config, 5, seed))
          << building << " seed " << seed;
      const int axis = world.split_axis;
      double shared_max = -1e9, disjoint_min = 1e9;
      for (int k = 0; k < 4; ++k)
        for (const auto& p : routes[k].waypoints) shared_max = std::max(shared_max, p[axis]);
      for (const auto& p : routes[4].waypoints) disjoint_min = std::min(disjoint_min, p[axis]);
      EXPECT_GE(disjoint_min - shared_max, 5.0) << building << " seed " << seed;
    }
}

TEST(ProceduralWorld, AnUnknownBuildingIsRefusedByName) {
  SimulationConfig config = proceduralConfig("castle", "imu");
  std::string error;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("castle"), std::string::npos);
}

}  // namespace
}  // namespace mm4mm::sim
