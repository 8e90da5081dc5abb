#pragma once
// Exact ray casting against a world's solids, floor and ceiling. Solids are binned on a plan grid
// and a ray walks the cells its projection crosses (Amanatides–Woo), so a cast costs about the
// number of cells up to the first hit, not the number of solids.

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "mm4mm/sim/world.hpp"

namespace mm4mm::sim {

class Raycaster {
 public:
  /// Keeps a reference to `world`, which must outlive the caster.
  explicit Raycaster(const World& world, double cell_size_m = 1.0);

  /// Distance (m) along the unit vector `direction` from `origin` to the first surface within
  /// `max_range_m`, or nothing.
  std::optional<double> cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                             double max_range_m) const;

  /// Smallest plan distance from `point` to any solid reaching heights [z_min, z_max] (m).
  double clearance(const Eigen::Vector2d& point, double z_min_m, double z_max_m,
                   double search_radius_m) const;

 private:
  const World& world_;
  double cell_size_m_;
  Eigen::Vector2d origin_;
  int nx_ = 0, ny_ = 0;
  std::vector<std::vector<int>> cells_;

  const std::vector<int>& cell(int cx, int cy) const {
    return cells_[static_cast<std::size_t>(cy) * nx_ + cx];
  }
};

}  // namespace mm4mm::sim
