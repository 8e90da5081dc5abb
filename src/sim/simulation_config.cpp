#include "mm4mm/sim/simulation_config.hpp"

namespace mm4mm::sim {
namespace {

bool fail(std::string* error, const std::string& message) {
  if (error) *error = message;
  return false;
}

}  // namespace

std::string SimulationConfig::layoutMode() const {
  if (layout.mode != "auto") return layout.mode;
  return world == "corridor" ? "windows" : "common_start";
}

bool SimulationConfig::IsValid(std::string* error) const {
  if (world != "warehouse" && world != "corridor")
    return fail(error, "world must be 'warehouse' or 'corridor', got '" + world + "'");
  const std::string mode = layoutMode();
  if (mode != "common_start" && mode != "windows" && mode != "random")
    return fail(error, "layout.mode must be auto, common_start, windows or random, got '" +
                           layout.mode + "'");
  if (mode == "windows" && world != "corridor")
    return fail(error, "layout.mode 'windows' needs world 'corridor'");
  if (earth.magnitude_uT <= 0.0 || earth.magnitude_uT > 100.0)
    return fail(error, "earth.magnitude_uT must be in (0, 100]");
  if (background.components < 0) return fail(error, "background.components must be >= 0");
  if (background.min_wavelength_m <= 0.0 ||
      background.max_wavelength_m < background.min_wavelength_m)
    return fail(error, "background wavelengths must satisfy 0 < min <= max");
  if (steel.dipole_spacing_m <= 0.0) return fail(error, "steel.dipole_spacing_m must be > 0");
  if (steel.floor_rebar_spacing_m < 0.0 || steel.floor_rebar_depth_m <= 0.0)
    return fail(error, "steel.floor_rebar_spacing_m must be >= 0 and floor_rebar_depth_m > 0");
  if (steel.cutoff_radius_m <= 0.0) return fail(error, "steel.cutoff_radius_m must be > 0");
  const WarehouseConfig& w = warehouse;
  if (w.shelf_rows < 1 || w.shelf_blocks < 1 || w.bays_per_block < 1)
    return fail(error, "warehouse shelf_rows, shelf_blocks and bays_per_block must be >= 1");
  const double rows_extent =
      w.shelf_rows * (2.0 * w.rack_depth_m + w.rack_gap_m) + (w.shelf_rows - 1) * w.aisle_width_m;
  if (rows_extent + 2.0 * (w.pillar_size_m + 8.0) > w.size_y_m)
    return fail(error, "warehouse.size_y_m is too small for its shelf rows and perimeter lanes");
  const double blocks_extent = w.shelf_blocks * w.bays_per_block * w.bay_width_m +
                               (w.shelf_blocks - 1) * w.cross_aisle_width_m;
  if (blocks_extent + 2.0 * (w.pillar_size_m + 8.0) > w.size_x_m)
    return fail(error, "warehouse.size_x_m is too small for its shelf blocks and perimeter lanes");
  if (w.cross_aisle_width_m < 2.0 * (w.pillar_size_m + w.pillar_offset_from_rows_m) + 3.0)
    return fail(error, "warehouse.cross_aisle_width_m leaves no lane between the pillars");
  if (corridor.length_m < 20.0 || corridor.width_m < 10.0)
    return fail(error, "corridor must be at least 20 m long and 10 m wide");
  if (corridor.pillar_sides < 3) return fail(error, "corridor.pillar_sides must be >= 3");
  for (const auto& range : corridor.pillar_free_ranges_m)
    if (range.size() != 2 || range[1] < range[0])
      return fail(error,
                  "corridor.pillar_free_ranges_m entries must be [from, to] with from <= to");
  if (rig.magnetometer_count < 1) return fail(error, "rig.magnetometer_count must be >= 1");
  if (rig.magnetometer_rate_hz <= 0.0) return fail(error, "rig.magnetometer_rate_hz must be > 0");
  if (rig.magnetometer_noise_uT < 0.0 || rig.magnetometer_bias_uT < 0.0)
    return fail(error, "rig magnetometer noise and bias must be >= 0");
  if (lidar.beams < 1) return fail(error, "lidar.beams must be >= 1");
  if (lidar.azimuth_step_deg <= 0.0 || lidar.azimuth_step_deg > 45.0)
    return fail(error, "lidar.azimuth_step_deg must be in (0, 45]");
  if (lidar.max_range_m <= lidar.min_range_m)
    return fail(error, "lidar.max_range_m must exceed lidar.min_range_m");
  if (motion.speed_mps <= 0.0 || motion.turn_rate_dps <= 0.0)
    return fail(error, "motion.speed_mps and motion.turn_rate_dps must be > 0");
  if (motion.keyframe_distance_m <= 0.0 || motion.keyframe_angle_deg <= 0.0)
    return fail(error, "motion keyframe distance and angle must be > 0");
  if (motion.corner_radius_m < 0.0) return fail(error, "motion.corner_radius_m must be >= 0");
  if (odometry.scale_error_max < 0.0 || odometry.translation_noise_m_per_sqrt_m < 0.0 ||
      odometry.yaw_noise_deg_per_sqrt_m < 0.0 || odometry.yaw_bias_deg_per_100m_max < 0.0)
    return fail(error, "odometry noise settings must be >= 0");
  if (layout.route_length_m < 10.0) return fail(error, "layout.route_length_m must be >= 10");
  if (layout.window_length_m < 10.0 || layout.window_spacing_m <= 0.0)
    return fail(error, "layout.window_length_m must be >= 10 and window_spacing_m > 0");
  return true;
}

}  // namespace mm4mm::sim
