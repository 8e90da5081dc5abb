#include "mm4mm/merge/candidate_pairs.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <stdexcept>
#include <tuple>

namespace mm4mm {

PlacedCoverage placedCoverage(const MagneticMap& map, const Eigen::Isometry3d& T_atlas_session) {
  PlacedCoverage coverage;
  coverage.cell_size_m = map.cell_size_m;
  if (map.width <= 0 || map.height <= 0) return coverage;
  // The maps are planar: the placement's yaw and horizontal translation carry one into the other.
  const Eigen::Matrix3d& R = T_atlas_session.linear();
  const Eigen::Rotation2Dd yaw(std::atan2(R(1, 0), R(0, 0)));
  const Eigen::Vector2d t = T_atlas_session.translation().head<2>();
  const double cell = map.cell_size_m;
  const Eigen::Vector2d extent(map.width * cell, map.height * cell);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(INFINITY), hi = -lo;
  for (const Eigen::Vector2d& corner : {Eigen::Vector2d(0, 0), Eigen::Vector2d(extent.x(), 0),
                                        Eigen::Vector2d(0, extent.y()), extent}) {
    const Eigen::Vector2d p = yaw * (map.origin_m + corner) + t;
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Rotation2Dd back = yaw.inverse();
  // Atlas cells visited in (ix, iy) order, so the list comes out sorted.
  for (auto ix = static_cast<std::int32_t>(std::floor(lo.x() / cell));
       ix <= static_cast<std::int32_t>(std::floor(hi.x() / cell)); ++ix)
    for (auto iy = static_cast<std::int32_t>(std::floor(lo.y() / cell));
         iy <= static_cast<std::int32_t>(std::floor(hi.y() / cell)); ++iy) {
      const Eigen::Vector2d centre((ix + 0.5) * cell, (iy + 0.5) * cell);
      const Eigen::Vector2d local = (back * (centre - t) - map.origin_m) / cell;
      const int sx = static_cast<int>(std::floor(local.x()));
      const int sy = static_cast<int>(std::floor(local.y()));
      if (sx >= 0 && sy >= 0 && sx < map.width && sy < map.height && map.covered(sx, sy))
        coverage.cells.emplace_back(ix, iy);
    }
  return coverage;
}

double commonArea_m2(const PlacedCoverage& a, const PlacedCoverage& b) {
  if (std::abs(a.cell_size_m - b.cell_size_m) > 1e-9)
    throw std::invalid_argument("commonArea_m2: coverages of different cell sizes");
  std::size_t common = 0;
  auto i = a.cells.begin();
  auto j = b.cells.begin();
  while (i != a.cells.end() && j != b.cells.end()) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++common, ++i, ++j;
    }
  }
  return static_cast<double>(common) * a.cell_size_m * a.cell_size_m;
}

std::vector<CandidatePair> selectCandidatePairs(
    const std::vector<std::optional<Eigen::Isometry3d>>& T_atlas,
    const std::vector<PlacedCoverage>& coverage, const std::vector<int>& order,
    const std::vector<bool>& ranks, const std::vector<std::pair<int, int>>& skip,
    const CandidateRule& rule) {
  const int n = static_cast<int>(T_atlas.size());
  if (coverage.size() != T_atlas.size() || order.size() != T_atlas.size() ||
      ranks.size() != T_atlas.size())
    throw std::invalid_argument("selectCandidatePairs: one coverage, order and rank per session");
  const std::set<std::pair<int, int>> skipped(skip.begin(), skip.end());
  // Every overlapping pair of placed sessions that a ranking session takes part in.
  std::vector<CandidatePair> pairs;
  for (int a = 0; a < n; ++a)
    for (int b = a + 1; b < n; ++b) {
      if (!T_atlas[a] || !T_atlas[b] || !(ranks[a] || ranks[b]) || skipped.count({a, b})) continue;
      const double overlap = commonArea_m2(coverage[a], coverage[b]);
      if (overlap > 0.0) pairs.push_back({a, b, overlap, T_atlas[a]->inverse() * *T_atlas[b]});
    }
  // Each ranking session's largest overlap with an earlier one is its anchor, kept whatever its
  // size: the pair that says why it was placed where it is.
  std::vector<int> anchor(n, -1);
  for (int p = 0; p < static_cast<int>(pairs.size()); ++p)
    for (const auto& [later, earlier] :
         {std::pair{pairs[p].a, pairs[p].b}, std::pair{pairs[p].b, pairs[p].a}})
      if (ranks[later] && order[earlier] < order[later] &&
          (anchor[later] < 0 || pairs[p].overlap_m2 > pairs[anchor[later]].overlap_m2))
        anchor[later] = p;
  std::vector<bool> keep(pairs.size(), false);
  for (int s = 0; s < n; ++s)
    if (anchor[s] >= 0) pairs[anchor[s]].anchor = keep[anchor[s]] = true;
  // Then each ranking session's largest other overlaps of at least the minimum.
  std::vector<std::vector<std::size_t>> by_session(n);
  for (std::size_t p = 0; p < pairs.size(); ++p)
    if (!pairs[p].anchor && pairs[p].overlap_m2 >= rule.min_pair_overlap_m2)
      for (int s : {pairs[p].a, pairs[p].b})
        if (ranks[s]) by_session[s].push_back(p);
  for (std::vector<std::size_t>& list : by_session) {
    std::stable_sort(list.begin(), list.end(), [&](std::size_t x, std::size_t y) {
      return pairs[x].overlap_m2 > pairs[y].overlap_m2;
    });
    for (std::size_t k = 0; k < list.size(); ++k)
      if (rule.max_pairs_per_session == 0 || static_cast<int>(k) < rule.max_pairs_per_session)
        keep[list[k]] = true;
  }
  std::vector<CandidatePair> kept;
  for (std::size_t p = 0; p < pairs.size(); ++p)
    if (keep[p]) kept.push_back(pairs[p]);
  return kept;  // built in (a, b) order
}

}  // namespace mm4mm
