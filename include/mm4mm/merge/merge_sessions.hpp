#pragma once
// Merging N sessions at once (docs/design.md "Data flow"), in the named steps of merge_steps.hpp:
// every pair matched magnetically in parallel (or each session against the growing map),
// confident pairs refined by ICP-EM, a maximum-confidence spanning tree plus the other pairs that
// agree with it, inter-session edges between keyframes, and one multi-session solve.
// Sessions that match nothing stay unconnected; they are never forced into a wrong place.
// The order is the paper's Eq. 1: p(T_M, T_B | ...) = p(T_B | magnetic maps) ·
// p(T_M | T_B, point maps): the magnetic match proposes T_B, and the geometric refinement is
// conditioned on it (its prior and its overlap region).

#include <Eigen/Geometry>
#include <cstdio>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mm4mm/geometry/floor_height.hpp"
#include "mm4mm/geometry/icp_em.hpp"
#include "mm4mm/geometry/point_map.hpp"
#include "mm4mm/graph/multi_session_graph.hpp"
#include "mm4mm/magnetic/magnetic_matcher.hpp"
#include "mm4mm/merge/growing_map_matching.hpp"
#include "mm4mm/merge/inter_session_edges.hpp"
#include "mm4mm/merge/joint_match.hpp"
#include "mm4mm/merge/structure_map.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// How sessions find each other magnetically.
enum class PairMatching {
  kAllPairs,    ///< every pair matched (N (N - 1) / 2 matches); ambiguous pairs can be settled
  kGrowingMap,  ///< each session against the growing fused map (about N matches per pass)
};

struct MergeConfig {
  MagneticMatcherConfig matcher;
  PairMatching pair_matching = PairMatching::kAllPairs;
  GrowingMapConfig growing_map;  ///< kGrowingMap
  /// Pair refinement over the two whole point maps, restricted to the magnetic overlap. The maps
  /// are thinned to the finest ICP-EM level; ICP-EM computes its own covariances per level.
  PointMapConfig point_map = [] {
    PointMapConfig c;
    c.voxel_size_m = 0.25;
    return c;
  }();
  IcpEmConfig pair_icp;
  double overlap_margin_m = 8.0;
  InterSessionEdgeConfig edges;
  /// Magnetic-only sessions: edges take the magnetic transform with these standard deviations.
  double magnetic_edge_sigma_m = 0.1;
  double magnetic_edge_sigma_deg = 0.5;
  /// A pair outside the spanning tree is kept when its transform agrees with the tree's path
  /// between the two sessions within these (drift separates the two a little).
  double consistency_translation_m = 1.0;
  double consistency_rotation_deg = 3.0;
  /// Geometry settles what the field leaves open: a pair the matcher calls "ambiguous" (two
  /// credible magnetic modes) is refined by ICP-EM from each credible mode (at most
  /// `max_modes_verified`), and accepted at the mode whose inlier ratio reaches
  /// `min_geometric_inlier_ratio` and beats every other mode's by `geometric_inlier_margin`.
  /// Repetitive geometry (a shift by one pillar pitch) fits equally well and stays refused. An
  /// accepted pair whose ICP-EM inlier ratio falls below the minimum is dropped: the walls of
  /// the two sessions do not agree there.
  bool verify_ambiguous_with_geometry = true;
  int max_modes_verified = 3;
  double min_geometric_inlier_ratio = 0.8;
  double geometric_inlier_margin = 0.15;
  /// Geometry-only fallback (structure_map.hpp): a pair in which a session cannot be matched
  /// magnetically (magneticMatchObstacle) but both have scans is matched on the two sessions'
  /// structure maps with `geometry_matcher` and its confidence rule, then refined and verified by
  /// ICP-EM as any pair. Such pairs rank after magnetic ones in the spanning tree. All-pairs
  /// matching and add (the new session's pairs); the growing-map matching does not fall back.
  bool geometry_fallback = true;
  /// Two sessions whose magnetometers' heights above the floor are both known
  /// (SensorRig::frame_height_above_floor_m) and differ by more than this (m) are not compared by
  /// their field: near the floor the field changes with height, and the simulated buildings'
  /// true field at 0.3 m and 0.6 m already correlates below the matcher's min_r in some
  /// (bench/field_height_bench, tuning worlds: every world's median local r >= min_r up to
  /// 0.2 m apart). Such a pair is not searched by the field alone, which cannot match it; where
  /// both have scans the joint stage still puts the structure maps' modes to the field (as for
  /// any pair the field alone refused), else it is refused. The solve's magnetic residuals skip a
  /// reading taken further than this from the other session's map height. Infinite: always
  /// compared.
  double max_height_difference_m = 0.2;
  StructureMapConfig structure_map;
  MagneticMatcherConfig geometry_matcher = [] {
    MagneticMatcherConfig c;
    c.map.cell_size_m = 0.2;
    c.coarse_cell_size_m = 0.4;
    c.search.yaw_step_deg = 2.0;
    c.use_compass_prior = false;  // a structure map holds walls, no field that points north
    // The grid holds its occupancy in every channel (StructureMap::asMatchGrid), and channels
    // that repeat one another give the same r as one of them (each sum over the overlap doubles),
    // so one channel: three transforms a yaw fewer in the sweep, half the refinement's lookups.
    c.score.channels = MatchChannels::kVertical;
    // The confidence model was fitted on field matches; walls correlate otherwise (it is off by
    // default; this keeps it off here when a config turns it on for the field).
    c.confidence_model.decides = false;
    c.min_r = 0.7;  // occupancy grids of two sessions agree less than two field maps
    // Stricter than the field's rule: a shift by one pillar pitch keeps nearly all the overlap
    // and correlates nearly as well, so any credible mode with half the best z is a rival. Every
    // mode is refined before they are compared (a coarse score understates a rival).
    c.max_second_ratio = 0.5;
    c.refine_modes = c.search.max_modes;
    // Coarse to fine was checked on field maps only; walls keep the exhaustive sweep.
    c.search.pyramid_factor = 1;
    return c;
  }();
  /// Geometry proposes, the field decides (joint_match.hpp): a pair of two sessions with scans
  /// that the field alone did not accept (no overlap, ambiguous, yaw uncertain) gets the credible
  /// modes of its structure maps' match put to the field; accepted where the field picks one, then
  /// refined by ICP-EM as any pair. All-pairs matching only.
  JointMatchConfig joint;
  MultiSessionGraphConfig graph;
  bool IsValid(std::string* error) const;
};

enum class PairRole {
  kRefused,       ///< the match (magnetic, or on structure maps) answered "no overlap" or
                  ///< "ambiguous", or ICP-EM contradicted it
  kTree,          ///< in the maximum-confidence spanning tree
  kConsistent,    ///< outside the tree, agrees with it, its edges are used
  kInconsistent,  ///< outside the tree, disagrees with it, dropped
};
/// The role's name in report.json; inline, so that io/ can write and read it without linking the
/// pipeline.
inline std::string toString(PairRole role) {
  switch (role) {
    case PairRole::kRefused:
      return "refused";
    case PairRole::kTree:
      return "tree";
    case PairRole::kConsistent:
      return "consistent";
    case PairRole::kInconsistent:
      return "inconsistent";
  }
  return "unknown";
}

struct PairResult {
  int a = 0;
  int b = 0;
  MagneticMatchResult magnetic;
  /// The pair takes part in the atlas: its match (magnetic, or on structure maps for a
  /// geometry-only pair) accepted it and ICP-EM did not contradict it, or ICP-EM chose between its
  /// ambiguous modes.
  bool accepted = false;
  /// ICP-EM inlier ratio from each verified magnetic mode (ambiguous pairs), in mode order.
  std::vector<double> mode_inlier_ratios;
  /// Index into `magnetic.modes` of the mode the geometry chose (-1: none, or not ambiguous).
  int geometry_chosen_mode = -1;
  /// Matched on the sessions' structure maps, not the field (the geometry-only fallback):
  /// `magnetic` then holds that match.
  bool geometry_only = false;
  /// Placed jointly (joint_match.hpp): `magnetic` holds the field's choice among the structure
  /// match's modes, not a search of the field alone.
  bool joint = false;
  /// Where the sessions' magnetometers are further apart in height than
  /// MergeConfig::max_height_difference_m: that distance (m, a's height minus b's), and the
  /// pair was not searched by the field alone.
  std::optional<double> height_difference_m;
  bool refined = false;  ///< ICP-EM ran (both sessions have scans)
  IcpEmResult icp;
  /// The pair's transform after refinement (the magnetic one for magnetic-only sessions).
  Eigen::Isometry3d T_a_b = Eigen::Isometry3d::Identity();
  PairRole role = PairRole::kRefused;
  int edges = 0;         ///< inter-session edges it contributed
  int edges_kept = 0;    ///< of which the solve kept
  double seconds = 0.0;  ///< matching + refinement + edges
};

/// Why a session cannot be matched magnetically at all (magneticMatchObstacle); describe() words
/// it for the report and the command line.
struct MatchObstacle {
  enum class Reason {
    kNone,
    kNoKeyframes,
    kNoReadings,         ///< no magnetometer readings
    kNoReadingsInSpan,   ///< none within the keyframes' time span
    kTooLittleCoverage,  ///< its map covers less than any match needs
  };
  Reason reason = Reason::kNone;
  double covered_m2 = 0.0;   ///< kTooLittleCoverage: the map's covered area
  double travelled_m = 0.0;  ///< kTooLittleCoverage: the keyframes' path length
  double needed_m2 = 0.0;    ///< kTooLittleCoverage: the matcher's minimum overlap
  bool any() const { return reason != Reason::kNone; }
};

/// The reason's name in report.json (`not_matchable_reason`); inline, as toString(PairRole).
inline std::string toString(MatchObstacle::Reason reason) {
  switch (reason) {
    case MatchObstacle::Reason::kNone:
      return "none";
    case MatchObstacle::Reason::kNoKeyframes:
      return "no_keyframes";
    case MatchObstacle::Reason::kNoReadings:
      return "no_readings";
    case MatchObstacle::Reason::kNoReadingsInSpan:
      return "no_readings_in_span";
    case MatchObstacle::Reason::kTooLittleCoverage:
      return "too_little_coverage";
  }
  return "unknown";
}

/// The obstacle in words ("" for none), for the report and the command line; inline, as
/// toString.
inline std::string describe(const MatchObstacle& obstacle) {
  switch (obstacle.reason) {
    case MatchObstacle::Reason::kNone:
      return {};
    case MatchObstacle::Reason::kNoKeyframes:
      return "no keyframes";
    case MatchObstacle::Reason::kNoReadings:
      return "no magnetometer readings, so nothing to match it by";
    case MatchObstacle::Reason::kNoReadingsInSpan:
      return "no magnetometer reading falls within its keyframes' time span";
    case MatchObstacle::Reason::kTooLittleCoverage:
      break;
  }
  char text[200];
  std::snprintf(text, sizeof text,
                "its magnetic map covers %.1f m² after %.1f m of travel, less than the %.0f m² any "
                "match needs",
                obstacle.covered_m2, obstacle.travelled_m, obstacle.needed_m2);
  return text;
}

struct MergeResult {
  /// The settings it was computed with (stored in the atlas beside the outputs').
  MergeConfig config;
  std::vector<PairResult> pairs;  ///< every pair (a < b), in order
  std::vector<InterSessionEdge> edges;
  /// Session frames in the atlas from the spanning tree's pair transforms, before the solve
  /// (identity where the tree does not reach): one rigid transform per session, no drift
  /// correction. The baseline the solve is measured against.
  std::vector<Eigen::Isometry3d> tree_T_atlas_session;
  /// The session whose frame the atlas's is (its first keyframe held at its odometry pose): the
  /// first of the largest group of matched sessions in a new atlas, and an atlas's own in `add`.
  /// Sessions that group does not reach are unconnected.
  int frame_session = 0;
  MultiSessionSolution solution;
  std::vector<MagneticMap> magnetic_maps;  ///< each session's fine map, its own frame
  /// Each session's structure map where a geometry-only match needed it (else empty).
  std::vector<StructureMap> structure_maps;
  /// Per session, why it cannot be matched magnetically at all (see magneticMatchObstacle;
  /// MatchObstacle::kNone where it can). Its pairs are not matched magnetically; with MergeConfig's
  /// geometry_fallback they are matched on structure maps where both sessions have scans (all-pairs
  /// matching and add), else the session stays unconnected (the growing-map matching tries it
  /// against the map and finds nothing).
  std::vector<MatchObstacle> match_obstacles;
  /// Per session, its frame's height above the floor, stated or from its scans
  /// (frameHeightAboveFloor), and its magnetometers' mean height above the floor (m), where known.
  std::vector<std::optional<FrameHeight>> frame_heights;
  std::vector<std::optional<double>> magnetometer_heights_m;
  /// How each session's magnetometers were calibrated before the merge, for the report; filled by
  /// the caller that ran the pipeline's calibration step (calibrateSessions), which states the
  /// calibrations in the sessions' rigs for mergeSessions and every later stage to apply.
  std::vector<SessionCalibration> calibrations;
  int magnetic_matches = 0;  ///< magnetic matches run
  int geometry_matches = 0;  ///< geometry-only matches run (structure maps)
  double seconds_maps = 0.0;
  double seconds_matching = 0.0;
  double seconds_refinement = 0.0;
  double seconds_solve = 0.0;
};

/// Progress messages for long work (the CLI prints them).
using ProgressCallback = std::function<void(const std::string&)>;

/// Why `session`, whose own magnetic map is `map`, cannot overlap any other session magnetically
/// (kNone when it can). A session without
/// magnetometer readings, or none within its keyframes' time span, has no map; a session that
/// hardly moves (or records only briefly) covers less than the `config`'s minimum overlap, which
/// any match needs. Its pairs fall back to geometry where both sessions have scans
/// (MergeConfig::geometry_fallback; all-pairs matching and add, not the growing-map matching).
MatchObstacle magneticMatchObstacle(const Session& session, const MagneticMap& map,
                                    const MagneticMatcherConfig& config);

/// Merges `sessions` into one atlas whose frame is that of the first session of the largest group
/// of sessions that overlap (MergeResult::frame_session). Deterministic for a
/// config (the matcher's seed). Throws std::invalid_argument for an invalid config or fewer than
/// one session.
MergeResult mergeSessions(const std::vector<Session>& sessions, const MergeConfig& config,
                          const ProgressCallback& progress = {});

/// One line each for the progress of a merge or add: what the matching ran and accepted, and what
/// the solve connected.
std::string matchingSummary(const MergeResult& result);
std::string solveSummary(const MergeResult& result);

}  // namespace mm4mm
