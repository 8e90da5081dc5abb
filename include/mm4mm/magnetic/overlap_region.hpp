#pragma once
// The region two sessions' magnetic maps share under a transform: where ICP-EM looks for point
// pairs (paper Section III-B.2).

#include <Eigen/Geometry>

#include "mm4mm/core/planar_region.hpp"
#include "mm4mm/magnetic/magnetic_map.hpp"

namespace mm4mm {

/// Where the two sessions' point maps can overlap, as delimited by the magnetic association
/// (paper Section III-B.2): the cells of a's grid covered by a's magnetic map whose centre,
/// mapped into b by T_a_b^-1, falls in a cell covered by b's, grouped into cells of about
/// `cell_size_m` (an integer number of a's cells) and dilated by `margin_m`. The margin matters:
/// the magnetometers sweep a strip a few metres wide, while the LiDAR sees walls and shelves
/// many metres away from it. Cost: one transform per cell of a's grid. Throws
/// std::invalid_argument for a non-finite T_a_b, a negative margin or a non-positive cell size.
PlanarRegion overlapRegion(const MagneticMap& a, const MagneticMap& b,
                           const Eigen::Isometry3d& T_a_b, double margin_m = 8.0,
                           double cell_size_m = 0.25);

}  // namespace mm4mm
