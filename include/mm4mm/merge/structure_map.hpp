#pragma once
// A session's walls as a 2-D grid the magnetic matcher can search: the geometry-only fallback for
// a session without magnetometer readings. The scans of the session's keyframes, cut to a height
// band around the LiDAR and flattened onto its plane, are ray-cast into an OctoMap occupancy grid;
// each cell the rays observed (free or occupied) is covered and holds its occupancy probability.
// The correlation search, the PSO refinement and the confidence rule then run on these grids as
// on magnetic maps (StructureMap::asMatchGrid): every channel carries the occupancy, so any of
// them correlates walls with walls (MergeConfig::geometry_matcher reads one). In repetitive
// geometry the rule sees several equal modes and answers "ambiguous", which is the point of
// matching by the field there.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "mm4mm/magnetic/magnetic_map.hpp"
#include "mm4mm/session/session.hpp"

namespace mm4mm {

struct StructureMapConfig {
  double cell_size_m = 0.2;
  /// Returns between these heights relative to the LiDAR (m) are kept: walls, pillars and
  /// shelves, not the floor or the ceiling.
  double band_below_lidar_m = 0.3;
  double band_above_lidar_m = 1.7;
  double max_range_m = 30.0;  ///< longer returns clear space up to here and mark nothing
  /// Scans of keyframes closer than this to the last one used are skipped (m): neighbouring
  /// keyframes see the same walls, and ray casting is the cost.
  double keyframe_spacing_m = 1.0;

  bool IsValid(std::string* error) const;
};

/// A session's walls on a grid in its own frame. Cell (ix, iy) covers [origin + (ix, iy) * cell,
/// origin + (ix+1, iy+1) * cell), as a MagneticMap's cells do.
struct StructureMap {
  Eigen::Vector2d origin_m = Eigen::Vector2d::Zero();
  double cell_size_m = 0.2;
  int width = 0;
  int height = 0;
  double lidar_height_m = 0.0;  ///< the LiDAR's mean height over the scans used
  /// OctoMap occupancy probability in [0.12, 0.97], row-major (iy * width + ix); NaN where no ray
  /// passed.
  std::vector<float> occupancy;

  std::size_t observedCells() const;
  /// The grid as the magnetic matcher and overlapRegion take it: the occupancy in every channel
  /// but session_y (zero), the LiDAR's height as the map's.
  MagneticMap asMatchGrid() const;
};

/// The structure grid of `session` in its own frame (see the file comment). A session without
/// scans gives an empty grid. Throws std::invalid_argument for an invalid config.
StructureMap buildStructureMap(const Session& session, const StructureMapConfig& config = {});

}  // namespace mm4mm
