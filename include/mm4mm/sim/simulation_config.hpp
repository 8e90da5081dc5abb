#pragma once
// Settings of the simulator. Every field has a default; YAML presets in configs/ override them and
// mirror this nesting. Units are in the field names or comments.

#include <string>
#include <vector>

namespace mm4mm::sim {

/// The Earth's main field, constant over a building.
struct EarthFieldConfig {
  double magnitude_uT = 45.0;
  double inclination_deg = 55.0;  ///< dip below the horizon (northern hemisphere: positive)
  double declination_deg = 20.0;  ///< heading of magnetic north from the world x axis
};

/// Smooth building-scale variation: sum of harmonic potentials whose sources lie below the floor.
struct BackgroundFieldConfig {
  int components = 10;
  double amplitude_uT = 1.5;  ///< per component, field magnitude at floor level
  double min_wavelength_m = 15.0;
  double max_wavelength_m = 60.0;
};

/// Magnetic dipoles of structural steel: every steel member (pillar rebar cage, shelf upright,
/// shelf beam) is a chain of dipoles. Each member has an induced moment along the Earth's field
/// and a seeded random remanent one, so that geometrically identical places differ magnetically.
struct SteelConfig {
  double dipole_spacing_m = 0.5;             ///< along every steel member
  double pillar_induced_moment_Am2 = 6.0;    ///< per dipole, along the Earth's field
  double pillar_remanent_moment_Am2 = 12.0;  ///< std-dev per axis, one draw per pillar
  double upright_induced_moment_Am2 = 4.0;
  double upright_remanent_moment_Am2 = 8.0;
  double beam_induced_moment_Am2 = 4.0;
  double beam_remanent_moment_Am2 = 8.0;
  double moment_jitter = 0.3;     ///< relative per-dipole variation along a member
  double cutoff_radius_m = 25.0;  ///< farther dipoles are skipped; adds ~0.1 µT error
};

/// The reinforcement of a concrete floor as it is laid: welded mesh sheets of straight bars in
/// both directions, overlapping at their laps, a few centimetres below the surface. A bar
/// magnetised along its axis (the Earth's field induces it, handling leaves a remanent part) has
/// no field outside but at its ends, where its magnetisation ends as a magnetic charge
/// q = M · A (A·m); so the floor's field lines up along the sheets' edges and laps and repeats
/// with the sheets, and the random remanence of each bar breaks the repetition.
struct FloorMeshConfig {
  bool enabled = true;
  double bar_spacing_m = 0.2;  ///< between parallel bars of a sheet (0.15-0.3 m is usual)
  double bar_diameter_m = 0.010;
  double sheet_length_m = 4.8;    ///< along x
  double sheet_width_m = 2.4;     ///< along y
  double lap_m = 0.3;             ///< sheets overlap by this much at their edges
  double depth_m = 0.04;          ///< below the floor surface (the concrete cover)
  double susceptibility = 150.0;  ///< effective, along a long thin bar
  double remanent_magnetisation_A_per_m = 20000.0;  ///< std-dev along each bar, one draw per bar
  double cutoff_radius_m = 6.0;                     ///< farther bar ends are skipped
};

/// Sparse irregular steel in and on the floor (anchors, plates, conduit, drains): dipoles at
/// random places, random moments.
struct FloorSteelConfig {
  double density_per_m2 = 0.2;
  double min_depth_m = 0.05;
  double max_depth_m = 0.3;
  double moment_Am2 = 4.0;  ///< std-dev per axis
};

/// 85 m x 75 m hall: rows of identical double-sided steel shelves, concrete pillars at row ends.
struct WarehouseConfig {
  double size_x_m = 85.0;
  double size_y_m = 75.0;
  double height_m = 10.0;
  double wall_thickness_m = 0.3;
  int shelf_rows = 9;
  int shelf_blocks = 2;  ///< blocks of shelves along x, separated by cross aisles
  int bays_per_block = 11;
  double bay_width_m = 2.7;
  double rack_depth_m = 1.1;   ///< one side of a double-sided row
  double rack_gap_m = 0.2;     ///< between the two sides of a row
  double aisle_width_m = 4.0;  ///< between rows
  double cross_aisle_width_m = 5.6;
  std::vector<double> shelf_levels_m{0.15, 1.6, 3.05, 4.5};
  double shelf_top_m = 6.0;
  double upright_size_m = 0.1;
  double goods_fill = 0.8;  ///< fraction of a bay filled by the goods box on each level
  double pillar_size_m = 0.6;
  double pillar_offset_from_rows_m = 0.2;  ///< gap between a row's end and its pillar
};

/// 173 m x 20 m corridor: straight walls, two rows of octagonal pillars.
struct CorridorConfig {
  double length_m = 173.0;
  double width_m = 20.0;
  double height_m = 4.5;
  double wall_thickness_m = 0.3;
  double pillar_spacing_m = 8.0;
  double pillar_radius_m = 0.4;
  int pillar_sides = 8;
  std::vector<double> pillar_rows_y_m{6.67, 13.33};
  /// x ranges [from, to] without pillars (a stretch where geometry cannot fix position along x).
  std::vector<std::vector<double>> pillar_free_ranges_m;
};

/// Buildings the benchmarks were not built around (procedural_world.cpp): the building type, its
/// plan, its contents and its steel are all drawn from the world's seed, within ranges stated
/// beside each builder, so tuning seeds and held-out seeds see different buildings.
struct ProceduralConfig {
  /// "any" (one of the others, drawn from the seed), "hallway" (a corridor with rooms off it),
  /// "office" (two corridors joined by cross corridors, rooms on every side), "garage" (parking
  /// aisles, pillars, parked cars), "racks" (rack aisles of drawn dimensions), "hall" (an open
  /// hall with columns and machines).
  std::string building = "any";
  /// Draw the floor's reinforcement and sparse steel per world from wide ranges (how buildings
  /// differ) instead of taking floor_mesh and floor_steel as given.
  bool draw_floor_steel = true;
};

/// The sensor rig: magnetometers in a lateral row and an HDL-32E-like LiDAR. `preset` names one
/// of the rigs of applyRigPreset; the other fields then hold that rig.
struct RigConfig {
  std::string preset = "imu";
  int magnetometer_count = 1;
  double magnetometer_spacing_m = 0.5;
  double magnetometer_height_m = 0.3;
  double magnetometer_rate_hz = 20.0;
  double magnetometer_noise_uT = 0.2;  ///< clean model: white noise std-dev per axis
  double magnetometer_bias_uT = 0.3;   ///< clean model: constant per-sensor, per-axis bias std-dev
  double lidar_height_m = 0.8;
};

/// What a real magnetometer on a real robot reads besides the field (magnetometer_model.hpp).
/// Every quantity is drawn per session and sensor: a session is another robot, or the same one
/// with its sensor remounted. "clean" keeps only the rig's white noise and small bias.
struct MagnetometerErrorConfig {
  std::string model = "realistic";  ///< "realistic" or "clean"
  double hard_iron_min_uT = 2.0;    ///< magnitude drawn uniformly in [min, max], any direction
  double hard_iron_max_uT = 15.0;
  /// Soft iron: a symmetric matrix I + E whose eigenvalue deviations are drawn in ±d, with d
  /// drawn in [min, max] per sensor, along random axes.
  double soft_iron_min = 0.03;
  double soft_iron_max = 0.10;
  double axis_scale_error_max = 0.02;  ///< per-axis gain error drawn in ±max
  double misalignment_max_deg = 0.5;   ///< non-orthogonality of the axes, drawn in ±max
  double noise_min_uT = 0.2;           ///< white noise std-dev per axis, drawn in [min, max]
  double noise_max_uT = 1.0;
  /// The drive current's field, along a random body direction: a gain per m/s of forward speed
  /// and one per m/s² of acceleration, each drawn in [0, max].
  double current_speed_max_uT_per_mps = 3.0;
  double current_acceleration_max_uT_per_mps2 = 2.0;
  double drift_uT = 0.3;  ///< std-dev of the slow offset drift (thermal), per axis
  double drift_time_constant_s = 600.0;
};

struct LidarConfig {
  bool enabled = true;  ///< false: magnetic-only sessions (no scans/)
  int beams = 32;
  double min_elevation_deg = -30.67;
  double max_elevation_deg = 10.67;
  double azimuth_step_deg = 0.72;
  double min_range_m = 0.5;
  double max_range_m = 80.0;
  double range_noise_m = 0.02;
};

struct MotionConfig {
  double speed_mps = 1.0;
  double turn_rate_dps = 30.0;  ///< turning in place
  double corner_radius_m = 1.0;
  double tilt_amplitude_deg = 0.8;  ///< roll/pitch jitter
  double keyframe_distance_m = 1.0;
  double keyframe_angle_deg = 20.0;
  /// A person walking with the device: the body sways sideways and bobs with each step.
  double sway_lateral_m = 0.0;
  double sway_vertical_m = 0.0;
  double step_frequency_hz = 1.8;
  /// Full turns in place before the session drives off, as many robots do to calibrate their
  /// IMU: a magnetometer at the turning centre then reads one place at every heading.
  double calibration_turns = 0.0;
};

/// Drift of a good LiDAR-inertial odometry.
struct OdometryConfig {
  double scale_error_max = 0.002;  ///< per-session scale error drawn in [-max, max]
  double translation_noise_m_per_sqrt_m = 0.003;
  double yaw_noise_deg_per_sqrt_m = 0.02;
  double yaw_bias_deg_per_100m_max = 0.1;  ///< per-session constant yaw-rate bias
  /// Roll and pitch as an IMU estimates them: the truth plus a slowly varying error whose
  /// std-dev is drawn per session in [min, max].
  double attitude_error_min_deg = 0.1;
  double attitude_error_max_deg = 0.5;
  double attitude_error_time_constant_s = 5.0;
  /// Where the scans constrain nothing along an axis (a featureless stretch of corridor), the
  /// odometry drifts along it: a per-session scale error drawn in ±max and a random walk.
  double degenerate_scale_error_max = 0.03;
  double degenerate_noise_m_per_sqrt_m = 0.02;
  double pose_rate_hz = 50.0;  ///< of the full pose stream (odometry.txt)
};

/// Where the sessions start and which parts of the world they cover.
struct LayoutConfig {
  /// "auto" (the world's paper set-up), "common_start" (all start near one place, yaw stepped),
  /// "windows" (each covers an x window, starts spaced along x), or "random" (any pose).
  std::string mode = "auto";
  double route_length_m = 250.0;  ///< common_start and random
  double start_offset_x_m = 0.2;  ///< common_start: between consecutive sessions
  double start_yaw_step_deg = 180.0;
  double window_spacing_m = 55.0;  ///< windows: between consecutive session starts
  double window_length_m = 62.0;
  /// Adds one extra session (the last) whose route overlaps no other session.
  bool disjoint_session = false;
};

/// A building changed between sessions (issue 18): steel and what stands with it taken away or
/// brought in. Sessions from `first_session` on are recorded after the change, the earlier ones
/// before it. The routes are planned in the unchanged lanes, so no session drives through what a
/// change brings in: an object brought in is one the world has (a shelf section, a rack) that the
/// sessions before the change do not see. A move is a box of each. What the change does to the
/// field is written beside the sessions as its ground truth (sim/world_change.hpp).
struct ChangeConfig {
  /// 0: no change (every session sees the whole world).
  int first_session = 0;
  /// Plan boxes [x_min, y_min, x_max, y_max] (world, m). Every steel dipole above the floor and
  /// every solid wholly inside a box belongs to it; the floor's reinforcement and sparse floor
  /// steel stay.
  std::vector<std::vector<double>> removed_m;  ///< standing before the change, gone after it
  std::vector<std::vector<double>> added_m;    ///< absent before the change, standing after it
  /// The ground truth's grid: |ΔB| at the magnetometers' height on cells of this size over the
  /// boxes dilated by `truth_margin_m`; a cell whose (ΔB_h, ΔB_v) reaches `truth_threshold_uT`
  /// counts as changed (the detector's floor, merge/magnetic_change.hpp).
  double truth_cell_m = 0.25;
  double truth_margin_m = 10.0;
  double truth_threshold_uT = 1.0;
};

struct SimulationConfig {
  std::string world = "warehouse";  ///< "warehouse", "corridor" or "procedural"
  EarthFieldConfig earth;
  BackgroundFieldConfig background;
  SteelConfig steel;
  FloorMeshConfig floor_mesh;
  FloorSteelConfig floor_steel;
  WarehouseConfig warehouse;
  CorridorConfig corridor;
  ProceduralConfig procedural;
  RigConfig rig;
  MagnetometerErrorConfig magnetometer_errors;
  LidarConfig lidar;
  MotionConfig motion;
  OdometryConfig odometry;
  LayoutConfig layout;
  ChangeConfig change;

  /// The layout mode after resolving "auto" for this world.
  std::string layoutMode() const;
  /// False with a message naming the first bad field.
  bool IsValid(std::string* error) const;
};

/// The building types of ProceduralConfig::building besides "any".
const std::vector<std::string>& proceduralBuildings();

/// Sets `config`'s rig (and, for the handheld device, its motion) to a named preset:
///   imu       one IMU's magnetometer at 0.3 m (the default rig);
///   husky3    three IMUs in a lateral row 0.5 m apart, as on the paper's real Husky A200;
///   array7    the paper's simulated array: seven magnetometers in a lateral row 0.5 m apart;
///   handheld  one magnetometer in a hand-held device at 1.1 m, carried at walking pace with
///             sway, step bob and ±10° of pitch and roll.
/// Throws std::invalid_argument for an unknown name.
void applyRigPreset(const std::string& preset, SimulationConfig* config);

}  // namespace mm4mm::sim
