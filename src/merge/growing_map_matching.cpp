#include "mm4mm/merge/growing_map_matching.hpp"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <tuple>

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

// Keeps, for every session, its `limit` largest overlaps; a pair stays when either of its
// sessions keeps it.
std::vector<CandidatePair> strongestPairs(const std::vector<CandidatePair>& pairs, int sessions,
                                          int limit) {
  if (limit <= 0) return pairs;
  std::vector<std::vector<std::size_t>> by_session(sessions);
  for (std::size_t p = 0; p < pairs.size(); ++p) {
    by_session[pairs[p].a].push_back(p);
    by_session[pairs[p].b].push_back(p);
  }
  std::vector<bool> keep(pairs.size(), false);
  for (auto& list : by_session) {
    std::stable_sort(list.begin(), list.end(), [&](std::size_t x, std::size_t y) {
      return pairs[x].overlap_m2 > pairs[y].overlap_m2;
    });
    for (std::size_t k = 0; k < list.size() && static_cast<int>(k) < limit; ++k)
      keep[list[k]] = true;
  }
  std::vector<CandidatePair> kept;
  for (std::size_t p = 0; p < pairs.size(); ++p)
    if (keep[p]) kept.push_back(pairs[p]);
  return kept;
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
  return true;
}

double commonCoverage_m2(const MagneticMap& a, const MagneticMap& b) {
  if (std::abs(a.cell_size_m - b.cell_size_m) > 1e-9)
    throw std::invalid_argument("commonCoverage_m2: maps of different cell sizes");
  const double cell = a.cell_size_m;
  // b's cell index of a's cell (0, 0): the grids are aligned, so the offset is whole.
  const int dx = static_cast<int>(std::lround((a.origin_m.x() - b.origin_m.x()) / cell));
  const int dy = static_cast<int>(std::lround((a.origin_m.y() - b.origin_m.y()) / cell));
  const int x0 = std::max(0, -dx), x1 = std::min(a.width, b.width - dx);
  const int y0 = std::max(0, -dy), y1 = std::min(a.height, b.height - dy);
  std::size_t common = 0;
  for (int iy = y0; iy < y1; ++iy)
    for (int ix = x0; ix < x1; ++ix)
      if (a.covered(ix, iy) && b.covered(ix + dx, iy + dy)) ++common;
  return static_cast<double>(common) * cell * cell;
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
    // Unplaced sessions' layers are still empty, and fusion ignores empty layers.
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

  // Every pair of placed sessions that overlaps; each session's largest overlap with one placed
  // in an earlier pass is its anchor: the pair that says why it was placed, kept whatever its
  // size or rank, so that the pairs connect every placed session to the first.
  std::vector<CandidatePair> pairs;
  std::vector<int> anchor(n, -1);  // index into pairs
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      if (!result.T_atlas_session[a] || !result.T_atlas_session[b]) continue;
      const double overlap = commonCoverage_m2(layers[a].map, layers[b].map);
      if (overlap <= 0.0) continue;
      const int index = static_cast<int>(pairs.size());
      pairs.push_back(
          {a, b, overlap, result.T_atlas_session[a]->inverse() * *result.T_atlas_session[b]});
      for (const auto& [later, earlier] : {std::pair{a, b}, std::pair{b, a}})
        if (placed_in_pass[earlier] < placed_in_pass[later] &&
            (anchor[later] < 0 || overlap > pairs[anchor[later]].overlap_m2))
          anchor[later] = index;
    }
  std::vector<bool> is_anchor(pairs.size(), false);
  for (int s = 0; s < n; ++s)
    if (anchor[s] >= 0) is_anchor[anchor[s]] = true;
  std::vector<CandidatePair> wide, anchors;
  for (std::size_t p = 0; p < pairs.size(); ++p)
    if (is_anchor[p]) {
      anchors.push_back(pairs[p]);
      anchors.back().anchor = true;
    } else if (pairs[p].overlap_m2 >= config.min_pair_overlap_m2)
      wide.push_back(pairs[p]);
  std::vector<CandidatePair> kept = strongestPairs(wide, n, config.max_pairs_per_session);
  kept.insert(kept.end(), anchors.begin(), anchors.end());
  std::sort(kept.begin(), kept.end(),
            [](const auto& x, const auto& y) { return std::tie(x.a, x.b) < std::tie(y.a, y.b); });
  result.pairs = std::move(kept);
  return result;
}

}  // namespace mm4mm
