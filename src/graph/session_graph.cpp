#include "mm4mm/graph/session_graph.hpp"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>

#include "mm4mm/core/pose.hpp"
#include "mm4mm/core/trajectory.hpp"

namespace mm4mm {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

void checkSession(const Session& session, const std::vector<StampedPose>& kf) {
  for (std::size_t i = 1; i < kf.size(); ++i) {
    if (!(kf[i].time_s > kf[i - 1].time_s))
      throw std::invalid_argument("buildSessionGraph: keyframe " + std::to_string(i) +
                                  " is not after the previous one");
  }
  const auto& mag = session.magnetometer;
  const int sensors = static_cast<int>(session.rig.magnetometers_body.size());
  for (std::size_t i = 0; i < mag.size(); ++i) {
    if (mag[i].sensor < 0 || mag[i].sensor >= sensors)
      throw std::invalid_argument("buildSessionGraph: magnetometer sample " + std::to_string(i) +
                                  " names sensor " + std::to_string(mag[i].sensor) +
                                  ", the rig has " + std::to_string(sensors));
    if (i > 0 && mag[i].time_s < mag[i - 1].time_s)
      throw std::invalid_argument("buildSessionGraph: magnetometer samples are not sorted by time");
  }
}

// One magnetic node per distinct sample time inside [first keyframe, last keyframe]; ids are
// assigned later, once the nodes are merged with the scan nodes.
std::vector<MagneticNode> magneticNodes(const Session& session,
                                        const std::vector<StampedPose>& kf) {
  // Reserved exactly: a high-rate log has millions of nodes, and a vector grown by doubling
  // holds the old and the new copy at once.
  std::size_t count = 0;
  const MagnetometerSample* previous = nullptr;
  for (const MagnetometerSample& sample : session.magnetometer) {
    if (sample.time_s < kf.front().time_s || sample.time_s > kf.back().time_s) continue;
    count += previous == nullptr || previous->time_s != sample.time_s;
    previous = &sample;
  }
  std::vector<MagneticNode> nodes;
  nodes.reserve(count);
  const std::size_t sensors = session.rig.magnetometers_body.size();
  for (const MagnetometerSample& sample : session.magnetometer) {
    if (sample.time_s < kf.front().time_s || sample.time_s > kf.back().time_s) continue;
    if (nodes.empty() || nodes.back().time_s != sample.time_s) {
      MagneticNode node;
      node.time_s = sample.time_s;
      node.T_session_body = poseAt(kf, sample.time_s);
      node.readings_body_uT.assign(sensors, Eigen::Vector3d::Zero());
      node.has_reading.assign(sensors, false);
      nodes.push_back(std::move(node));
    }
    nodes.back().readings_body_uT[sample.sensor] = sample.field_body_uT;
    nodes.back().has_reading[sample.sensor] = true;
  }
  return nodes;
}

// The graph of `session` with `kf` for its keyframes (the session's own, or placed elsewhere).
SessionGraph buildGraph(const Session& session, const std::vector<StampedPose>& kf,
                        const SessionGraphConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("buildSessionGraph: " + error);
  checkSession(session, kf);

  SessionGraph graph;
  graph.session_id = session.id;
  graph.noise = config;
  if (kf.empty()) return graph;

  for (std::size_t k = 0; k < kf.size(); ++k) {
    ScanNode node;
    node.time_s = kf[k].time_s;
    node.T_session_body = kf[k].T_frame_body;
    node.keyframe = static_cast<int>(k);
    graph.scans.push_back(node);
  }
  graph.magnetic = magneticNodes(session, kf);
  graph.odometry.reserve(graph.scans.size() + graph.magnetic.size() - 1);

  // Merge both kinds by time (scan first on a tie), numbering the nodes in that order, and chain
  // consecutive ones with an odometry edge.
  std::size_t next_scan = 0;
  std::size_t next_mag = 0;
  int id = 0;
  const Eigen::Isometry3d* previous_pose = nullptr;
  const auto visit = [&](int* node_id, const Eigen::Isometry3d& pose) {
    *node_id = id;
    if (previous_pose) {
      OdometryEdge edge;
      edge.from = id - 1;
      edge.to = id;
      edge.T_from_to = previous_pose->inverse(Eigen::Isometry) * pose;
      edge.information = odometryInformation(edge.T_from_to.translation().norm(),
                                             rotationAngle(edge.T_from_to.linear()), config);
      graph.odometry.push_back(edge);
    }
    previous_pose = &pose;
    ++id;
  };
  while (next_scan < graph.scans.size() || next_mag < graph.magnetic.size()) {
    const bool take_scan = next_mag == graph.magnetic.size() ||
                           (next_scan < graph.scans.size() &&
                            graph.scans[next_scan].time_s <= graph.magnetic[next_mag].time_s);
    if (take_scan) {
      ScanNode& node = graph.scans[next_scan++];
      visit(&node.id, node.T_session_body);
    } else {
      MagneticNode& node = graph.magnetic[next_mag++];
      visit(&node.id, node.T_session_body);
    }
  }
  return graph;
}

}  // namespace

bool SessionGraphConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* message) {
    if (error) *error = message;
    return false;
  };
  if (!(translation_sigma_per_sqrt_m >= 0.0))
    return fail("translation_sigma_per_sqrt_m must be >= 0");
  if (!(translation_sigma_floor_m > 0.0)) return fail("translation_sigma_floor_m must be > 0");
  if (!(rotation_sigma_per_sqrt_m_deg >= 0.0))
    return fail("rotation_sigma_per_sqrt_m_deg must be >= 0");
  if (!(rotation_sigma_per_sqrt_rad_deg >= 0.0))
    return fail("rotation_sigma_per_sqrt_rad_deg must be >= 0");
  if (!(rotation_sigma_floor_deg > 0.0)) return fail("rotation_sigma_floor_deg must be > 0");
  const double all[] = {translation_sigma_per_sqrt_m, translation_sigma_floor_m,
                        rotation_sigma_per_sqrt_m_deg, rotation_sigma_per_sqrt_rad_deg,
                        rotation_sigma_floor_deg};
  for (double value : all) {
    if (!std::isfinite(value))
      return fail("translation_sigma_* and rotation_sigma_* must be finite");
  }
  return true;
}

Eigen::Matrix<double, 6, 6> odometryInformation(double distance_m, double turned_rad,
                                                const SessionGraphConfig& config) {
  // Variances of independent drift increments add, so each term is a variance linear in the
  // distance or angle (a random walk), and the floor is added in quadrature.
  const double d = std::max(distance_m, 0.0);
  const double theta = std::max(turned_rad, 0.0);
  const double k_t = config.translation_sigma_per_sqrt_m;
  const double f_t = config.translation_sigma_floor_m;
  const double k_rm = config.rotation_sigma_per_sqrt_m_deg * kDegToRad;
  const double k_ra = config.rotation_sigma_per_sqrt_rad_deg * kDegToRad;
  const double f_r = config.rotation_sigma_floor_deg * kDegToRad;
  const double var_t = k_t * k_t * d + f_t * f_t;
  const double var_r = k_rm * k_rm * d + k_ra * k_ra * theta + f_r * f_r;
  Eigen::Matrix<double, 6, 1> diagonal;
  diagonal << Eigen::Vector3d::Constant(1.0 / var_t), Eigen::Vector3d::Constant(1.0 / var_r);
  return diagonal.asDiagonal();
}

SessionGraph buildSessionGraph(const Session& session, const SessionGraphConfig& config) {
  return buildGraph(session, session.keyframes, config);
}

SessionGraph buildSessionGraphAt(const Session& session,
                                 const std::vector<Eigen::Isometry3d>& T_frame_keyframe,
                                 const SessionGraphConfig& config) {
  if (T_frame_keyframe.size() != session.keyframes.size())
    throw std::invalid_argument("buildSessionGraphAt: " + std::to_string(T_frame_keyframe.size()) +
                                " poses for the " + std::to_string(session.keyframes.size()) +
                                " keyframes of session " + session.id);
  std::vector<StampedPose> placed = session.keyframes;
  for (std::size_t k = 0; k < placed.size(); ++k) placed[k].T_frame_body = T_frame_keyframe[k];
  return buildGraph(session, placed, config);
}

}  // namespace mm4mm
