#pragma once
// One session as a pose graph (paper Section III-A, docs/design.md "Data flow"): a node per
// keyframe (the scans of the point map), a node per magnetometer sample time (the readings of the
// magnetic map), and odometry edges along the merged time sequence of both. The multi-session graph
// adds inter-session edges between these nodes; the magnetic nodes let it pin the field readings to
// the corrected trajectory instead of to the raw odometry.
//
// Frames: every node pose is T_session_body, the body frame in the session (odometry) frame.
// An edge's T_from_to = T_session_from^-1 * T_session_to is the motion from the `from` node's
// body frame to the `to` node's, expressed in the `from` body frame.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// A keyframe: where a scan was taken (or would be, for a magnetic-only session).
struct ScanNode {
  int id = 0;
  double time_s = 0.0;
  Eigen::Isometry3d T_session_body = Eigen::Isometry3d::Identity();
  int keyframe = 0;  ///< index into Session::keyframes (and Session::scans when present)
};

/// One magnetometer sample time: the body pose then, slerped between the bracketing keyframes as
/// placeFingerprints does, and the reading of every sensor of the rig at that instant.
struct MagneticNode {
  int id = 0;
  double time_s = 0.0;
  Eigen::Isometry3d T_session_body = Eigen::Isometry3d::Identity();
  /// One entry per sensor of the rig (index = SensorRig::magnetometers_body index); field in µT
  /// along the body axes. Entries without a sample at this time are zero.
  std::vector<Eigen::Vector3d> readings_body_uT;
  std::vector<bool> has_reading;  ///< same size; false where the sensor has no sample now
};

/// Relative-pose constraint from odometry between two nodes.
struct OdometryEdge {
  int from = 0;
  int to = 0;
  /// Pose of the `to` body frame in the `from` body frame.
  Eigen::Isometry3d T_from_to = Eigen::Isometry3d::Identity();
  /// Inverse covariance of the error [δt (m, xyz); δθ (rad, rotation vector xyz)], as g2o's
  /// EDGE_SE3:QUAT and Ceres' pose_graph_3d order it. The rotation block is in radians of the
  /// rotation vector (Ceres' residual 2·vec(δq)); g2o's own EdgeSE3 measures vec(δq) ≈ δθ/2, so
  /// a g2o solver weighs rotation 4x less than intended here.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

/// Odometry noise model. An edge that moves the body by distance d (m) and turns it by angle θ
/// (rad) gets an isotropic covariance per block,
///   σ_t² = (translation_sigma_per_sqrt_m · √d)² + translation_sigma_floor²
///   σ_r² = (rotation_sigma_per_sqrt_m · √d)² + (rotation_sigma_per_sqrt_rad · √θ)²
///          + rotation_sigma_floor²,
/// and information = diag(1/σ_t², 1/σ_t², 1/σ_t², 1/σ_r², 1/σ_r², 1/σ_r²). Drift of a
/// LiDAR-inertial odometry behaves like a random walk along the path, whose variance grows
/// linearly with distance travelled and angle turned; with that model the covariances of
/// consecutive edges add up to the covariance of the composed edge (up to the floor, which is
/// counted once, and the rotation of the isotropic blocks, which leaves them unchanged). The floor
/// keeps the information finite for two nodes at the same pose (a scan and a magnetometer sample
/// at the same time).
struct SessionGraphConfig {
  double translation_sigma_per_sqrt_m = 0.01;    ///< m per √(m travelled)
  double translation_sigma_floor_m = 0.001;      ///< m
  double rotation_sigma_per_sqrt_m_deg = 0.1;    ///< deg per √(m travelled)
  double rotation_sigma_per_sqrt_rad_deg = 0.1;  ///< deg per √(rad turned)
  double rotation_sigma_floor_deg = 0.01;        ///< deg

  /// False with a message naming the bad field when a rate is negative or a floor not positive.
  bool IsValid(std::string* error) const;
};

struct SessionGraph {
  std::string session_id;
  /// The noise model the information matrices came from, kept so that edges composed later
  /// (the g2o writer's scan-to-scan chain) get information from the same model.
  SessionGraphConfig noise;
  std::vector<ScanNode> scans;         ///< keyframe order (scans[k].keyframe == k when built)
  std::vector<MagneticNode> magnetic;  ///< time order
  /// Chain over the merged time sequence of scan and magnetic nodes: odometry[i] joins the i-th
  /// and (i+1)-th node of that sequence. A scan and a magnetic node at the same time are ordered
  /// scan first.
  std::vector<OdometryEdge> odometry;
};

/// Information matrix of the noise model for a motion of `distance_m` travelled and `turned_rad`
/// turned (both >= 0); see SessionGraphConfig.
Eigen::Matrix<double, 6, 6> odometryInformation(double distance_m, double turned_rad,
                                                const SessionGraphConfig& config);

/// Builds the graph of `session`: a scan node per keyframe, a magnetic node per distinct
/// magnetometer sample time inside the keyframes' time span (samples outside it are dropped, as
/// in placeFingerprints), and odometry edges along the merged time sequence. Node ids are 0 … N-1
/// in that sequence, so they are unique across both kinds. Edge distances and turns are those
/// between the interpolated poses of consecutive nodes. Throws std::invalid_argument when
/// `config` is invalid or the session breaks its invariants (keyframe times not increasing,
/// samples not sorted by time, a sensor index outside the rig).
SessionGraph buildSessionGraph(const Session& session, const SessionGraphConfig& config = {});

/// The graph of `session` with its keyframes at `T_frame_keyframe` (one pose per keyframe, such
/// as a solve's in the atlas frame) instead of their own poses; the session is not copied.
/// Throws as buildSessionGraph, and std::invalid_argument when the poses are not one per keyframe.
SessionGraph buildSessionGraphAt(const Session& session,
                                 const std::vector<Eigen::Isometry3d>& T_frame_keyframe,
                                 const SessionGraphConfig& config = {});

}  // namespace mm4mm
