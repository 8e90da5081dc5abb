#pragma once
// One pose graph over every session (docs/design.md "Data flow", the product's step beyond the
// paper): each session's keyframes are nodes joined by odometry edges, inter-session edges from
// the geometric refinement join keyframes of different sessions, and magnetic residuals tie each
// session's field readings to the other sessions' magnetic maps. One Ceres solve corrects every
// session's drift, not one rigid transform per session.
//
// Magnetic nodes are not free variables here: each sample is attached rigidly to its nearest
// keyframe by the odometry between them (under a metre of travel, where the odometry is good to
// millimetres), so the solve has one pose per keyframe and still moves every reading with the
// corrected trajectory.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/graph/session_graph.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// A relative-pose constraint between keyframe `keyframe_a` of session `session_a` and keyframe
/// `keyframe_b` of session `session_b` (indices into the solve's session list).
struct InterSessionEdge {
  int session_a = 0;
  int keyframe_a = 0;
  int session_b = 0;
  int keyframe_b = 0;
  /// Pose of b's keyframe body in a's keyframe body.
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  /// Inverse covariance of [δt (m); δθ (rad, rotation vector)], the OdometryEdge convention.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
};

enum class RobustLoss { kNone, kHuber, kCauchy };

struct MultiSessionGraphConfig {
  SessionGraphConfig odometry_noise;
  /// Loss on the whitened squared error of each inter-session edge; `loss_scale` is in standard
  /// deviations (the residual is whitened by the edge's information).
  RobustLoss inter_session_loss = RobustLoss::kCauchy;
  double inter_session_loss_scale = 3.0;
  /// After a solve, inter-session edges whose whitened squared error exceeds this are dropped and
  /// the graph is solved again: an inconsistent edge is removed, not averaged in. The default is
  /// generous because ICP information matrices are optimistic.
  double max_inter_session_chi2 = 200.0;
  int max_outlier_rounds = 5;

  /// Magnetic residuals: every `magnetic_stride_m` of travel, each reading's (B_h, B_v) against
  /// the other connected sessions' magnetic maps where they cover it.
  bool use_magnetic_residuals = true;
  double magnetic_stride_m = 0.5;
  double magnetic_sigma_uT = 1.0;
  /// Huber scale of the magnetic residuals, in standard deviations.
  double magnetic_loss_scale = 2.0;

  int max_iterations = 100;
  /// Ceres sums per-thread partial costs in no fixed order, so more than one thread can change
  /// the last bits of the solution from run to run; one keeps merges reproducible.
  int threads = 1;
  bool IsValid(std::string* error) const;
};

/// What goes into a solve. `sessions[i].keyframes` are the odometry poses; `T_atlas_session[i]`
/// places session i's odometry frame in the atlas (the initial guess, from the pairwise
/// transforms); sessions with `connected[i] == false` are left out of the solve. `magnetic_maps`
/// is empty or one map per session (each in its own session frame) for the magnetic residuals.
struct MultiSessionProblem {
  std::vector<const Session*> sessions;
  std::vector<Eigen::Isometry3d> T_atlas_session;
  std::vector<bool> connected;
  std::vector<InterSessionEdge> edges;
  std::vector<const MagneticMap*> magnetic_maps;
  /// Warm start (`mm4mm add`): empty, or per session either empty (start from T_atlas_session
  /// times the odometry) or one atlas-frame pose per keyframe, the previous solve's estimate.
  std::vector<std::vector<Eigen::Isometry3d>> initial_T_atlas_keyframe;
  /// The session whose first keyframe is held where it starts (the gauge: the atlas frame is its
  /// frame); -1: the first connected session.
  int gauge_session = -1;
  /// A reading is compared with another session's map only where it was taken within this
  /// height (m) of that map: the field changes with height (MergeConfig::max_height_difference_m).
  /// Where both sessions' magnetometer heights above the floor are known
  /// (`heights_above_floor_m`), those are compared; else the reading's z in the other session's
  /// frame near its nearest keyframe and the map's mean height, which an odometry's z drift moves
  /// apart.
  double max_height_difference_m = std::numeric_limits<double>::infinity();
  /// Empty or one per session: its magnetometers' mean height above the floor (m), where known
  /// (MergeResult::magnetometer_heights_m).
  std::vector<std::optional<double>> heights_above_floor_m;
};

struct MultiSessionSolution {
  /// Optimised keyframe poses in the atlas frame, per session. An unconnected session keeps its
  /// odometry (its frame is not known in the atlas).
  std::vector<std::vector<Eigen::Isometry3d>> T_atlas_keyframe;
  /// `T_atlas_session` of docs/design.md: first keyframe's optimised pose times the inverse of its
  /// odometry pose (identity for an unconnected session).
  std::vector<Eigen::Isometry3d> T_atlas_session;
  /// Sessions placed in the atlas: connected on input and still reachable from the gauge session
  /// through kept inter-session edges.
  std::vector<bool> connected;
  std::vector<bool> edge_kept;    ///< one per input edge
  std::vector<double> edge_chi2;  ///< whitened squared error after the final solve
  int magnetic_residuals = 0;     ///< how many took part in the final solve
  int iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  bool converged = false;
  double seconds = 0.0;
};

/// Solves the multi-session graph: odometry edges from each session's keyframe poses with
/// information from `config.odometry_noise`, the inter-session edges with the robust loss, the
/// magnetic residuals, and the first keyframe of the gauge session held fixed. Sessions count as
/// connected while kept edges reach them from the gauge. Sparse Cholesky (SuiteSparse)
/// Levenberg–Marquardt. Throws std::invalid_argument when sizes disagree, an edge names a missing
/// or unconnected session or keyframe, the gauge session is not connected, or the config is
/// invalid.
MultiSessionSolution solveMultiSessionGraph(const MultiSessionProblem& problem,
                                            const MultiSessionGraphConfig& config = {});

}  // namespace mm4mm
