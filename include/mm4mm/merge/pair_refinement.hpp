#pragma once
// The stages after magnetic matching that `merge` and `add` share: ICP-EM refinement of the
// candidate pairs inside their magnetic overlap (ambiguous pairs settled by the geometry), the
// maximum-confidence spanning tree that places the sessions, the consistency of the other pairs
// with it, and the inter-session edges of a pair once it is placed.

#include <Eigen/Geometry>
#include <optional>
#include <vector>

#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/merge/structure_map.hpp"

namespace mm4mm {

/// Marks the maximum-confidence spanning forest of the accepted pairs (Kruskal: magnetic pairs by
/// descending z, then geometry-only ones) as PairRole::kTree; leaves the other pairs' roles as
/// they are.
void markSpanningTree(int sessions, std::vector<PairResult>* pairs);

/// Session frames in the atlas (the frame of session `root`) by composing the tree pairs'
/// transforms outward from `root`; sessions the tree does not reach stay unset.
std::vector<std::optional<Eigen::Isometry3d>> placeByTree(int sessions,
                                                          const std::vector<PairResult>& pairs,
                                                          int root = 0);

/// The sessions the tree pairs join to `session`, itself included, in index order: its component
/// of the spanning forest. For a session placeByTree left unset, these are the sessions it was
/// matched with that are unplaced with it, because none of them reaches the root (the session
/// whose frame is the atlas's).
std::vector<int> treeComponent(int session, const std::vector<PairResult>& pairs);

/// The session whose frame a new atlas takes: the first (lowest index) of the largest component
/// of the spanning forest, so that a first session that overlaps no other does not leave every
/// other session out; among components of one size, the one holding the earliest session.
int largestComponentRoot(int sessions, const std::vector<PairResult>& pairs);

/// Marks every accepted pair outside the tree kConsistent when its transform agrees with the
/// tree's placements within the config's consistency thresholds, else kInconsistent.
void markConsistency(const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
                     const MergeConfig& config, std::vector<PairResult>* pairs);

/// A candidate pair of two placed sessions (the growing map's, or a new session's with the atlas),
/// its magnetic result restating the placement: the two maps' agreement at `T_a_b`. An anchor
/// (the pair that placed a session) is accepted as such; any other pair must correlate like a
/// match of its own (r >= the matcher's min_r).
PairResult pairAtPlacement(int a, int b, const Eigen::Isometry3d& T_a_b, const MagneticMap& map_a,
                           const MagneticMap& map_b, const MergeConfig& config, bool anchor);

/// A geometry-only pair (a, b): matched on the two sessions' structure maps (`structure_maps`,
/// indexed by session) with the config's geometry matcher, accepted where that match is.
PairResult geometryOnlyPair(int a, int b, const std::vector<StructureMap>& structure_maps,
                            const MergeConfig& config);

/// Refines `pairs` (indices into `sessions` and `maps`, each map in its session's frame) in
/// parallel: an accepted pair by ICP-EM from its transform, dropped when the inlier ratio stays
/// below `config.min_geometric_inlier_ratio`; an ambiguous one from each credible mode, accepted
/// where the geometry clearly prefers one. A geometry-only pair's overlap region comes from
/// `structure_maps` (indexed by session; only needed when there are such pairs), which it was
/// matched on. Pairs of sessions without scans keep their magnetic transform. Point maps are
/// built once, only for the sessions the refined pairs touch. Adds each pair's time to `seconds`.
void refinePairs(const std::vector<const Session*>& sessions,
                 const std::vector<const MagneticMap*>& maps,
                 const std::vector<StructureMap>& structure_maps, const MergeConfig& config,
                 const std::vector<PairResult*>& pairs, const ProgressCallback& progress = {});

/// Inter-session edges of a placed pair at its transform: from keyframe scans where both sessions
/// have them, otherwise from the magnetic transform with the config's magnetic edge sigmas.
std::vector<InterSessionEdge> pairEdges(const Session& a, int index_a, const Session& b,
                                        int index_b, const Eigen::Isometry3d& T_a_b,
                                        const MergeConfig& config);

}  // namespace mm4mm
