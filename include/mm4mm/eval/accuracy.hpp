#pragma once
// The accuracy metrics of docs/design.md, for sessions that carry ground truth.

#include <Eigen/Geometry>
#include <vector>

#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// Median error over the keyframe pairs where two sessions overlap (docs/design.md metric 1).
struct OverlapError {
  int pairs = 0;  ///< keyframe pairs within `radius` of each other by ground truth
  double median_translation_m = 0.0;
  double median_rotation_deg = 0.0;

  /// The pair is aligned when the median error is below 0.5 m and 2°.
  bool aligned(double max_translation_m = 0.5, double max_rotation_deg = 2.0) const {
    return pairs > 0 && median_translation_m < max_translation_m &&
           median_rotation_deg < max_rotation_deg;
  }
};

/// For every keyframe i of b within `radius_m` (ground truth) of a keyframe j of a (the nearest
/// one), ΔT = (T̂_j⁻¹ T̂_i)(G_j⁻¹ G_i)⁻¹ with T̂_j = a's odometry and T̂_i = T_a_b · b's
/// odometry. Both sessions need ground truth.
OverlapError overlapError(const Session& a, const Session& b, const Eigen::Isometry3d& T_a_b,
                          double radius_m = 2.0);

/// The same for estimated keyframe poses of both sessions in a common frame (an atlas):
/// ΔT = (T̂_j⁻¹ T̂_i)(G_j⁻¹ G_i)⁻¹ with T̂ = `estimated_a` / `estimated_b`.
OverlapError overlapError(const Session& a, const Session& b,
                          const std::vector<Eigen::Isometry3d>& estimated_a,
                          const std::vector<Eigen::Isometry3d>& estimated_b, double radius_m = 2.0);

/// The paper's metric between session frames (docs/design.md metric 2): e_t and e_r of T_e · T_g⁻¹.
struct FrameError {
  double translation_m = 0.0;
  double rotation_deg = 0.0;
};

/// True T_a_b between session frames, each fixed by its first keyframe: (G_a0 O_a0⁻¹)⁻¹ (G_b0
/// O_b0⁻¹).
Eigen::Isometry3d trueRelativeTransform(const Session& a, const Session& b);
FrameError frameError(const Session& a, const Session& b, const Eigen::Isometry3d& T_a_b);

/// docs/design.md metric 3: RMSE (m) of keyframe positions in the atlas frame against ground truth
/// carried into the atlas frame through the first keyframe of `sessions[reference]` (the atlas
/// frame is that session's odometry frame). `T_atlas_keyframe[s]` holds session s's estimated
/// keyframe poses; only sessions with `include[s]` count. Every session needs ground truth.
double atlasTrajectoryError(const std::vector<const Session*>& sessions,
                            const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                            const std::vector<bool>& include, int reference = 0);

/// Each session's odometry keyframe poses moved rigidly by `T_atlas_session[s]`: where one rigid
/// transform per session, without drift correction, puts them.
std::vector<std::vector<Eigen::Isometry3d>> placeOdometry(
    const std::vector<const Session*>& sessions,
    const std::vector<Eigen::Isometry3d>& T_atlas_session);

/// The same figure for the raw odometry: each session's odometry placed in the atlas by its
/// true frame (trueRelativeTransform from the reference), so only drift counts.
double odometryTrajectoryError(const std::vector<const Session*>& sessions,
                               const std::vector<bool>& include, int reference = 0);

/// The three figures of docs/design.md for an atlas, over its connected sessions.
struct AtlasEvaluation {
  struct Pair {
    int a = 0;
    int b = 0;
    OverlapError overlap;  ///< metric 1 on the optimised trajectories
  };
  struct Frame {
    int session = 0;
    FrameError error;  ///< metric 2: the session's frame against the reference's
  };
  std::vector<Pair> pairs;      ///< connected pairs that overlap by ground truth
  std::vector<Frame> frames;    ///< connected sessions other than the reference
  double ate_m = 0.0;           ///< metric 3 after the solve
  double odometry_ate_m = 0.0;  ///< metric 3 of the raw odometry at the true frames
};

/// Evaluates optimised keyframe poses `T_atlas_keyframe` (one trajectory per session, atlas frame
/// = the odometry frame of `reference`) against ground truth; only `connected` sessions count.
/// Throws std::invalid_argument when a connected session has no ground truth.
AtlasEvaluation evaluateAtlas(const std::vector<const Session*>& sessions,
                              const std::vector<std::vector<Eigen::Isometry3d>>& T_atlas_keyframe,
                              const std::vector<bool>& connected, int reference = 0);

}  // namespace mm4mm
