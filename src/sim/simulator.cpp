#include "mm4mm/sim/simulator.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <utility>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/sim/lidar.hpp"
#include "mm4mm/sim/magnetometer_model.hpp"
#include "mm4mm/sim/odometry_drift.hpp"
#include "mm4mm/sim/trajectory.hpp"
#include "mm4mm/sim/world_change.hpp"
#include "random_draws.hpp"

namespace mm4mm::sim {

std::uint64_t deriveSeed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t z = seed + 0x9e3779b97f4a7c15ULL * (stream + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

namespace {

enum SeedStream : std::uint64_t { kWorld = 1, kBackground = 2, kRoutes = 3, kSessions = 100 };

// Sessions share the world but, with a disjoint session, not all of it: shared sessions keep to
// the low end of one axis, the disjoint one to the high end, with two lane spacings between.
struct RegionMasks {
  NodeMask shared;
  NodeMask disjoint;
};

RegionMasks regionMasks(const World& world, bool with_disjoint) {
  const auto& nodes = world.lanes.nodes;
  RegionMasks masks{NodeMask(nodes.size(), true), NodeMask(nodes.size(), false)};
  if (!with_disjoint) return masks;
  const int axis = world.split_axis;
  std::set<long> keys;
  for (const auto& n : nodes) keys.insert(std::lround(n[axis] * 100.0));
  const std::vector<long> levels(keys.begin(), keys.end());
  const int n = static_cast<int>(levels.size());
  const int disjoint_levels = std::max(2, n / 5);
  if (n < disjoint_levels + 4)
    throw std::invalid_argument("world too small for a disjoint session");
  const long disjoint_min = levels[n - disjoint_levels];
  // Two levels apart, and at least kMinGap_cm: lanes of a procedural building can lie closer
  // than a rig's footprint (a door beside a corridor node).
  constexpr long kMinGap_cm = 500;
  long shared_max = levels[n - disjoint_levels - 2];
  while (disjoint_min - shared_max < kMinGap_cm) {
    const auto below = std::lower_bound(levels.begin(), levels.end(), shared_max);
    if (below == levels.begin())
      throw std::invalid_argument("world too small for a disjoint session");
    shared_max = *std::prev(below);
  }
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const long key = std::lround(nodes[i][axis] * 100.0);
    masks.shared[i] = key <= shared_max;
    masks.disjoint[i] = key >= disjoint_min;
  }
  return masks;
}

// The allowed node nearest the centre of the allowed region that has lanes in both x directions.
int centralCrossing(const World& world, const NodeMask& allowed) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  int count = 0;
  for (std::size_t i = 0; i < allowed.size(); ++i)
    if (allowed[i]) centre += world.lanes.nodes[i], ++count;
  centre /= std::max(count, 1);
  int best = -1;
  for (std::size_t i = 0; i < allowed.size(); ++i) {
    if (!allowed[i]) continue;
    int along_x = 0;
    for (int n : world.lanes.neighbours[i])
      if (allowed[n] && std::abs(world.lanes.nodes[n].y() - world.lanes.nodes[i].y()) < 1e-6)
        ++along_x;
    if (along_x < 2) continue;
    if (best < 0 ||
        (world.lanes.nodes[i] - centre).norm() < (world.lanes.nodes[best] - centre).norm())
      best = static_cast<int>(i);
  }
  if (best < 0) throw std::invalid_argument("no lane crossing to start the sessions from");
  return best;
}

std::vector<double> sortedLaneXs(const World& world, const NodeMask& allowed) {
  std::set<long> keys;
  for (std::size_t i = 0; i < allowed.size(); ++i)
    if (allowed[i]) keys.insert(std::lround(world.lanes.nodes[i].x() * 100.0));
  std::vector<double> xs;
  for (long k : keys) xs.push_back(k / 100.0);
  return xs;
}

std::vector<Route> sweepWindows(const World& world, const SimulationConfig& config, int count,
                                const NodeMask& allowed) {
  const std::vector<double> xs = sortedLaneXs(world, allowed);
  const double pitch = xs.size() > 1 ? xs[1] - xs[0] : 1.0;
  const int last = static_cast<int>(xs.size()) - 1;
  const int window =
      std::max(1, static_cast<int>(std::lround(config.layout.window_length_m / pitch)));
  int spacing = std::max(1, static_cast<int>(std::lround(config.layout.window_spacing_m / pitch)));
  // Keep the configured spacing (the paper's set-up) and shorten the last window at the end of
  // the corridor; squeeze the starts together only when they would not fit at all.
  if (count > 1 && (count - 1) * spacing > last - 2)
    spacing = std::max(1, (last - 2) / (count - 1));
  std::vector<Route> routes;
  for (int k = 0; k < count; ++k) {
    const int first = std::min(k * spacing, last - 1);
    routes.push_back(
        sweepRoute(world.lanes, xs[first], xs[std::min(first + window, last)], allowed));
  }
  return routes;
}

}  // namespace

SimulatedWorld::SimulatedWorld(const SimulationConfig& config, std::uint64_t seed)
    : SimulatedWorld(buildWorld(config, deriveSeed(seed, kWorld)), config, seed) {}

SimulatedWorld::SimulatedWorld(World world_in, const SimulationConfig& config, std::uint64_t seed)
    : world(std::move(world_in)),
      field(config.earth, config.background, world.dipoles, config.steel.cutoff_radius_m,
            world.charges, config.floor_mesh.cutoff_radius_m, deriveSeed(seed, kBackground)),
      raycaster(world) {}

ChangingWorld::ChangingWorld(const SimulationConfig& config, std::uint64_t seed)
    : first_session_(config.change.first_session),
      whole_(std::make_unique<SimulatedWorld>(config, seed)) {
  if (config.change.first_session <= 0) return;
  before_ = std::make_unique<SimulatedWorld>(changedWorld(whole_->world, config.change, false),
                                             config, seed);
  after_ = std::make_unique<SimulatedWorld>(changedWorld(whole_->world, config.change, true),
                                            config, seed);
}

SensorRig simulatedRig(const RigConfig& config) {
  SensorRig rig;
  const double centre = 0.5 * (config.magnetometer_count - 1);
  for (int k = 0; k < config.magnetometer_count; ++k)
    rig.magnetometers_body.emplace_back(0.0, (k - centre) * config.magnetometer_spacing_m,
                                        config.magnetometer_height_m);
  rig.T_body_lidar.translation() = Eigen::Vector3d(0.0, 0.0, config.lidar_height_m);
  return rig;
}

std::vector<Route> planSessionRoutes(const World& world, const SimulationConfig& config, int count,
                                     std::uint64_t seed) {
  const bool disjoint = config.layout.disjoint_session;
  if (count < 1 || (disjoint && count < 2))
    throw std::invalid_argument(disjoint ? "a disjoint session needs at least 2 sessions"
                                         : "need at least 1 session");
  const RegionMasks masks = regionMasks(world, disjoint);
  const int shared_count = disjoint ? count - 1 : count;
  std::mt19937_64 rng(deriveSeed(seed, kRoutes));
  const std::string mode = config.layoutMode();
  const double length = config.layout.route_length_m;

  std::vector<Route> routes;
  if (mode == "windows") {
    routes = sweepWindows(world, config, shared_count, masks.shared);
  } else if (mode == "common_start") {
    const int start = centralCrossing(world, masks.shared);
    for (int k = 0; k < shared_count; ++k) {
      const Eigen::Vector2d position =
          world.lanes.nodes[start] + Eigen::Vector2d(k * config.layout.start_offset_x_m, 0.0);
      const double yaw = wrapAngle(k * config.layout.start_yaw_step_deg * M_PI / 180.0);
      routes.push_back(
          randomWalkRoute(world.lanes, start, position, yaw, length, masks.shared, &rng));
    }
  } else {
    std::vector<int> candidates;
    for (std::size_t i = 0; i < masks.shared.size(); ++i)
      if (masks.shared[i]) candidates.push_back(static_cast<int>(i));
    std::uniform_int_distribution<std::size_t> pick(0, candidates.size() - 1);
    std::uniform_real_distribution<double> any_yaw(-M_PI, M_PI);
    for (int k = 0; k < shared_count; ++k) {
      const int start = candidates[pick(rng)];
      routes.push_back(randomWalkRoute(world.lanes, start, world.lanes.nodes[start], any_yaw(rng),
                                       length, masks.shared, &rng));
    }
  }
  if (disjoint) {
    if (mode == "windows") {
      const std::vector<double> xs = sortedLaneXs(world, masks.disjoint);
      routes.push_back(sweepRoute(world.lanes, xs.front(), xs.back(), masks.disjoint));
    } else {
      int start = -1;
      for (std::size_t i = 0; i < masks.disjoint.size() && start < 0; ++i)
        if (masks.disjoint[i]) start = static_cast<int>(i);
      std::uniform_real_distribution<double> any_yaw(-M_PI, M_PI);
      routes.push_back(randomWalkRoute(world.lanes, start, world.lanes.nodes[start], any_yaw(rng),
                                       0.5 * length, masks.disjoint, &rng));
    }
  }
  return routes;
}

Session simulateSession(const SimulatedWorld& simulated, const Route& route,
                        const SimulationConfig& config, const std::string& id, std::uint64_t seed) {
  const PlanarTrajectory trajectory(route, config.motion);
  const TiltJitter tilt(config.motion.tilt_amplitude_deg * M_PI / 180.0, deriveSeed(seed, 1));
  const MotionConfig& motion = config.motion;
  // A walker sways sideways once per two steps and bobs once per step.
  std::mt19937_64 sway_rng(deriveSeed(seed, 4));
  const double sway_phase = std::uniform_real_distribution<double>(0.0, 2.0 * M_PI)(sway_rng);
  const auto true_pose = [&](double t) {
    const PlanarState s = trajectory.at(t);
    const Eigen::Vector2d rp = tilt.rollPitchAt(t);
    const double w = 2.0 * M_PI * motion.step_frequency_hz * t + sway_phase;
    const Eigen::Vector2d lateral(-std::sin(s.yaw_rad), std::cos(s.yaw_rad));
    const Eigen::Vector2d xy = s.position + motion.sway_lateral_m * std::sin(0.5 * w) * lateral;
    return poseFromRpy(Eigen::Vector3d(xy.x(), xy.y(), motion.sway_vertical_m * std::sin(w)),
                       rp.x(), rp.y(), s.yaw_rad);
  };
  // Forward speed and acceleration as the drive sees them: differences over half a second (the
  // trajectory changes speed at once; a real drive ramps over about that long).
  const auto speed_at = [&](double t) {
    constexpr double kHalf = 0.25;
    const double t0 = std::max(0.0, t - kHalf), t1 = std::min(trajectory.duration(), t + kHalf);
    return t1 > t0 ? (trajectory.at(t1).distance_m - trajectory.at(t0).distance_m) / (t1 - t0)
                   : 0.0;
  };
  const auto acceleration_at = [&](double t) {
    constexpr double kHalf = 0.25;
    return (speed_at(t + kHalf) - speed_at(t - kHalf)) / (2.0 * kHalf);
  };

  // The odometry's pose stream, and keyframes on it like a LiDAR odometry takes them: after a
  // distance or a turn since the last one.
  const double pose_period = 1.0 / config.odometry.pose_rate_hz;
  const std::size_t pose_count =
      static_cast<std::size_t>(std::floor(trajectory.duration() / pose_period)) + 1;
  std::vector<double> pose_times(pose_count);
  for (std::size_t j = 0; j < pose_count; ++j) pose_times[j] = j * pose_period;
  std::vector<std::size_t> keyframe_index{0};
  {
    PlanarState last = trajectory.at(0.0);
    const double keyframe_angle = motion.keyframe_angle_deg * M_PI / 180.0;
    for (std::size_t j = 1; j < pose_count; ++j) {
      const PlanarState s = trajectory.at(pose_times[j]);
      if (s.distance_m - last.distance_m >= motion.keyframe_distance_m ||
          std::abs(wrapAngle(s.yaw_rad - last.yaw_rad)) >= keyframe_angle) {
        keyframe_index.push_back(j);
        last = s;
      }
    }
  }

  Session session;
  session.id = id;
  session.rig = simulatedRig(config.rig);
  // What a user gives from a geomagnetic model for the site: the main field the simulator adds.
  session.rig.earth_field_horizontal_uT =
      config.earth.magnitude_uT * std::cos(config.earth.inclination_deg * M_PI / 180.0);
  session.rig.earth_field_vertical_uT =
      config.earth.magnitude_uT * sim::earthFieldDirection(config.earth).z();
  // The session frame is the odometry's, which starts where the body stands: on the floor.
  session.rig.frame_height_above_floor_m = 0.0;
  std::vector<Eigen::Isometry3d> truth(pose_count);
  std::vector<std::optional<Eigen::Vector2d>> degenerate(pose_count);
  tbb::parallel_for(std::size_t{0}, pose_count, [&](std::size_t j) {
    truth[j] = true_pose(pose_times[j]);
    degenerate[j] = simulated.world.degenerateAxisAt(truth[j].translation().head<2>());
  });
  const std::vector<Eigen::Isometry3d> odometry =
      driftingOdometry(truth, config.odometry, deriveSeed(seed, 2), pose_times, degenerate);
  std::vector<StampedPose> ground_truth;
  for (std::size_t j = 0; j < pose_count; ++j)
    session.odometry.push_back({pose_times[j], odometry[j]});
  for (std::size_t j : keyframe_index) {
    session.keyframes.push_back({pose_times[j], odometry[j]});
    ground_truth.push_back({pose_times[j], truth[j]});
  }
  session.ground_truth = std::move(ground_truth);

  // Magnetometers: each sensor's errors drawn first, in sensor order; the field is evaluated in
  // parallel; the noise and drift are drawn in sample order afterwards, so the result does not
  // depend on the number of threads.
  std::mt19937_64 rng(deriveSeed(seed, 3));
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<SimulatedMagnetometer> sensors_model;
  std::vector<MagnetometerCalibration> truths;
  for (std::size_t k = 0; k < session.rig.magnetometers_body.size(); ++k) {
    sensors_model.push_back(drawMagnetometer(config.magnetometer_errors, config.rig, &rng));
    truths.push_back(sensors_model.back().trueCalibration());
  }
  session.true_calibration = std::move(truths);
  const double period = 1.0 / config.rig.magnetometer_rate_hz;
  const double last_time = session.keyframes.back().time_s;
  const std::size_t sample_times = static_cast<std::size_t>(std::floor(last_time / period)) + 1;
  const std::size_t sensors = sensors_model.size();
  session.magnetometer.resize(sample_times * sensors);
  tbb::parallel_for(std::size_t{0}, sample_times, [&](std::size_t j) {
    const double t = j * period;
    const Eigen::Isometry3d pose = true_pose(t);
    const double speed = speed_at(t), acceleration = acceleration_at(t);
    for (std::size_t k = 0; k < sensors; ++k) {
      const Eigen::Vector3d field_body =
          pose.linear().transpose() *
          simulated.field.fieldAt(pose * session.rig.magnetometers_body[k]);
      session.magnetometer[j * sensors + k] = {
          t, static_cast<int>(k), sensors_model[k].read(field_body, speed, acceleration)};
    }
  });
  std::vector<Eigen::Vector3d> drift(sensors, Eigen::Vector3d::Zero());
  const bool drifts = config.magnetometer_errors.model != "clean";
  for (std::size_t j = 0; j < sample_times; ++j)
    for (std::size_t k = 0; k < sensors; ++k) {
      const SimulatedMagnetometer& m = sensors_model[k];
      MagnetometerSample& sample = session.magnetometer[j * sensors + k];
      if (drifts && j > 0) {
        const double decay = std::exp(-period / m.drift_time_constant_s);
        drift[k] = decay * drift[k] +
                   m.drift_uT * std::sqrt(1.0 - decay * decay) * drawVector3(gauss, rng);
      }
      sample.field_body_uT += drift[k] + m.noise_uT * drawVector3(gauss, rng);
    }

  // Scans, in parallel; each keyframe's noise comes from its own seeded stream, so the result
  // does not depend on the number of threads.
  if (!config.lidar.enabled) return session;
  const std::vector<Eigen::Vector3d> beams = lidarBeamDirections(config.lidar);
  session.scans.resize(keyframe_index.size());
  tbb::parallel_for(std::size_t{0}, keyframe_index.size(), [&](std::size_t i) {
    std::mt19937_64 scan_rng(deriveSeed(seed, 1000 + i));
    const Eigen::Isometry3d T_world_lidar = truth[keyframe_index[i]] * session.rig.T_body_lidar;
    PointCloud points =
        simulateScan(simulated.raycaster, T_world_lidar, beams, config.lidar, &scan_rng);
    const Eigen::Isometry3f T_body_lidar = session.rig.T_body_lidar.cast<float>();
    for (auto& p : points) p = T_body_lidar * p;
    session.scans[i] = std::move(points);
  });
  return session;
}

std::vector<Session> simulateSessions(const SimulationConfig& config, int count, std::uint64_t seed,
                                      const ProgressCallback& progress) {
  const ChangingWorld worlds(config, seed);
  const std::vector<Route> routes = planSessionRoutes(worlds.whole().world, config, count, seed);
  std::vector<Session> sessions;
  for (int k = 0; k < count; ++k) {
    const std::string id = "s" + std::to_string(k);
    sessions.push_back(simulateSession(worlds.forSession(k), routes[k], config, id,
                                       deriveSeed(seed, kSessions + k)));
    if (progress)
      progress(id + ": " + std::to_string(sessions.back().keyframes.size()) + " keyframes, " +
               std::to_string(static_cast<int>(routes[k].length())) + " m");
  }
  return sessions;
}

}  // namespace mm4mm::sim
