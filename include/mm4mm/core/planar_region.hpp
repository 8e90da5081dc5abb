#pragma once
// A mask of cells in a frame's x-y plane: where ICP-EM may associate points, as delimited by the
// magnetic maps' overlap. Plain data, so that geometry/ and magnetic/ can both speak it.

#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mm4mm {

/// A set of cells in the x-y plane of frame a: where ICP-EM may associate points. Cell (ix, iy)
/// covers [origin + (ix, iy) * cell, origin + (ix + 1, iy + 1) * cell).
struct PlanarRegion {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();  ///< corner of cell (0, 0), frame a (m)
  double cell_size_m = 0.25;
  int width = 0;                     ///< cells along x
  int height = 0;                    ///< cells along y
  std::vector<std::uint8_t> inside;  ///< row-major (iy * width + ix); non-zero: in the region

  /// Whether the x-y position `p_a` (frame a, m) falls in an inside cell; false off the grid.
  bool contains(const Eigen::Vector2d& p_a) const;
  /// Number of inside cells.
  std::size_t insideCells() const;
};

/// The region grown by `margin_m` (m): every cell whose centre lies within `margin_m` of an
/// inside cell's centre becomes inside; the grid is enlarged to hold them.
/// Throws std::invalid_argument for a negative or non-finite margin.
PlanarRegion dilateRegion(const PlanarRegion& region, double margin_m);

}  // namespace mm4mm
