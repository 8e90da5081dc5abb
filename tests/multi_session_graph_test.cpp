#include "mm4mm/graph/multi_session_graph.hpp"

#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <functional>
#include <random>
#include <stdexcept>
#include <vector>

#include "graph/pose_graph_costs.hpp"
#include "mm4mm/core/pose.hpp"
#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/sim/odometry_drift.hpp"

namespace mm4mm {
namespace {

constexpr double kDeg = M_PI / 180.0;

// A field with structure along x and y (µT), heading-free: what a magnetometer reads levelled.
Eigen::Vector2d fieldAt(const Eigen::Vector2d& p) {
  return {20.0 + 6.0 * std::sin(0.9 * p.x()) + 3.0 * std::cos(0.7 * p.y() + 0.3 * p.x()),
          -40.0 + 5.0 * std::cos(0.6 * p.x() + 1.0) + 2.0 * std::sin(1.1 * p.y())};
}

// A session driving `true_poses` (world frame), odometry drifted with `seed`, with a rig of
// three magnetometers across the body reading fieldAt at 20 samples per metre.
Session makeSession(const std::string& id, const std::vector<Eigen::Isometry3d>& true_poses,
                    double drift_scale, std::uint64_t seed) {
  sim::OdometryConfig drift;
  drift.translation_noise_m_per_sqrt_m *= drift_scale;
  drift.yaw_noise_deg_per_sqrt_m *= drift_scale;
  drift.yaw_bias_deg_per_100m_max *= drift_scale;
  drift.scale_error_max *= drift_scale;
  const std::vector<Eigen::Isometry3d> odometry = sim::driftingOdometry(true_poses, drift, seed);
  Session session;
  session.id = id;
  session.rig.magnetometers_body = {{0, -0.5, 0.3}, {0, 0, 0.3}, {0, 0.5, 0.3}};
  std::vector<StampedPose> truth;
  for (std::size_t k = 0; k < true_poses.size(); ++k) {
    session.keyframes.push_back({static_cast<double>(k), odometry[k]});
    truth.push_back({static_cast<double>(k), true_poses[k]});
  }
  session.ground_truth = truth;
  for (std::size_t k = 0; k + 1 < true_poses.size(); ++k) {
    for (int step = 0; step < 20; ++step) {
      const double alpha = step / 20.0;
      const Eigen::Isometry3d body = interpolatePose(true_poses[k], true_poses[k + 1], alpha);
      for (int sensor = 0; sensor < 3; ++sensor) {
        const Eigen::Vector3d where = body * session.rig.magnetometers_body[sensor];
        const Eigen::Vector2d f = fieldAt(where.head<2>());
        // Levelled body frame = body frame here (no tilt): horizontal along body x.
        session.magnetometer.push_back({k + alpha, sensor, Eigen::Vector3d(f.x(), 0.0, f.y())});
      }
    }
  }
  return session;
}

std::vector<Eigen::Isometry3d> straightRoute(Eigen::Vector2d start, double yaw, int keyframes) {
  std::vector<Eigen::Isometry3d> poses;
  const Eigen::Vector2d direction(std::cos(yaw), std::sin(yaw));
  for (int k = 0; k < keyframes; ++k) {
    const Eigen::Vector2d p = start + direction * k;
    poses.push_back(planarPose(p.x(), p.y(), yaw));
  }
  return poses;
}

// A lap around a w x h rectangle starting at `corner`, one keyframe per metre.
std::vector<Eigen::Isometry3d> rectangleRoute(Eigen::Vector2d corner, double w, double h) {
  std::vector<Eigen::Isometry3d> poses;
  const double legs[4] = {w, h, w, h};
  Eigen::Vector2d p = corner;
  for (int leg = 0; leg < 4; ++leg) {
    const double yaw = leg * M_PI / 2;
    const Eigen::Vector2d direction(std::cos(yaw), std::sin(yaw));
    for (int k = 0; k < static_cast<int>(legs[leg]); ++k) {
      poses.push_back(planarPose(p.x(), p.y(), yaw));
      p += direction;
    }
  }
  return poses;
}

// Inter-session edges from ground truth between keyframes of a and b closer than 1 m.
std::vector<InterSessionEdge> trueEdges(const Session& a, int ia, const Session& b, int ib,
                                        double sigma_m, double sigma_deg, int every) {
  std::vector<InterSessionEdge> edges;
  const auto& ga = *a.ground_truth;
  const auto& gb = *b.ground_truth;
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
  information.topLeftCorner<3, 3>() *= 1.0 / (sigma_m * sigma_m);
  information.bottomRightCorner<3, 3>() *= 1.0 / std::pow(sigma_deg * kDeg, 2);
  int found = 0;
  for (std::size_t j = 0; j < gb.size(); ++j) {
    for (std::size_t i = 0; i < ga.size(); ++i) {
      if ((ga[i].T_frame_body.translation() - gb[j].T_frame_body.translation()).norm() > 1.0)
        continue;
      if (found++ % every == 0)
        edges.push_back({ia, static_cast<int>(i), ib, static_cast<int>(j),
                         ga[i].T_frame_body.inverse() * gb[j].T_frame_body, information});
      break;
    }
  }
  return edges;
}

TEST(PoseGraphCosts, RelativePoseCostPassesGradientChecker) {
  const Eigen::Isometry3d measured = poseFromRpy({1.0, -0.4, 0.2}, 0.05, -0.02, 0.7);
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity() * 4.0;
  information(0, 4) = information(4, 0) = 0.5;
  std::unique_ptr<ceres::CostFunction> cost(
      internal::RelativePoseCost::Create(measured, information));
  ceres::EigenQuaternionManifold quaternion;
  std::vector<const ceres::Manifold*> manifolds = {nullptr,     &quaternion, nullptr,
                                                   &quaternion, nullptr,     nullptr};
  ceres::GradientChecker checker(cost.get(), &manifolds, ceres::NumericDiffOptions());
  Eigen::Vector3d p_a(0.3, 0.1, -0.2), p_b(1.4, -0.1, 0.1);
  Eigen::Quaterniond q_a(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.1, 0.2, 1).normalized()));
  Eigen::Quaterniond q_b(Eigen::AngleAxisd(1.2, Eigen::Vector3d(-0.1, 0.1, 1).normalized()));
  const double* parameters[] = {p_a.data(), q_a.coeffs().data(), p_b.data(), q_b.coeffs().data()};
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters, 1e-7, &results)) << results.error_log;
}

TEST(PoseGraphCosts, RelativePoseCostIsZeroAtTheMeasurement) {
  const Eigen::Isometry3d T_a = poseFromRpy({2, 1, 0}, 0.1, 0.0, 0.3);
  const Eigen::Isometry3d T_a_b = poseFromRpy({1, 0.5, 0.1}, 0.0, 0.05, -0.8);
  const Eigen::Isometry3d T_b = T_a * T_a_b;
  const internal::RelativePoseCost cost(T_a_b, Eigen::Matrix<double, 6, 6>::Identity());
  Eigen::Vector3d p_a = T_a.translation(), p_b = T_b.translation();
  Eigen::Quaterniond q_a(T_a.linear()), q_b(T_b.linear());
  Eigen::Matrix<double, 6, 1> residual;
  cost(p_a.data(), q_a.coeffs().data(), p_b.data(), q_b.coeffs().data(), residual.data());
  EXPECT_LT(residual.norm(), 1e-12);
  p_b.x() += 0.1;  // 10 cm along the atlas x, which is a's body x rotated by 0.3 rad
  cost(p_a.data(), q_a.coeffs().data(), p_b.data(), q_b.coeffs().data(), residual.data());
  EXPECT_NEAR(residual.head<3>().norm(), 0.1, 1e-9);
}

TEST(PoseGraphCosts, MagneticMapCostPassesGradientChecker) {
  const Session session = makeSession("m", straightRoute({0, 0}, 0.0, 20), 0.0, 1);
  MagneticMap map = buildMagneticMap(placeFingerprints(session), session.rig, {});
  const auto interpolable = internal::makeInterpolable(downsample(map, 5));
  std::unique_ptr<ceres::CostFunction> cost(internal::MagneticMapCost::Create(
      *interpolable, {0.2, 0.1, 0.3}, planarPose(5.0, 0.0, 0.1), {21.0, -39.0}, 1.0));
  ceres::EigenQuaternionManifold quaternion;
  std::vector<const ceres::Manifold*> manifolds = {nullptr,     &quaternion, nullptr,
                                                   &quaternion, nullptr,     nullptr};
  // The checker differentiates numerically by Ridders' extrapolation, whose first step (1 % of
  // the parameter, here a third of a map cell) would straddle the spline's knots.
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-5;
  ceres::GradientChecker checker(cost.get(), &manifolds, numeric);
  Eigen::Vector3d p_s(7.13, 0.12, 0.0), p_t(6.0, -0.05, 0.0);
  Eigen::Quaterniond q_s(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()));
  Eigen::Quaterniond q_t(Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitZ()));
  const Eigen::Vector2d o_s(1.5, -12.0), o_t(-0.5, 3.0);
  const double* parameters[] = {p_s.data(),          q_s.coeffs().data(), p_t.data(),
                                q_t.coeffs().data(), o_s.data(),          o_t.data()};
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(parameters, 1e-6, &results)) << results.error_log;
}

TEST(PoseGraphCosts, InterpolableMapReproducesTheFieldInsideTheSwath) {
  const Session session = makeSession("m", straightRoute({0, 0}, 0.0, 20), 0.0, 1);
  const MagneticMap map = buildMagneticMap(placeFingerprints(session), session.rig, {});
  const auto interpolable = internal::makeInterpolable(downsample(map, 5));
  for (double x : {3.0, 7.3, 12.6}) {
    const double column = (x - interpolable->origin_m.x()) / interpolable->cell_size_m - 0.5;
    const double row = (0.1 - interpolable->origin_m.y()) / interpolable->cell_size_m - 0.5;
    double value[2];
    interpolable->interpolator->Evaluate(row, column, value);
    const Eigen::Vector2d truth = fieldAt({x, 0.1});
    EXPECT_NEAR(value[0], truth.x(), 0.3) << x;
    EXPECT_NEAR(value[1], truth.y(), 0.3) << x;
  }
}

struct ThreeSessions {
  std::vector<Session> sessions;
  std::vector<InterSessionEdge> edges;
  MultiSessionProblem problem;
};

constexpr double kLapDriftScale = 4.0;

// The noise model that matches kLapDriftScale times the simulator's default drift.
MultiSessionGraphConfig lapConfig() {
  MultiSessionGraphConfig config;
  config.use_magnetic_residuals = false;
  config.odometry_noise.translation_sigma_per_sqrt_m = 0.01 * kLapDriftScale;
  config.odometry_noise.rotation_sigma_per_sqrt_m_deg = 0.1 * kLapDriftScale;
  return config;
}

// Three laps of the same 40 m x 20 m rectangle from different corners, odometry drifting four
// times the simulator's default, edges from ground truth (exact values, 2 cm / 0.1° information).
ThreeSessions threeDriftingLaps() {
  ThreeSessions out;
  out.sessions.push_back(makeSession("s0", rectangleRoute({0, 0}, 40, 20), kLapDriftScale, 11));
  auto lap1 = rectangleRoute({0, 0}, 40, 20);
  std::rotate(lap1.begin(), lap1.begin() + 30, lap1.end());
  out.sessions.push_back(makeSession("s1", lap1, kLapDriftScale, 12));
  auto lap2 = rectangleRoute({0, 0}, 40, 20);
  std::rotate(lap2.begin(), lap2.begin() + 70, lap2.end());
  out.sessions.push_back(makeSession("s2", lap2, kLapDriftScale, 13));
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{0, 1}, {1, 2}, {0, 2}}) {
    const auto edges = trueEdges(out.sessions[a], a, out.sessions[b], b, 0.02, 0.1, 7);
    out.edges.insert(out.edges.end(), edges.begin(), edges.end());
  }
  for (const Session& s : out.sessions) out.problem.sessions.push_back(&s);
  // Initial frames: the true ones, then perturbed, as a pairwise match would leave them.
  for (int s = 0; s < 3; ++s)
    out.problem.T_atlas_session.push_back(
        trueRelativeTransform(out.sessions[0], out.sessions[s]) *
        (s == 0 ? Eigen::Isometry3d::Identity() : planarPose(0.3, -0.2, 1.0 * kDeg)));
  out.problem.connected = {true, true, true};
  out.problem.edges = out.edges;
  return out;
}

TEST(MultiSessionGraph, SolveWithDriftReducesTrajectoryError) {
  ThreeSessions laps = threeDriftingLaps();
  const MultiSessionSolution solution = solveMultiSessionGraph(laps.problem, lapConfig());
  const double odometry_ate = odometryTrajectoryError(laps.problem.sessions, {true, true, true});
  const double solved_ate =
      atlasTrajectoryError(laps.problem.sessions, solution.T_atlas_keyframe, {true, true, true});
  ASSERT_GT(odometry_ate, 0.15);  // the drift is there to correct
  EXPECT_LT(solved_ate, 0.5 * odometry_ate) << "odometry " << odometry_ate;
  EXPECT_TRUE(solution.converged);
  for (bool kept : solution.edge_kept) EXPECT_TRUE(kept);
  for (bool connected : solution.connected) EXPECT_TRUE(connected);
  // The gauge: session 0's first keyframe stays where its odometry put it.
  EXPECT_TRUE(
      solution.T_atlas_keyframe[0][0].isApprox(laps.sessions[0].keyframes[0].T_frame_body, 1e-9));
}

TEST(MultiSessionGraph, DropsAnInconsistentEdgeInsteadOfAveragingIt) {
  ThreeSessions laps = threeDriftingLaps();
  InterSessionEdge wrong = laps.problem.edges.front();
  wrong.T_a_b = wrong.T_a_b * planarPose(8.0, 0.0, 0.0);  // an aisle further along
  laps.problem.edges.push_back(wrong);
  const MultiSessionSolution solution = solveMultiSessionGraph(laps.problem, lapConfig());
  EXPECT_FALSE(solution.edge_kept.back());
  int dropped = 0;
  for (bool kept : solution.edge_kept) dropped += kept ? 0 : 1;
  EXPECT_EQ(dropped, 1);
  const double odometry_ate = odometryTrajectoryError(laps.problem.sessions, {true, true, true});
  EXPECT_LT(
      atlasTrajectoryError(laps.problem.sessions, solution.T_atlas_keyframe, {true, true, true}),
      0.5 * odometry_ate);
}

TEST(MultiSessionGraph, SessionWithoutEdgesStaysUnconnected) {
  ThreeSessions laps = threeDriftingLaps();
  std::vector<InterSessionEdge> kept;
  for (const auto& e : laps.problem.edges)
    if (e.session_a != 2 && e.session_b != 2) kept.push_back(e);
  laps.problem.edges = kept;
  const MultiSessionSolution solution = solveMultiSessionGraph(laps.problem, lapConfig());
  EXPECT_TRUE(solution.connected[0]);
  EXPECT_TRUE(solution.connected[1]);
  EXPECT_FALSE(solution.connected[2]);
  EXPECT_TRUE(solution.T_atlas_session[2].isApprox(Eigen::Isometry3d::Identity()));
}

// Along a featureless corridor the geometric edges say nothing about the position along the
// axis; the magnetic residuals do.
TEST(MultiSessionGraph, MagneticResidualsFixTheAlongCorridorOffset) {
  const std::vector<Session> sessions = {
      makeSession("a", straightRoute({0, 0}, 0.0, 40), 0.0, 21),
      makeSession("b", straightRoute({5, 0.3}, 0.0, 40), 0.0, 22)};
  MultiSessionProblem problem;
  for (const Session& s : sessions) problem.sessions.push_back(&s);
  const Eigen::Isometry3d truth = trueRelativeTransform(sessions[0], sessions[1]);
  problem.T_atlas_session = {Eigen::Isometry3d::Identity(), truth * planarPose(1.2, 0.0, 0.0)};
  problem.connected = {true, true};
  // Degenerate corridor edges: tight across the corridor and in rotation, nothing along x, and
  // measured where the wrong seed put them (1.2 m off along the axis).
  for (int j = 5; j < 30; j += 5) {
    InterSessionEdge edge;
    edge.session_a = 0;
    edge.keyframe_a = j + 5;
    edge.session_b = 1;
    edge.keyframe_b = j;
    edge.T_a_b = planarPose(-0.0 + 1.2, 0.3, 0.0);
    edge.information = Eigen::Matrix<double, 6, 6>::Identity() * 1e4;
    edge.information(0, 0) = 1e-6;
    problem.edges.push_back(edge);
  }
  std::vector<MagneticMap> maps;
  for (const Session& s : sessions)
    maps.push_back(buildMagneticMap(placeFingerprints(s), s.rig, {}));
  problem.magnetic_maps = {&maps[0], &maps[1]};

  MultiSessionGraphConfig config;
  config.use_magnetic_residuals = false;
  const MultiSessionSolution geometric = solveMultiSessionGraph(problem, config);
  config.use_magnetic_residuals = true;
  const MultiSessionSolution magnetic = solveMultiSessionGraph(problem, config);
  const auto alongAxisError = [&](const MultiSessionSolution& solution) {
    return std::abs((solution.T_atlas_session[1] * truth.inverse()).translation().x());
  };
  EXPECT_GT(alongAxisError(geometric), 1.0);
  EXPECT_LT(alongAxisError(magnetic), 0.1);
  EXPECT_GT(magnetic.magnetic_residuals, 100);
}

// Two sessions along one corridor, b beside a, joined by one edge (the true relative pose of a's
// keyframe 15 and b's 10), with each session's magnetic map; `change_b` alters b first.
struct TwoCorridorSessions {
  std::vector<Session> sessions;
  std::vector<MagneticMap> maps;
  MultiSessionProblem problem;
  explicit TwoCorridorSessions(const std::function<void(Session*)>& change_b) {
    sessions = {makeSession("a", straightRoute({0, 0}, 0.0, 40), 0.0, 21),
                makeSession("b", straightRoute({5, 0.3}, 0.0, 40), 0.0, 22)};
    change_b(&sessions[1]);
    for (const Session& s : sessions) {
      problem.sessions.push_back(&s);
      maps.push_back(buildMagneticMap(placeFingerprints(s), s.rig, {}));
    }
    problem.T_atlas_session = {Eigen::Isometry3d::Identity(),
                               trueRelativeTransform(sessions[0], sessions[1])};
    problem.connected = {true, true};
    InterSessionEdge edge;
    edge.session_a = 0;
    edge.keyframe_a = 15;
    edge.session_b = 1;
    edge.keyframe_b = 10;
    edge.T_a_b = planarPose(0.0, 0.3, 0.0);
    edge.information = Eigen::Matrix<double, 6, 6>::Identity() * 1e4;
    problem.edges.push_back(edge);
    problem.magnetic_maps = {&maps[0], &maps[1]};
  }
};

// b's magnetometers 0.8 m higher: b reads another field, so no reading is compared with a map
// made at the other height.
TEST(MultiSessionGraph, ReadingsAreNotComparedWithAMapAtAnotherHeight) {
  TwoCorridorSessions two([](Session* b) {
    for (Eigen::Vector3d& sensor : b->rig.magnetometers_body) sensor.z() += 0.8;
  });
  ASSERT_NEAR(two.maps[1].height_m - two.maps[0].height_m, 0.8, 1e-6);
  MultiSessionProblem& problem = two.problem;
  MultiSessionGraphConfig config;
  config.use_magnetic_residuals = true;
  EXPECT_GT(solveMultiSessionGraph(problem, config).magnetic_residuals, 100);  // no limit
  problem.max_height_difference_m = 0.2;
  EXPECT_EQ(solveMultiSessionGraph(problem, config).magnetic_residuals, 0);
  problem.max_height_difference_m = 1.0;
  EXPECT_GT(solveMultiSessionGraph(problem, config).magnetic_residuals, 100);
}

// b's odometry climbs 0.8 m along the corridor that it drove on the level: its frame's z says
// nothing about the height its magnetometers read at. Where both sessions' heights above the floor
// are known, they decide, and the drift drops no reading; where they are not, the z rule drops
// the readings the drift moved off the map's height.
TEST(MultiSessionGraph, HeightsAboveTheFloorDecideWhereAnOdometryDriftsInHeight) {
  TwoCorridorSessions two([](Session* b) {
    for (std::size_t k = 0; k < b->keyframes.size(); ++k)
      b->keyframes[k].T_frame_body.translation().z() += 0.02 * static_cast<double>(k);
  });
  MultiSessionProblem& problem = two.problem;
  MultiSessionGraphConfig config;
  config.use_magnetic_residuals = true;
  const int unlimited = solveMultiSessionGraph(problem, config).magnetic_residuals;
  ASSERT_GT(unlimited, 100);
  problem.max_height_difference_m = 0.2;
  const int by_z = solveMultiSessionGraph(problem, config).magnetic_residuals;
  EXPECT_LT(by_z, unlimited * 3 / 4) << "the drift dropped too few readings for this test";
  problem.heights_above_floor_m = {0.3, 0.3};
  EXPECT_EQ(solveMultiSessionGraph(problem, config).magnetic_residuals, unlimited);
  problem.heights_above_floor_m = {0.3, 1.1};
  EXPECT_EQ(solveMultiSessionGraph(problem, config).magnetic_residuals, 0);
  problem.heights_above_floor_m = {0.3, std::nullopt};  // one unknown: the z rule
  EXPECT_EQ(solveMultiSessionGraph(problem, config).magnetic_residuals, by_z);
  problem.heights_above_floor_m = {0.3};
  EXPECT_THROW(solveMultiSessionGraph(problem, config), std::invalid_argument);
}

TEST(MultiSessionGraph, RejectsEdgesToMissingKeyframes) {
  ThreeSessions laps = threeDriftingLaps();
  laps.problem.edges.front().keyframe_b = 100000;
  try {
    solveMultiSessionGraph(laps.problem);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("keyframe 100000"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mm4mm
