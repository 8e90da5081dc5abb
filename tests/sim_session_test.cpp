// Simulated sessions against their own ground truth: geometry, drift, magnetometers, layouts,
// determinism.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/trajectory.hpp"
#include "mm4mm/magnetic/fingerprint.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "mm4mm/sim/trajectory.hpp"

namespace mm4mm::sim {
namespace {

// Small and quick: coarse LiDAR, short routes. The physics is the same as the presets'.
SimulationConfig quickConfig(const std::string& world) {
  SimulationConfig config;
  config.world = world;
  config.lidar.azimuth_step_deg = 3.0;
  config.layout.route_length_m = 80.0;
  config.layout.window_length_m = 24.0;
  config.layout.window_spacing_m = 16.0;
  return config;
}

double distanceToSurface(const World& world, const Eigen::Vector3d& p) {
  double best = std::min(std::abs(p.z()), std::abs(world.ceiling_height_m - p.z()));
  for (const Solid& s : world.solids) {
    const double plan = s.planDistance(p.head<2>());
    const double vertical = std::max({0.0, s.z_min_m - p.z(), p.z() - s.z_max_m});
    best = std::min(best, std::hypot(plan, vertical));
  }
  return best;
}

Eigen::Isometry3d frameOf(const Session& s) {
  // T_world_session: ground truth of keyframe 0 composed with the inverse of its odometry pose.
  return s.ground_truth->front().T_frame_body * s.keyframes.front().T_frame_body.inverse();
}

class SimulatedWarehouse : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    config_ = new SimulationConfig(quickConfig("warehouse"));
    applyRigPreset("array7", config_);  // realistic sensors, the default
    world_ = new SimulatedWorld(*config_, 7);
    const auto routes = planSessionRoutes(world_->world, *config_, 2, 7);
    sessions_ = new std::vector<Session>;
    for (int k = 0; k < 2; ++k)
      sessions_->push_back(simulateSession(*world_, routes[k], *config_, "s" + std::to_string(k),
                                           deriveSeed(7, 100 + k)));
  }
  static void TearDownTestSuite() {
    delete sessions_;
    delete world_;
    delete config_;
  }
  static SimulationConfig* config_;
  static SimulatedWorld* world_;
  static std::vector<Session>* sessions_;
};
SimulationConfig* SimulatedWarehouse::config_ = nullptr;
SimulatedWorld* SimulatedWarehouse::world_ = nullptr;
std::vector<Session>* SimulatedWarehouse::sessions_ = nullptr;

TEST_F(SimulatedWarehouse, ScanPointsLieOnTheWorldGeometryAtGroundTruthPoses) {
  const Session& s = sessions_->front();
  ASSERT_EQ(s.scans.size(), s.keyframes.size());
  int checked = 0, off_surface = 0;
  for (std::size_t i = 0; i < s.scans.size(); i += 7) {
    const Eigen::Isometry3d& G = (*s.ground_truth)[i].T_frame_body;
    ASSERT_GT(s.scans[i].size(), 1000u);
    for (std::size_t j = 0; j < s.scans[i].size(); j += 97) {
      const Eigen::Vector3d p = G * s.scans[i][j].cast<double>();
      if (distanceToSurface(world_->world, p) > 0.1) ++off_surface;  // 5 sigma of range noise
      ++checked;
    }
  }
  EXPECT_GT(checked, 500);
  EXPECT_LE(off_surface, checked / 500);
}

TEST_F(SimulatedWarehouse, ScanPointsDoNotFitTheDriftedOdometryAsWellAsTheTruth) {
  // The odometry is in the session frame; mapped into the world it must be close to but not
  // equal to the truth at the end of the route.
  const Session& s = sessions_->front();
  const Eigen::Isometry3d T_world_session = frameOf(s);
  const Eigen::Isometry3d last_odometry = T_world_session * s.keyframes.back().T_frame_body;
  const double error =
      (last_odometry.translation() - s.ground_truth->back().T_frame_body.translation()).norm();
  EXPECT_GT(error, 1e-4);
}

TEST_F(SimulatedWarehouse, OdometryDriftStaysWithinConfiguredBounds) {
  for (const Session& s : *sessions_) {
    EXPECT_TRUE(s.keyframes.front().T_frame_body.translation().isZero(1e-12));
    EXPECT_NEAR(yawOf(s.keyframes.front().T_frame_body.linear()), 0.0, 1e-12);
    const Eigen::Isometry3d T_world_session = frameOf(s);
    double travelled = 0.0, worst_ratio = 0.0;
    for (std::size_t i = 1; i < s.keyframes.size(); ++i) {
      travelled += ((*s.ground_truth)[i].T_frame_body.translation() -
                    (*s.ground_truth)[i - 1].T_frame_body.translation())
                       .norm();
      const Eigen::Vector3d estimate = T_world_session * s.keyframes[i].T_frame_body.translation();
      const double error = (estimate - (*s.ground_truth)[i].T_frame_body.translation()).norm();
      if (travelled > 20.0) worst_ratio = std::max(worst_ratio, error / travelled);
    }
    // Scale error up to 0.2 %, yaw drift of hundredths of a degree per metre and the IMU's
    // attitude error: below 1.5 %.
    EXPECT_LT(worst_ratio, 0.015) << s.id;
    EXPECT_GT(travelled, 0.9 * config_->layout.route_length_m) << s.id;
  }
}

TEST_F(SimulatedWarehouse, KeyframesAboutEveryMetre) {
  const Session& s = sessions_->front();
  int long_gaps = 0;
  for (std::size_t i = 1; i < s.keyframes.size(); ++i) {
    const double step = ((*s.ground_truth)[i].T_frame_body.translation() -
                         (*s.ground_truth)[i - 1].T_frame_body.translation())
                            .norm();
    EXPECT_LT(step, 1.05);
    EXPECT_GT(s.keyframes[i].time_s, s.keyframes[i - 1].time_s);
    if (step > 0.9) ++long_gaps;
  }
  EXPECT_GT(long_gaps, static_cast<int>(s.keyframes.size()) / 2);
}

// At keyframe times the true pose is known exactly. Realistic sensors read S·B + h + v·k plus
// noise, drift and the acceleration current: corrected with the session's true calibration the
// reading must equal the true field in the body frame up to those few µT, and uncorrected it must
// not (the hard iron alone is 2-15 µT).
TEST_F(SimulatedWarehouse, MagnetometersReadTheTrueFieldThroughTheirCalibration) {
  const Session& s = sessions_->front();
  ASSERT_EQ(s.rig.magnetometers_body.size(), 7u);
  EXPECT_NEAR(s.rig.magnetometers_body.front().y(), -1.5, 1e-12);
  EXPECT_NEAR(s.rig.magnetometers_body.back().y(), 1.5, 1e-12);
  ASSERT_TRUE(s.true_calibration.has_value());
  ASSERT_EQ(s.true_calibration->size(), 7u);
  ASSERT_FALSE(s.odometry.empty());
  int checked = 0;
  double corrected_error = 0.0, raw_error = 0.0;
  for (const MagnetometerSample& m : s.magnetometer) {
    const auto kf =
        std::find_if(s.ground_truth->begin(), s.ground_truth->end(),
                     [&](const StampedPose& p) { return std::abs(p.time_s - m.time_s) < 1e-9; });
    if (kf == s.ground_truth->end()) continue;
    const Eigen::Isometry3d& G = kf->T_frame_body;
    const Eigen::Vector3d truth_body =
        G.linear().transpose() * world_->field.fieldAt(G * s.rig.magnetometers_body[m.sensor]);
    const double speed = forwardSpeedAt(s.odometry, m.time_s);
    corrected_error +=
        ((*s.true_calibration)[m.sensor].correct(m.field_body_uT, speed) - truth_body).norm();
    raw_error += (m.field_body_uT - truth_body).norm();
    ++checked;
  }
  ASSERT_GT(checked, 50);
  EXPECT_LT(corrected_error / checked, 2.5);
  EXPECT_GT(corrected_error / checked, 0.2);  // noise and drift are there
  EXPECT_GT(raw_error / checked, 2.0 * corrected_error / checked);
}

TEST_F(SimulatedWarehouse, SensorBarNeverPassesThroughGeometry) {
  for (const Session& s : *sessions_)
    for (const StampedPose& g : *s.ground_truth)
      for (const Eigen::Vector3d& m : s.rig.magnetometers_body)
        EXPECT_GT(world_->raycaster.clearance((g.T_frame_body * m).head<2>(), 0.0, 1.0, 2.0), 0.1);
}

TEST(SimulatedLayouts, PaperWarehouseSetUpIsTwoTenthsOfAMetreAndHalfATurnApart) {
  const SimulationConfig config = quickConfig("warehouse");
  const SimulatedWorld world(config, 3);
  const auto routes = planSessionRoutes(world.world, config, 4, 3);
  ASSERT_EQ(routes.size(), 4u);
  for (int k = 1; k < 4; ++k) {
    const Eigen::Vector2d offset = routes[k].waypoints.front() - routes[k - 1].waypoints.front();
    EXPECT_NEAR(offset.norm(), 0.2, 1e-9);
    EXPECT_NEAR(std::abs(wrapAngle(routes[k].start_yaw_rad - routes[k - 1].start_yaw_rad)), M_PI,
                1e-9);
  }
}

TEST(SimulatedLayouts, PaperCorridorSetUpStartsAbout55MetresApartAndOverlaps) {
  SimulationConfig config;
  config.world = "corridor";
  const SimulatedWorld world(config, 3);
  const auto routes = planSessionRoutes(world.world, config, 3, 3);
  for (int k = 1; k < 3; ++k) {
    const Eigen::Vector2d offset = routes[k].waypoints.front() - routes[k - 1].waypoints.front();
    EXPECT_NEAR(offset.x(), 55.0, 2.0);
    EXPECT_NEAR(offset.y(), 0.0, 1e-9);
    // Consecutive windows share a stretch of corridor.
    double a_max = -1e9, b_min = 1e9;
    for (const auto& p : routes[k - 1].waypoints) a_max = std::max(a_max, p.x());
    for (const auto& p : routes[k].waypoints) b_min = std::min(b_min, p.x());
    EXPECT_GE(a_max - b_min, 5.0);
  }
}

double closestApproach(const Route& a, const Route& b) {
  const auto densify = [](const Route& r) {
    std::vector<Eigen::Vector2d> points;
    for (std::size_t i = 1; i < r.waypoints.size(); ++i)
      for (double s = 0; s < 1; s += 0.05)
        points.push_back((1 - s) * r.waypoints[i - 1] + s * r.waypoints[i]);
    return points;
  };
  double best = std::numeric_limits<double>::infinity();
  for (const auto& p : densify(a))
    for (const auto& q : densify(b)) best = std::min(best, (p - q).norm());
  return best;
}

TEST(SimulatedLayouts, DisjointSessionKeepsAwayFromAllOthers) {
  for (const std::string name : {"warehouse", "corridor"}) {
    SimulationConfig config = quickConfig(name);
    config.layout.disjoint_session = true;
    const SimulatedWorld world(config, 9);
    const auto routes = planSessionRoutes(world.world, config, 4, 9);
    for (int k = 0; k < 3; ++k) {
      // The 3 m sensor bars must not touch: more than 3 m plus a margin between centre lines.
      EXPECT_GT(closestApproach(routes[k], routes[3]), 5.0) << name << " session " << k;
      if (k > 0) {
        EXPECT_LT(closestApproach(routes[k], routes[k - 1]), 1.0) << name << " session " << k;
      }
    }
  }
}

TEST(SimulatedLayouts, RandomStartsHaveAnyYaw) {
  SimulationConfig config = quickConfig("warehouse");
  config.layout.mode = "random";
  const SimulatedWorld world(config, 4);
  const auto routes = planSessionRoutes(world.world, config, 6, 4);
  int off_axis = 0;
  for (const Route& r : routes) {
    const double quarter = std::remainder(r.start_yaw_rad, M_PI / 2);
    if (std::abs(quarter) > 0.05) ++off_axis;
  }
  EXPECT_GE(off_axis, 4);
}

TEST(Simulation, SameSeedSameSessionsOtherSeedOtherSessions) {
  SimulationConfig config = quickConfig("corridor");
  config.layout.window_length_m = 10.0;
  const auto a = simulateSessions(config, 2, 42);
  const auto b = simulateSessions(config, 2, 42);
  const auto c = simulateSessions(config, 2, 43);
  ASSERT_EQ(a.size(), 2u);
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].keyframes.size(), b[k].keyframes.size());
    for (std::size_t i = 0; i < a[k].keyframes.size(); ++i)
      EXPECT_TRUE(a[k].keyframes[i].T_frame_body.isApprox(b[k].keyframes[i].T_frame_body, 0.0));
    ASSERT_EQ(a[k].magnetometer.size(), b[k].magnetometer.size());
    for (std::size_t i = 0; i < a[k].magnetometer.size(); ++i)
      EXPECT_EQ(a[k].magnetometer[i].field_body_uT, b[k].magnetometer[i].field_body_uT);
    for (std::size_t i = 0; i < a[k].scans.size(); ++i) EXPECT_EQ(a[k].scans[i], b[k].scans[i]);
  }
  EXPECT_NE(a[0].magnetometer[0].field_body_uT, c[0].magnetometer[0].field_body_uT);
}

TEST(PlanarTrajectory, FollowsRouteAtConfiguredSpeedWithRoundedCorners) {
  Route route;
  route.waypoints = {{0, 0}, {10, 0}, {10, 10}};
  route.start_yaw_rad = M_PI;  // facing backwards: turns in place first
  MotionConfig motion;
  const PlanarTrajectory trajectory(route, motion);
  const double turn_time = M_PI / (motion.turn_rate_dps * M_PI / 180.0);
  const double arc = 0.5 * M_PI * motion.corner_radius_m;
  const double expected =
      turn_time + (20.0 - 2.0 * motion.corner_radius_m + arc) / motion.speed_mps;
  EXPECT_NEAR(trajectory.duration(), expected, 1e-9);
  EXPECT_NEAR(trajectory.at(0.0).yaw_rad, M_PI, 1e-9);
  EXPECT_NEAR(trajectory.at(turn_time).yaw_rad, 0.0, 1e-9);
  const PlanarState end = trajectory.at(trajectory.duration());
  EXPECT_TRUE(end.position.isApprox(Eigen::Vector2d(10, 10), 1e-9));
  EXPECT_NEAR(end.yaw_rad, M_PI / 2, 1e-9);
  // Mid-arc: 45 degrees through the corner, r (1 - cos 45°) inside it.
  const PlanarState mid =
      trajectory.at(turn_time + (10.0 - motion.corner_radius_m + 0.5 * arc) / motion.speed_mps);
  EXPECT_NEAR(mid.yaw_rad, M_PI / 4, 1e-9);
  const double r = motion.corner_radius_m;
  EXPECT_TRUE(mid.position.isApprox(
      Eigen::Vector2d(10 - r + r * std::sin(M_PI / 4), r - r * std::cos(M_PI / 4)), 1e-9));
}

}  // namespace
}  // namespace mm4mm::sim
