#include "mm4mm/sim/simulation_config.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace mm4mm::sim {
namespace {

bool fail(std::string* error, const std::string& message) {
  if (error) *error = message;
  return false;
}

}  // namespace

std::string SimulationConfig::layoutMode() const {
  if (layout.mode != "auto") return layout.mode;
  if (world == "procedural") return "random";  // no paper set-up: sessions start anywhere
  return world == "corridor" ? "windows" : "common_start";
}

bool SimulationConfig::IsValid(std::string* error) const {
  if (world != "warehouse" && world != "corridor" && world != "procedural")
    return fail(error,
                "world must be 'warehouse', 'corridor' or 'procedural', got '" + world + "'");
  const auto& buildings = proceduralBuildings();
  if (procedural.building != "any" &&
      std::find(buildings.begin(), buildings.end(), procedural.building) == buildings.end())
    return fail(error,
                "procedural.building must be any, hallway, office, garage, racks or hall, "
                "got '" +
                    procedural.building + "'");
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
  const FloorMeshConfig& mesh = floor_mesh;
  if (!(mesh.bar_spacing_m >= 0.05) || !(mesh.bar_diameter_m > 0.0) ||
      !(mesh.bar_diameter_m < mesh.bar_spacing_m))
    return fail(error,
                "floor_mesh.bar_spacing_m must be >= 0.05 and bar_diameter_m in (0, spacing)");
  if (!(mesh.sheet_length_m > 2.0 * mesh.lap_m) || !(mesh.sheet_width_m > 2.0 * mesh.lap_m) ||
      !(mesh.lap_m >= 0.0))
    return fail(error, "floor_mesh sheets must be longer and wider than two laps, lap_m >= 0");
  if (!(mesh.depth_m > 0.0) || !(mesh.susceptibility >= 0.0) ||
      !(mesh.remanent_magnetisation_A_per_m >= 0.0) || !(mesh.cutoff_radius_m > 0.0))
    return fail(error,
                "floor_mesh.depth_m and cutoff_radius_m must be > 0, susceptibility and "
                "remanent_magnetisation_A_per_m >= 0");
  if (!(floor_steel.density_per_m2 >= 0.0) || !(floor_steel.min_depth_m > 0.0) ||
      !(floor_steel.max_depth_m >= floor_steel.min_depth_m) || !(floor_steel.moment_Am2 >= 0.0))
    return fail(error,
                "floor_steel: density_per_m2 and moment_Am2 must be >= 0, 0 < min_depth_m <= "
                "max_depth_m");
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
  if (rig.preset != "imu" && rig.preset != "husky3" && rig.preset != "array7" &&
      rig.preset != "handheld")
    return fail(error,
                "rig.preset must be imu, husky3, array7 or handheld, got '" + rig.preset + "'");
  if (rig.magnetometer_count < 1) return fail(error, "rig.magnetometer_count must be >= 1");
  if (rig.magnetometer_rate_hz <= 0.0) return fail(error, "rig.magnetometer_rate_hz must be > 0");
  if (rig.magnetometer_noise_uT < 0.0 || rig.magnetometer_bias_uT < 0.0)
    return fail(error, "rig magnetometer noise and bias must be >= 0");
  const MagnetometerErrorConfig& m = magnetometer_errors;
  if (m.model != "realistic" && m.model != "clean")
    return fail(error,
                "magnetometer_errors.model must be 'realistic' or 'clean', got '" + m.model + "'");
  if (!(m.hard_iron_min_uT >= 0.0 && m.hard_iron_max_uT >= m.hard_iron_min_uT &&
        m.hard_iron_max_uT <= 200.0))
    return fail(error,
                "magnetometer_errors: need 0 <= hard_iron_min_uT <= hard_iron_max_uT <= 200");
  if (!(m.soft_iron_min >= 0.0 && m.soft_iron_max >= m.soft_iron_min && m.soft_iron_max <= 0.3))
    return fail(error, "magnetometer_errors: need 0 <= soft_iron_min <= soft_iron_max <= 0.3");
  if (!(m.axis_scale_error_max >= 0.0 && m.axis_scale_error_max <= 0.2) ||
      !(m.misalignment_max_deg >= 0.0 && m.misalignment_max_deg <= 10.0))
    return fail(error,
                "magnetometer_errors: axis_scale_error_max must be in [0, 0.2], "
                "misalignment_max_deg in [0, 10]");
  if (!(m.noise_min_uT >= 0.0 && m.noise_max_uT >= m.noise_min_uT))
    return fail(error, "magnetometer_errors: need 0 <= noise_min_uT <= noise_max_uT");
  if (!(m.current_speed_max_uT_per_mps >= 0.0) ||
      !(m.current_acceleration_max_uT_per_mps2 >= 0.0) || !(m.drift_uT >= 0.0) ||
      !(m.drift_time_constant_s > 0.0))
    return fail(error,
                "magnetometer_errors: current gains and drift_uT must be >= 0, "
                "drift_time_constant_s > 0");
  if (change.first_session < 0) return fail(error, "change.first_session must be >= 0");
  const auto boxes_valid = [](const std::vector<std::vector<double>>& boxes) {
    return std::all_of(boxes.begin(), boxes.end(), [](const std::vector<double>& box) {
      return box.size() == 4 &&
             std::all_of(box.begin(), box.end(), [](double v) { return std::isfinite(v); }) &&
             box[0] < box[2] && box[1] < box[3];
    });
  };
  if (!boxes_valid(change.removed_m) || !boxes_valid(change.added_m))
    return fail(error,
                "change.removed_m and change.added_m entries must be [x_min, y_min, x_max, y_max] "
                "with min < max");
  if (change.first_session > 0 && change.removed_m.empty() && change.added_m.empty())
    return fail(error, "change.first_session is set but change.removed_m and added_m are empty");
  if (change.first_session == 0 && (!change.removed_m.empty() || !change.added_m.empty()))
    return fail(error,
                "change.removed_m or added_m is set but change.first_session is 0 (no change): "
                "say which session is the first after the change");
  for (const auto& r : change.removed_m)
    for (const auto& a : change.added_m)
      if (r[0] < a[2] && a[0] < r[2] && r[1] < a[3] && a[1] < r[3])
        return fail(error, "change.removed_m and change.added_m boxes must not overlap");
  if (!(change.truth_cell_m >= 0.05 && change.truth_cell_m <= 2.0) ||
      !(change.truth_margin_m >= 0.0) || !(change.truth_threshold_uT > 0.0))
    return fail(error,
                "change: truth_cell_m must be in [0.05, 2], truth_margin_m >= 0, "
                "truth_threshold_uT > 0");
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
  if (!(motion.sway_lateral_m >= 0.0 && motion.sway_lateral_m <= 0.5) ||
      !(motion.sway_vertical_m >= 0.0 && motion.sway_vertical_m <= 0.5) ||
      !(motion.step_frequency_hz > 0.0) ||
      !(motion.calibration_turns >= 0.0 && motion.calibration_turns <= 10.0))
    return fail(error,
                "motion.sway_lateral_m and sway_vertical_m must be in [0, 0.5], "
                "step_frequency_hz > 0, calibration_turns in [0, 10]");
  if (odometry.scale_error_max < 0.0 || odometry.translation_noise_m_per_sqrt_m < 0.0 ||
      odometry.yaw_noise_deg_per_sqrt_m < 0.0 || odometry.yaw_bias_deg_per_100m_max < 0.0)
    return fail(error, "odometry noise settings must be >= 0");
  if (!(odometry.attitude_error_min_deg >= 0.0 &&
        odometry.attitude_error_max_deg >= odometry.attitude_error_min_deg) ||
      !(odometry.attitude_error_time_constant_s > 0.0))
    return fail(error,
                "odometry: need 0 <= attitude_error_min_deg <= attitude_error_max_deg and "
                "attitude_error_time_constant_s > 0");
  if (!(odometry.degenerate_scale_error_max >= 0.0) ||
      !(odometry.degenerate_noise_m_per_sqrt_m >= 0.0))
    return fail(error, "odometry degenerate drift settings must be >= 0");
  if (!(odometry.pose_rate_hz >= 1.0 && odometry.pose_rate_hz <= 1000.0))
    return fail(error, "odometry.pose_rate_hz must be in [1, 1000]");
  if (layout.route_length_m < 10.0) return fail(error, "layout.route_length_m must be >= 10");
  if (layout.window_length_m < 10.0 || layout.window_spacing_m <= 0.0)
    return fail(error, "layout.window_length_m must be >= 10 and window_spacing_m > 0");
  return true;
}

void applyRigPreset(const std::string& preset, SimulationConfig* config) {
  RigConfig& rig = config->rig;
  const RigConfig defaults;
  MotionConfig& motion = config->motion;
  const MotionConfig walking_defaults;
  if (preset == "imu") {
    rig.magnetometer_count = 1;
    rig.magnetometer_height_m = defaults.magnetometer_height_m;
    rig.lidar_height_m = defaults.lidar_height_m;
  } else if (preset == "husky3" || preset == "array7") {
    rig.magnetometer_count = preset == "husky3" ? 3 : 7;
    rig.magnetometer_spacing_m = 0.5;
    rig.magnetometer_height_m = defaults.magnetometer_height_m;
    rig.lidar_height_m = defaults.lidar_height_m;
  } else if (preset == "handheld") {
    rig.magnetometer_count = 1;
    rig.magnetometer_height_m = 1.1;
    rig.lidar_height_m = 1.3;
    motion.speed_mps = 1.2;
    motion.turn_rate_dps = 60.0;
    motion.corner_radius_m = 0.5;
    motion.tilt_amplitude_deg = 10.0;
    motion.sway_lateral_m = 0.04;
    motion.sway_vertical_m = 0.03;
    motion.step_frequency_hz = walking_defaults.step_frequency_hz;
  } else {
    throw std::invalid_argument("rig.preset must be imu, husky3, array7 or handheld, got '" +
                                preset + "'");
  }
  rig.preset = preset;
}

}  // namespace mm4mm::sim
