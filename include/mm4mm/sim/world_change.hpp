#pragma once
// A building before and after a change between sessions (issue 18; ChangeConfig): the world with
// what a change's boxes hold taken out, and the change's ground truth, what it does to the field
// the magnetometers read. The detector (merge/magnetic_change.hpp) is scored against it.

#include <Eigen/Geometry>
#include <vector>

#include "mm4mm/sim/magnetic_field.hpp"
#include "mm4mm/sim/simulation_config.hpp"
#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

/// The plan box of a ChangeConfig entry [x_min, y_min, x_max, y_max].
Eigen::AlignedBox2d changeBox(const std::vector<double>& box);

/// What a box of the change holds in `world`: dipoles above the floor (z >= 0) inside it, and
/// solids whose plan lies wholly inside it.
struct BoxContents {
  int dipoles = 0;
  int solids = 0;
};
BoxContents boxContents(const World& world, const Eigen::AlignedBox2d& box);

/// `world` as the sessions before the change (`after` false) or after it (true) see it: without
/// what change.added_m holds before, without what change.removed_m holds after. Throws
/// std::invalid_argument naming the box when a box holds neither steel nor a solid: such a change
/// changes nothing, and is a mistake in its coordinates.
World changedWorld(const World& world, const ChangeConfig& change, bool after);

/// The change's ground truth: on a grid over the change's boxes dilated by truth_margin_m (cells
/// of truth_cell_m, `height_m` above the floor), the field after the change minus the field
/// before it, as the detector sees it. Row-major (iy * width + ix), cell centres at
/// origin_m + cell_m * (ix + 0.5, iy + 0.5).
struct ChangeTruth {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  double cell_m = 0.0;
  int width = 0;
  int height = 0;
  double height_m = 0.0;
  std::vector<float> delta_h_uT;  ///< change of the horizontal magnitude B_h
  std::vector<float> delta_v_uT;  ///< change of B_v (z up)
  std::vector<float> delta_x_uT;  ///< change of the field along world x
  std::vector<float> delta_y_uT;  ///< ... and along world y
  /// Cells whose |(ΔB_h, ΔB_v)| reaches truth_threshold_uT, their area (m²), and the largest
  /// |(ΔB_h, ΔB_v)| on the grid.
  std::vector<bool> changed;
  double changed_area_m2 = 0.0;
  double largest_uT = 0.0;
};
ChangeTruth changeTruth(const MagneticFieldModel& before, const MagneticFieldModel& after,
                        const ChangeConfig& change, double height_m);

}  // namespace mm4mm::sim
