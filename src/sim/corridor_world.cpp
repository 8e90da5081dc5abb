// The corridor: two long straight walls and two rows of regularly spaced polygonal pillars. Three
// lanes run along it (between wall and pillars, and between the pillar rows), joined by crossings
// midway between pillars.

#include <cmath>
#include <vector>

#include "world_builders.hpp"

namespace mm4mm::sim {
namespace {

bool inPillarFreeRange(const CorridorConfig& c, double x) {
  for (const auto& range : c.pillar_free_ranges_m)
    if (x >= range[0] && x <= range[1]) return true;
  return false;
}

// A LiDAR odometry holds its position along the corridor by the pillars it sees and by the end
// walls; between straight walls with neither in reach nothing fixes it along x.
constexpr double kPillarReach_m = 10.0;
constexpr double kEndWallReach_m = 30.0;
constexpr double kStep_m = 0.5;

std::vector<DegenerateRegion> degenerateStretches(const CorridorConfig& c,
                                                  const std::vector<double>& pillar_xs) {
  std::vector<DegenerateRegion> regions;
  double start = -1.0;
  for (double x = 0.0; x <= c.length_m + kStep_m; x += kStep_m) {
    bool degenerate = x > kEndWallReach_m && x < c.length_m - kEndWallReach_m;
    for (double p : pillar_xs)
      if (std::abs(p - x) <= kPillarReach_m) degenerate = false;
    if (degenerate && start < 0.0) start = x;
    if (!degenerate && start >= 0.0) {
      DegenerateRegion region;
      region.area = Eigen::AlignedBox2d(Eigen::Vector2d(start, 0.0), Eigen::Vector2d(x, c.width_m));
      region.axis = Eigen::Vector2d::UnitX();
      regions.push_back(region);
      start = -1.0;
    }
  }
  return regions;
}

}  // namespace

World buildCorridor(const CorridorConfig& c, SteelAnchors* anchors) {
  World world;
  world.name = "corridor";
  world.split_axis = 0;
  world.floor_xy =
      Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(c.length_m, c.width_m));
  world.ceiling_height_m = c.height_m;
  addEnclosingWalls(&world, c.wall_thickness_m);

  const double half_spacing = 0.5 * c.pillar_spacing_m;
  std::vector<double> pillar_xs;
  for (double x = half_spacing; x + c.pillar_radius_m < c.length_m - 1.0; x += c.pillar_spacing_m) {
    if (inPillarFreeRange(c, x)) continue;
    if (!c.pillar_rows_y_m.empty()) pillar_xs.push_back(x);
    for (double y : c.pillar_rows_y_m) {
      world.solids.push_back(
          regularPrism({x, y}, c.pillar_radius_m, c.pillar_sides, 0.0, c.height_m));
      anchors->push_back({SteelKind::kPillar, {x, y, 0.0}, {x, y, c.height_m}});
    }
  }

  // Lane lines midway between the walls and the pillar rows, and between the rows.
  std::vector<double> bounds{0.0};
  for (double y : c.pillar_rows_y_m) bounds.push_back(y);
  bounds.push_back(c.width_m);
  std::vector<double> ys;
  for (std::size_t i = 0; i + 1 < bounds.size(); ++i)
    ys.push_back(0.5 * (bounds[i] + bounds[i + 1]));

  std::vector<double> xs;
  for (double x = c.pillar_spacing_m; x < c.length_m - 3.0; x += c.pillar_spacing_m)
    xs.push_back(x);

  world.lanes = gridLanes(xs, ys);
  world.degenerate_regions = degenerateStretches(c, pillar_xs);
  return world;
}

}  // namespace mm4mm::sim
