// The session frame's height above the floor from its scans, against simulated sessions whose
// frame is known to start on the floor, and the same sessions with their frame raised.

#include "mm4mm/geometry/floor_height.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "mm4mm/sim/simulator.hpp"

namespace mm4mm {
namespace {

Session simulated(const std::string& world, const std::string& preset, std::uint64_t seed) {
  sim::SimulationConfig config;
  config.world = world;
  config.lidar.azimuth_step_deg = 3.0;
  config.layout.route_length_m = 60.0;
  sim::applyRigPreset(preset, &config);
  const sim::SimulatedWorld simulated_world(config, seed);
  const auto routes = sim::planSessionRoutes(simulated_world.world, config, 1, seed);
  return sim::simulateSession(simulated_world, routes.front(), config, "s0",
                              sim::deriveSeed(seed, 100));
}

// The frame's origin moved `height_m` up (and turned about z): the body, still on the floor, is
// that far below the frame's origin; scans stay in the body frame.
Session withFrameRaised(Session session, double height_m) {
  Eigen::Isometry3d T_new_old = Eigen::Isometry3d::Identity();
  T_new_old.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_new_old.translation() = Eigen::Vector3d(3.0, -2.0, -height_m);
  for (StampedPose& k : session.keyframes) k.T_frame_body = T_new_old * k.T_frame_body;
  session.rig.frame_height_above_floor_m.reset();
  return session;
}

TEST(FloorHeight, ARobotsFrameOnTheFloorIsFoundThereAndARaisedOneAtItsHeight) {
  for (const char* world : {"warehouse", "corridor", "procedural"}) {
    SCOPED_TRACE(world);
    const Session session = simulated(world, "imu", 3);
    ASSERT_TRUE(session.rig.frame_height_above_floor_m);  // the simulator states 0
    const std::optional<FloorHeight> floor = floorHeightFromScans(session);
    ASSERT_TRUE(floor);
    EXPECT_NEAR(floor->frame_height_m, *session.rig.frame_height_above_floor_m, 0.03);
    EXPECT_NEAR(floor->body_height_m, 0.0, 0.03);
    EXPECT_GT(floor->floor_points, 1000);
    for (double raised : {0.45, 1.2}) {
      const std::optional<FloorHeight> moved =
          floorHeightFromScans(withFrameRaised(session, raised));
      ASSERT_TRUE(moved);
      EXPECT_NEAR(moved->frame_height_m, raised, 0.03);
    }
  }
}

TEST(FloorHeight, AHandheldDeviceThatSwaysAndTiltsStillFindsTheFloor) {
  const Session session = simulated("warehouse", "handheld", 5);
  const std::optional<FloorHeight> floor = floorHeightFromScans(withFrameRaised(session, 1.3));
  ASSERT_TRUE(floor);
  EXPECT_NEAR(floor->frame_height_m, 1.3, 0.05);
}

// Real LiDAR drivers write a beam that returned nothing as a point at the sensor (the real scan
// pair in ../shared/data holds 5 032 such zeros in 69 088 points): not a surface.
TEST(FloorHeight, ReturnsAtTheLidarItselfAreNotAFloor) {
  Session session = simulated("warehouse", "imu", 6);
  const Eigen::Vector3f lidar = session.rig.T_body_lidar.translation().cast<float>();
  for (PointCloud& scan : session.scans) {
    scan.insert(scan.end(), 3 * scan.size(), lidar);
    scan.push_back({0.0f, 0.0f, -1e30f});  // and a wild return far below: no bin, no overflow
  }
  const std::optional<FloorHeight> floor = floorHeightFromScans(session);
  ASSERT_TRUE(floor);
  EXPECT_NEAR(floor->frame_height_m, 0.0, 0.03);
  FloorHeightConfig keeping_them;  // the same without the minimum range: they hide the floor
  keeping_them.min_range_m = 0.0;
  const std::optional<FloorHeight> misled = floorHeightFromScans(session, keeping_them);
  EXPECT_TRUE(!misled || std::abs(misled->frame_height_m) > 0.5);
}

TEST(FloorHeight, StatedHeightWinsAndNoFloorSeenGivesNone) {
  Session session = simulated("corridor", "imu", 4);
  session.rig.frame_height_above_floor_m = 0.7;
  ASSERT_TRUE(frameHeightAboveFloor(session));
  EXPECT_EQ(frameHeightAboveFloor(session)->height_m, 0.7);
  EXPECT_FALSE(frameHeightAboveFloor(session)->from_scans);
  session.rig.frame_height_above_floor_m.reset();
  ASSERT_TRUE(frameHeightAboveFloor(session));
  EXPECT_NEAR(frameHeightAboveFloor(session)->height_m, 0.0, 0.03);
  EXPECT_TRUE(frameHeightAboveFloor(session)->from_scans);

  // Scans that miss the floor (the floor's points cut away, say by a too-near range limit) show
  // the walls down to it, not a floor; a LiDAR that sees nothing below itself shows nothing.
  const auto cut = [](Session session, float below) {
    for (PointCloud& scan : session.scans)
      scan.erase(std::remove_if(scan.begin(), scan.end(),
                                [&](const Eigen::Vector3f& p) { return p.z() < below; }),
                 scan.end());
    return session;
  };
  EXPECT_FALSE(floorHeightFromScans(cut(session, 0.05f)));
  const Session looking_up =
      cut(session, static_cast<float>(session.rig.T_body_lidar.translation().z()) + 0.2f);
  EXPECT_FALSE(floorHeightFromScans(looking_up));
  EXPECT_FALSE(frameHeightAboveFloor(looking_up));

  // The LiDAR's pose in the body not stated (identity) while the body's origin is on the floor,
  // as an import from a bag without it gives: the floor is still found.
  session.rig.T_body_lidar = Eigen::Isometry3d::Identity();
  ASSERT_TRUE(floorHeightFromScans(session));
  EXPECT_NEAR(floorHeightFromScans(session)->frame_height_m, 0.0, 0.03);

  session.scans.clear();  // magnetic only
  EXPECT_FALSE(frameHeightAboveFloor(session));
}

}  // namespace
}  // namespace mm4mm
