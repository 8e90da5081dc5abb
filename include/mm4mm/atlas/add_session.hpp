#pragma once
// Adding one session to an existing atlas (`mm4mm add`, docs/design.md "Data flow"):
// the new session is matched against the atlas as a whole (its fused magnetic map) and against
// each unconnected session, refined by ICP-EM against the few placed sessions it overlaps most
// (merge/candidate_pairs.hpp, the growing map's rule), and its edges join the stored graph, which
// is solved again from the current estimate: merge's steps (merge/merge_steps.hpp) around an
// add's own matching.
//
// What one add costs: one magnetic match against the atlas map (its area, not its session count),
// one per unconnected session, and at most `growing_map.max_pairs_per_session` + 1 pair
// refinements. The warm-started solve and the rewritten outputs still visit every session.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mm4mm/atlas/atlas.hpp"
#include "mm4mm/merge/merge_sessions.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

/// Adds `session` to `atlas` (as loadAtlas reads it). Returns the result over the atlas's
/// sessions followed by `session` (index `atlas.sessions.size()`): `pairs` are the atlas's pairs
/// then the new ones, `edges` the stored edges then the new ones, `solution` the solve over all.
/// A session that overlaps nothing stays unconnected; an unconnected session the new one overlaps
/// is placed through it. Deterministic for a config. Throws std::invalid_argument when the
/// session's id is already in the atlas, when it is the same recording as a session of the atlas
/// (same keyframes and readings), or when the config is invalid.
MergeResult addSessionToAtlas(const Atlas& atlas, const Session& session, const MergeConfig& config,
                              const ProgressCallback& progress = {});

}  // namespace mm4mm
