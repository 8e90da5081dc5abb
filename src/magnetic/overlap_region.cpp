#include "mm4mm/magnetic/overlap_region.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mm4mm {

PlanarRegion overlapRegion(const MagneticMap& a, const MagneticMap& b,
                           const Eigen::Isometry3d& T_a_b, double margin_m, double cell_size_m) {
  if (!T_a_b.matrix().allFinite())
    throw std::invalid_argument("overlapRegion: T_a_b must be finite");
  if (!std::isfinite(margin_m) || margin_m < 0.0)
    throw std::invalid_argument("overlapRegion: margin_m must be >= 0 (m) and finite");
  if (!std::isfinite(cell_size_m) || cell_size_m <= 0.0)
    throw std::invalid_argument("overlapRegion: cell_size_m must be > 0 (m) and finite");
  const int factor = std::max(1, static_cast<int>(std::lround(cell_size_m / a.cell_size_m)));
  PlanarRegion region;
  region.origin_m = a.origin_m;
  region.cell_size_m = factor * a.cell_size_m;
  region.width = (a.width + factor - 1) / factor;
  region.height = (a.height + factor - 1) / factor;
  region.inside.assign(static_cast<std::size_t>(region.width) * region.height, 0);
  const Eigen::Isometry3d T_b_a = T_a_b.inverse();
  for (int iy = 0; iy < a.height; ++iy) {
    for (int ix = 0; ix < a.width; ++ix) {
      if (!a.covered(ix, iy)) continue;
      const Eigen::Vector2d centre = a.cellCentre(ix, iy);
      const Eigen::Vector3d p_b = T_b_a * Eigen::Vector3d(centre.x(), centre.y(), a.height_m);
      const double jx = std::floor((p_b.x() - b.origin_m.x()) / b.cell_size_m);
      const double jy = std::floor((p_b.y() - b.origin_m.y()) / b.cell_size_m);
      if (!(jx >= 0.0 && jy >= 0.0 && jx < b.width && jy < b.height)) continue;
      if (!b.covered(static_cast<int>(jx), static_cast<int>(jy))) continue;
      region.inside[static_cast<std::size_t>(iy / factor) * region.width + ix / factor] = 1;
    }
  }
  return dilateRegion(region, margin_m);
}

}  // namespace mm4mm
