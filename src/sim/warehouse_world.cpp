// The warehouse: identical double-sided steel shelf rows in blocks along x, concrete pillars at
// the row ends and along the perimeter lanes, four walls. Lanes run through every aisle, the cross
// aisles and the perimeter bands.

#include <algorithm>
#include <cmath>

#include "world_builders.hpp"

namespace mm4mm::sim {
namespace {

struct RowLayout {
  double x0 = 0.0;  ///< start of the first block
  double y0 = 0.0;  ///< start of the first row
  double row_depth = 0.0;
  double row_pitch = 0.0;
  double block_length = 0.0;
  double block_pitch = 0.0;
};

RowLayout layoutOf(const WarehouseConfig& c) {
  RowLayout l;
  l.row_depth = 2.0 * c.rack_depth_m + c.rack_gap_m;
  l.row_pitch = l.row_depth + c.aisle_width_m;
  l.block_length = c.bays_per_block * c.bay_width_m;
  l.block_pitch = l.block_length + c.cross_aisle_width_m;
  const double rows_extent = c.shelf_rows * l.row_pitch - c.aisle_width_m;
  const double blocks_extent = c.shelf_blocks * l.block_pitch - c.cross_aisle_width_m;
  l.x0 = 0.5 * (c.size_x_m - blocks_extent);
  l.y0 = 0.5 * (c.size_y_m - rows_extent);
  return l;
}

// One side of a double-sided row: uprights at every bay boundary on both faces, a board and a
// goods box on every level of every bay. Identical everywhere, as real racking is.
void addRackSide(const WarehouseConfig& c, double x_start, double y_lo, World* world,
                 SteelAnchors* anchors) {
  const double y_hi = y_lo + c.rack_depth_m;
  const double u = c.upright_size_m;
  for (int i = 0; i <= c.bays_per_block; ++i) {
    const double x = x_start + i * c.bay_width_m;
    for (double y : {y_lo + 0.5 * u, y_hi - 0.5 * u}) {
      world->solids.push_back(
          boxSolid({x - 0.5 * u, y - 0.5 * u}, {x + 0.5 * u, y + 0.5 * u}, 0.0, c.shelf_top_m));
      anchors->push_back({SteelKind::kUpright, {x, y, 0.0}, {x, y, c.shelf_top_m}});
    }
  }
  const double board = 0.05;
  const double x_end = x_start + c.bays_per_block * c.bay_width_m;
  for (double z : c.shelf_levels_m)
    for (double y : {y_lo, y_hi})
      anchors->push_back({SteelKind::kBeam, {x_start, y, z}, {x_end, y, z}});
  for (int i = 0; i < c.bays_per_block; ++i) {
    const double x_lo = x_start + i * c.bay_width_m + 0.5 * u;
    const double x_hi = x_start + (i + 1) * c.bay_width_m - 0.5 * u;
    for (std::size_t level = 0; level < c.shelf_levels_m.size(); ++level) {
      const double z = c.shelf_levels_m[level];
      world->solids.push_back(boxSolid({x_lo, y_lo}, {x_hi, y_hi}, z, z + board));
      const double next =
          level + 1 < c.shelf_levels_m.size() ? c.shelf_levels_m[level + 1] : c.shelf_top_m;
      const double goods_height = std::min(c.goods_fill * (next - z - board), 1.2);
      const double margin_x = 0.5 * (1.0 - c.goods_fill) * (x_hi - x_lo);
      const double margin_y = 0.5 * (1.0 - c.goods_fill) * c.rack_depth_m;
      world->solids.push_back(boxSolid({x_lo + margin_x, y_lo + margin_y},
                                       {x_hi - margin_x, y_hi - margin_y}, z + board,
                                       z + board + goods_height));
    }
  }
}

void addPillar(const WarehouseConfig& c, const Eigen::Vector2d& centre, World* world,
               SteelAnchors* anchors) {
  const Eigen::Vector2d half = Eigen::Vector2d::Constant(0.5 * c.pillar_size_m);
  world->solids.push_back(boxSolid(centre - half, centre + half, 0.0, c.height_m));
  anchors->push_back(
      {SteelKind::kPillar, {centre.x(), centre.y(), 0.0}, {centre.x(), centre.y(), c.height_m}});
}

// Lane centre lines: midway between obstacles, so the robot's sensor bar clears both sides.
void addLanes(const WarehouseConfig& c, const RowLayout& l, World* world) {
  const double pillar_reach = c.pillar_offset_from_rows_m + c.pillar_size_m;
  std::vector<double> xs{0.5 * (l.x0 - pillar_reach)};
  for (int b = 0; b + 1 < c.shelf_blocks; ++b)
    xs.push_back(l.x0 + b * l.block_pitch + l.block_length + 0.5 * c.cross_aisle_width_m);
  const double x_end = l.x0 + c.shelf_blocks * l.block_pitch - c.cross_aisle_width_m;
  xs.push_back(0.5 * (x_end + pillar_reach + c.size_x_m));

  std::vector<double> ys{0.5 * (l.y0 - pillar_reach)};
  for (int r = 0; r + 1 < c.shelf_rows; ++r)
    ys.push_back(l.y0 + r * l.row_pitch + l.row_depth + 0.5 * c.aisle_width_m);
  const double y_end = l.y0 + c.shelf_rows * l.row_pitch - c.aisle_width_m;
  ys.push_back(0.5 * (y_end + pillar_reach + c.size_y_m));

  world->lanes = gridLanes(xs, ys);
}

}  // namespace

World buildWarehouse(const WarehouseConfig& c, SteelAnchors* anchors) {
  World world;
  world.name = "warehouse";
  world.floor_xy =
      Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(c.size_x_m, c.size_y_m));
  world.ceiling_height_m = c.height_m;
  addEnclosingWalls(&world, c.wall_thickness_m);

  const RowLayout l = layoutOf(c);
  const double pillar_centre_offset = c.pillar_offset_from_rows_m + 0.5 * c.pillar_size_m;
  for (int r = 0; r < c.shelf_rows; ++r) {
    const double y_row = l.y0 + r * l.row_pitch;
    for (int b = 0; b < c.shelf_blocks; ++b) {
      const double x_block = l.x0 + b * l.block_pitch;
      addRackSide(c, x_block, y_row, &world, anchors);
      addRackSide(c, x_block, y_row + c.rack_depth_m + c.rack_gap_m, &world, anchors);
      const double y_centre = y_row + 0.5 * l.row_depth;
      addPillar(c, {x_block - pillar_centre_offset, y_centre}, &world, anchors);
      addPillar(c, {x_block + l.block_length + pillar_centre_offset, y_centre}, &world, anchors);
    }
  }
  // Perimeter pillars just outside the first and last rows: at the row-end pillar columns and
  // at the middle of each block, a regular grid that leaves the perimeter lanes free.
  const double y_low = l.y0 - pillar_centre_offset;
  const double y_high = l.y0 + c.shelf_rows * l.row_pitch - c.aisle_width_m + pillar_centre_offset;
  for (int b = 0; b < c.shelf_blocks; ++b) {
    const double x_block = l.x0 + b * l.block_pitch;
    for (double x : {x_block - pillar_centre_offset, x_block + 0.5 * l.block_length,
                     x_block + l.block_length + pillar_centre_offset})
      for (double y : {y_low, y_high}) addPillar(c, {x, y}, &world, anchors);
  }
  addLanes(c, l, &world);
  return world;
}

}  // namespace mm4mm::sim
