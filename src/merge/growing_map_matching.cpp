#include "mm4mm/merge/growing_map_matching.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "mm4mm/eval/accuracy.hpp"
#include "mm4mm/merge/fused_magnetic_map.hpp"

namespace mm4mm {
namespace {

MagneticLayer placedLayer(const Session& session, const Eigen::Isometry3d& T_atlas_session,
                          const MagneticMatcherConfig& matcher) {
  FusedMagneticMapConfig fused;
  fused.map = matcher.map;
  return buildMagneticLayer(session, placeOdometry({&session}, {T_atlas_session}).front(), fused);
}

}  // namespace

bool GrowingMapConfig::IsValid(std::string* error) const {
  const auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (max_passes < 1) return fail("max_passes must be >= 1");
  if (max_pairs_per_session < 0) return fail("max_pairs_per_session must be >= 0");
  if (!(min_pair_overlap_m2 > 0.0)) return fail("min_pair_overlap_m2 must be > 0");
  std::string inner;
  if (!offsets.IsValid(&inner)) {
    if (error) *error = "offsets." + inner;
    return false;
  }
  return true;
}

GrowingMapMatch matchAgainstGrowingMap(const std::vector<Session>& sessions,
                                       const std::vector<MagneticMap>& maps,
                                       const MagneticMatcherConfig& matcher,
                                       const GrowingMapConfig& config) {
  std::string error;
  if (!config.IsValid(&error)) throw std::invalid_argument("matchAgainstGrowingMap: " + error);
  if (maps.size() != sessions.size())
    throw std::invalid_argument("matchAgainstGrowingMap: one magnetic map per session needed");
  const int n = static_cast<int>(sessions.size());
  GrowingMapMatch result;
  result.T_atlas_session.resize(n);
  result.against_atlas.resize(n);
  if (n == 0) return result;

  std::vector<MagneticLayer> layers(n);
  std::vector<int> placed_in_pass(n, -1);  // -1: not placed; the first session: pass 0
  result.T_atlas_session[0] = Eigen::Isometry3d::Identity();
  placed_in_pass[0] = 0;
  layers[0] = placedLayer(sessions[0], Eigen::Isometry3d::Identity(), matcher);
  for (int pass = 1; pass <= config.max_passes; ++pass) {
    std::vector<int> unplaced;
    for (int s = 0; s < n; ++s)
      if (!result.T_atlas_session[s]) unplaced.push_back(s);
    if (unplaced.empty()) break;
    // Unplaced sessions' layers are still empty, and fusion ignores empty layers. The placed
    // sessions' field offsets are solved and applied first, as the atlas's fused map has them: a
    // session whose unobservable vertical hard iron differs from its neighbour's would otherwise
    // leave a step in B_v where their coverage meets, and a new session's overlap across it
    // correlates the step, not the field.
    // Applied in place, not to a copy (a building-sized layer per session): each pass's solve
    // on the layers shifted by the earlier passes gives the increment, the solve being linear in
    // the offsets and its anchors idempotent.
    if (config.offsets.enabled) applyFieldOffsets(layers, config.offsets);
    const MagneticMap atlas = fuseMagneticLayers(layers).map;
    ++result.passes;
    tbb::parallel_for(std::size_t{0}, unplaced.size(), [&](std::size_t k) {
      const int s = unplaced[k];
      result.against_atlas[s] = matchMagneticMaps(atlas, maps[s], matcher);
    });
    result.matches += static_cast<int>(unplaced.size());
    bool placed_any = false;
    for (int s : unplaced)
      if (result.against_atlas[s].overlap()) {
        result.T_atlas_session[s] = result.against_atlas[s].T_a_b.toIsometry();
        layers[s] = placedLayer(sessions[s], *result.T_atlas_session[s], matcher);
        placed_in_pass[s] = pass;
        placed_any = true;
      }
    if (!placed_any) break;
  }

  // The candidate pairs among the placed sessions: every session ranks its overlaps, and its
  // anchor is its largest overlap with one placed in an earlier pass.
  std::vector<PlacedCoverage> coverage(n);
  tbb::parallel_for(0, n, [&](int s) {
    if (result.T_atlas_session[s])
      coverage[s] = placedCoverage(maps[s], *result.T_atlas_session[s]);
  });
  result.pairs = selectCandidatePairs(result.T_atlas_session, coverage, placed_in_pass,
                                      std::vector<bool>(n, true), {}, config.candidateRule());
  return result;
}

}  // namespace mm4mm
