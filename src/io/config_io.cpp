#include "mm4mm/io/config_io.hpp"

#include <yaml-cpp/yaml.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "mm4mm/io/input_error.hpp"

namespace mm4mm {
namespace {

// Reads the keys of one YAML map into fields, remembering which keys it knew so that the rest
// can be reported as unknown.
class Section {
 public:
  Section(const YAML::Node& node, std::string path, std::string file)
      : node_(node), path_(std::move(path)), file_(std::move(file)) {
    if (node_ && !node_.IsMap()) throw error(node_, "'" + path_ + "' must be a map");
  }

  template <typename T>
  Section& field(const char* key, T* value) {
    known_.insert(key);
    if (!node_) return *this;
    const YAML::Node child = node_[key];
    if (!child) return *this;
    try {
      *value = child.as<T>();
    } catch (const YAML::Exception&) {
      throw error(child, "'" + qualified(key) + "' has the wrong type");
    }
    return *this;
  }

  Section section(const char* key) {
    known_.insert(key);
    // An absent parent gives an absent child (YAML::Node() would be a present null node).
    return Section(node_ ? node_[key] : node_, qualified(key), file_);
  }

  void rejectUnknownKeys() const {
    if (!node_) return;
    for (const auto& entry : node_) {
      // A complex key ("? [a, b]: 1") is valid YAML but no setting (found by fuzz_config).
      if (!entry.first.IsScalar())
        throw error(entry.first, "'" + (path_.empty() ? std::string("the top level") : path_) +
                                     "' has a key that is not a plain name");
      const std::string key = entry.first.as<std::string>();
      if (!known_.count(key))
        throw error(entry.first, "unknown key '" + qualified(key.c_str()) + "'");
    }
  }

 private:
  std::string qualified(const char* key) const { return path_.empty() ? key : path_ + "." + key; }
  InputError error(const YAML::Node& at, const std::string& problem) const {
    return InputError(file_, at.Mark().line + 1, problem);
  }

  YAML::Node node_;
  std::string path_;
  std::string file_;
  std::set<std::string> known_;
};

YAML::Node loadYaml(const std::string& file) {
  if (!std::filesystem::is_regular_file(file)) throw InputError(file, 0, "no such config file");
  try {
    return YAML::LoadFile(file);
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.line + 1, "not valid YAML: " + e.msg);
  }
}

// Enumerations are written by name in YAML.
template <typename Enum>
void readEnum(Section& section, const char* key, Enum* value,
              const std::vector<std::pair<std::string, Enum>>& names, const std::string& file) {
  std::string name;
  for (const auto& [n, v] : names)
    if (v == *value) name = n;
  section.field(key, &name);
  for (const auto& [n, v] : names)
    if (n == name) {
      *value = v;
      return;
    }
  std::string allowed;
  for (const auto& [n, v] : names) allowed += (allowed.empty() ? "" : ", ") + n;
  throw InputError(file, 0,
                   std::string("'") + key + "' must be one of " + allowed + ", got '" + name + "'");
}

}  // namespace

sim::SimulationConfig loadSimulationConfig(const std::filesystem::path& path,
                                           sim::SimulationConfig c) {
  const std::string file = path.string();
  const YAML::Node root = loadYaml(file);
  if (root.IsNull()) return c;

  Section top(root, "", file);
  top.field("world", &c.world);
  Section earth = top.section("earth");
  earth.field("magnitude_uT", &c.earth.magnitude_uT)
      .field("inclination_deg", &c.earth.inclination_deg)
      .field("declination_deg", &c.earth.declination_deg)
      .rejectUnknownKeys();
  Section background = top.section("background");
  background.field("components", &c.background.components)
      .field("amplitude_uT", &c.background.amplitude_uT)
      .field("min_wavelength_m", &c.background.min_wavelength_m)
      .field("max_wavelength_m", &c.background.max_wavelength_m)
      .rejectUnknownKeys();
  Section steel = top.section("steel");
  steel.field("dipole_spacing_m", &c.steel.dipole_spacing_m)
      .field("pillar_induced_moment_Am2", &c.steel.pillar_induced_moment_Am2)
      .field("pillar_remanent_moment_Am2", &c.steel.pillar_remanent_moment_Am2)
      .field("upright_induced_moment_Am2", &c.steel.upright_induced_moment_Am2)
      .field("upright_remanent_moment_Am2", &c.steel.upright_remanent_moment_Am2)
      .field("beam_induced_moment_Am2", &c.steel.beam_induced_moment_Am2)
      .field("beam_remanent_moment_Am2", &c.steel.beam_remanent_moment_Am2)
      .field("moment_jitter", &c.steel.moment_jitter)
      .field("cutoff_radius_m", &c.steel.cutoff_radius_m)
      .rejectUnknownKeys();
  Section mesh = top.section("floor_mesh");
  mesh.field("enabled", &c.floor_mesh.enabled)
      .field("bar_spacing_m", &c.floor_mesh.bar_spacing_m)
      .field("bar_diameter_m", &c.floor_mesh.bar_diameter_m)
      .field("sheet_length_m", &c.floor_mesh.sheet_length_m)
      .field("sheet_width_m", &c.floor_mesh.sheet_width_m)
      .field("lap_m", &c.floor_mesh.lap_m)
      .field("depth_m", &c.floor_mesh.depth_m)
      .field("susceptibility", &c.floor_mesh.susceptibility)
      .field("remanent_magnetisation_A_per_m", &c.floor_mesh.remanent_magnetisation_A_per_m)
      .field("cutoff_radius_m", &c.floor_mesh.cutoff_radius_m)
      .rejectUnknownKeys();
  Section floor_steel = top.section("floor_steel");
  floor_steel.field("density_per_m2", &c.floor_steel.density_per_m2)
      .field("min_depth_m", &c.floor_steel.min_depth_m)
      .field("max_depth_m", &c.floor_steel.max_depth_m)
      .field("moment_Am2", &c.floor_steel.moment_Am2)
      .rejectUnknownKeys();
  Section warehouse = top.section("warehouse");
  auto& w = c.warehouse;
  warehouse.field("size_x_m", &w.size_x_m)
      .field("size_y_m", &w.size_y_m)
      .field("height_m", &w.height_m)
      .field("wall_thickness_m", &w.wall_thickness_m)
      .field("shelf_rows", &w.shelf_rows)
      .field("shelf_blocks", &w.shelf_blocks)
      .field("bays_per_block", &w.bays_per_block)
      .field("bay_width_m", &w.bay_width_m)
      .field("rack_depth_m", &w.rack_depth_m)
      .field("rack_gap_m", &w.rack_gap_m)
      .field("aisle_width_m", &w.aisle_width_m)
      .field("cross_aisle_width_m", &w.cross_aisle_width_m)
      .field("shelf_levels_m", &w.shelf_levels_m)
      .field("shelf_top_m", &w.shelf_top_m)
      .field("upright_size_m", &w.upright_size_m)
      .field("goods_fill", &w.goods_fill)
      .field("pillar_size_m", &w.pillar_size_m)
      .field("pillar_offset_from_rows_m", &w.pillar_offset_from_rows_m)
      .rejectUnknownKeys();
  Section corridor = top.section("corridor");
  corridor.field("length_m", &c.corridor.length_m)
      .field("width_m", &c.corridor.width_m)
      .field("height_m", &c.corridor.height_m)
      .field("wall_thickness_m", &c.corridor.wall_thickness_m)
      .field("pillar_spacing_m", &c.corridor.pillar_spacing_m)
      .field("pillar_radius_m", &c.corridor.pillar_radius_m)
      .field("pillar_sides", &c.corridor.pillar_sides)
      .field("pillar_rows_y_m", &c.corridor.pillar_rows_y_m)
      .field("pillar_free_ranges_m", &c.corridor.pillar_free_ranges_m)
      .rejectUnknownKeys();
  Section rig = top.section("rig");
  // The preset first, so that the keys beside it adjust the rig it names.
  std::string preset = c.rig.preset;
  rig.field("preset", &preset);
  if (preset != c.rig.preset) {
    try {
      sim::applyRigPreset(preset, &c);
    } catch (const std::invalid_argument& e) {
      throw InputError(file, root["rig"]["preset"].Mark().line + 1, e.what());
    }
  }
  rig.field("magnetometer_count", &c.rig.magnetometer_count)
      .field("magnetometer_spacing_m", &c.rig.magnetometer_spacing_m)
      .field("magnetometer_height_m", &c.rig.magnetometer_height_m)
      .field("magnetometer_rate_hz", &c.rig.magnetometer_rate_hz)
      .field("magnetometer_noise_uT", &c.rig.magnetometer_noise_uT)
      .field("magnetometer_bias_uT", &c.rig.magnetometer_bias_uT)
      .field("lidar_height_m", &c.rig.lidar_height_m)
      .rejectUnknownKeys();
  Section errors = top.section("magnetometer_errors");
  auto& m = c.magnetometer_errors;
  errors.field("model", &m.model)
      .field("hard_iron_min_uT", &m.hard_iron_min_uT)
      .field("hard_iron_max_uT", &m.hard_iron_max_uT)
      .field("soft_iron_min", &m.soft_iron_min)
      .field("soft_iron_max", &m.soft_iron_max)
      .field("axis_scale_error_max", &m.axis_scale_error_max)
      .field("misalignment_max_deg", &m.misalignment_max_deg)
      .field("noise_min_uT", &m.noise_min_uT)
      .field("noise_max_uT", &m.noise_max_uT)
      .field("current_speed_max_uT_per_mps", &m.current_speed_max_uT_per_mps)
      .field("current_acceleration_max_uT_per_mps2", &m.current_acceleration_max_uT_per_mps2)
      .field("drift_uT", &m.drift_uT)
      .field("drift_time_constant_s", &m.drift_time_constant_s)
      .rejectUnknownKeys();
  Section lidar = top.section("lidar");
  lidar.field("enabled", &c.lidar.enabled)
      .field("beams", &c.lidar.beams)
      .field("min_elevation_deg", &c.lidar.min_elevation_deg)
      .field("max_elevation_deg", &c.lidar.max_elevation_deg)
      .field("azimuth_step_deg", &c.lidar.azimuth_step_deg)
      .field("min_range_m", &c.lidar.min_range_m)
      .field("max_range_m", &c.lidar.max_range_m)
      .field("range_noise_m", &c.lidar.range_noise_m)
      .rejectUnknownKeys();
  Section motion = top.section("motion");
  motion.field("speed_mps", &c.motion.speed_mps)
      .field("turn_rate_dps", &c.motion.turn_rate_dps)
      .field("corner_radius_m", &c.motion.corner_radius_m)
      .field("tilt_amplitude_deg", &c.motion.tilt_amplitude_deg)
      .field("keyframe_distance_m", &c.motion.keyframe_distance_m)
      .field("keyframe_angle_deg", &c.motion.keyframe_angle_deg)
      .field("sway_lateral_m", &c.motion.sway_lateral_m)
      .field("sway_vertical_m", &c.motion.sway_vertical_m)
      .field("step_frequency_hz", &c.motion.step_frequency_hz)
      .field("calibration_turns", &c.motion.calibration_turns)
      .rejectUnknownKeys();
  Section odometry = top.section("odometry");
  odometry.field("scale_error_max", &c.odometry.scale_error_max)
      .field("translation_noise_m_per_sqrt_m", &c.odometry.translation_noise_m_per_sqrt_m)
      .field("yaw_noise_deg_per_sqrt_m", &c.odometry.yaw_noise_deg_per_sqrt_m)
      .field("yaw_bias_deg_per_100m_max", &c.odometry.yaw_bias_deg_per_100m_max)
      .field("attitude_error_min_deg", &c.odometry.attitude_error_min_deg)
      .field("attitude_error_max_deg", &c.odometry.attitude_error_max_deg)
      .field("attitude_error_time_constant_s", &c.odometry.attitude_error_time_constant_s)
      .field("degenerate_scale_error_max", &c.odometry.degenerate_scale_error_max)
      .field("degenerate_noise_m_per_sqrt_m", &c.odometry.degenerate_noise_m_per_sqrt_m)
      .field("pose_rate_hz", &c.odometry.pose_rate_hz)
      .rejectUnknownKeys();
  Section layout = top.section("layout");
  layout.field("mode", &c.layout.mode)
      .field("route_length_m", &c.layout.route_length_m)
      .field("start_offset_x_m", &c.layout.start_offset_x_m)
      .field("start_yaw_step_deg", &c.layout.start_yaw_step_deg)
      .field("window_spacing_m", &c.layout.window_spacing_m)
      .field("window_length_m", &c.layout.window_length_m)
      .field("disjoint_session", &c.layout.disjoint_session)
      .rejectUnknownKeys();
  top.rejectUnknownKeys();

  std::string problem;
  if (!c.IsValid(&problem)) throw InputError(file, 0, problem);
  return c;
}

MagneticMatcherConfig loadMatcherConfig(const std::filesystem::path& path,
                                        MagneticMatcherConfig c) {
  const std::string file = path.string();
  const YAML::Node root = loadYaml(file);
  if (root.IsNull()) return c;
  Section top(root, "", file);
  CalibrationConfig& cal = c.calibration;
  top.section("calibration")
      .field("enabled", &cal.enabled)
      .field("sample_spacing_m", &cal.sample_spacing_m)
      .field("sample_turn_deg", &cal.sample_turn_deg)
      .field("noise_uT", &cal.noise_uT)
      .field("pair_radius_m", &cal.pair_radius_m)
      .field("min_pair_heading_deg", &cal.min_pair_heading_deg)
      .field("min_pair_separation_s", &cal.min_pair_separation_s)
      .field("max_pairs_per_reading", &cal.max_pairs_per_reading)
      .field("hard_iron_prior_uT", &cal.hard_iron_prior_uT)
      .field("soft_iron_prior", &cal.soft_iron_prior)
      .field("speed_prior_uT_per_mps", &cal.speed_prior_uT_per_mps)
      .field("estimate_speed_term", &cal.estimate_speed_term)
      .field("min_speed_spread_mps", &cal.min_speed_spread_mps)
      .field("min_tilt_deg", &cal.min_tilt_deg)
      .field("min_readings", &cal.min_readings)
      .field("max_heading_resultant", &cal.max_heading_resultant)
      .field("robust_iterations", &cal.robust_iterations)
      .rejectUnknownKeys();
  Section map = top.section("map");
  map.field("cell_size_m", &c.map.cell_size_m)
      .field("max_triangle_side_m", &c.map.max_triangle_side_m)
      .field("single_sensor_footprint_m", &c.map.single_sensor_footprint_m)
      .field("max_sensor_gap_m", &c.map.max_sensor_gap_m);
  readEnum(map, "single_sensor_interpolation", &c.map.single_sensor_interpolation,
           {{"footprint", SingleSensorInterpolation::kFootprint},
            {"gaussian_process", SingleSensorInterpolation::kGaussianProcess}},
           file);
  GaussianProcessMapConfig& gp = c.map.gaussian_process;
  map.section("gaussian_process")
      .field("length_scale_m", &gp.length_scale_m)
      .field("noise_ratio", &gp.noise_ratio)
      .field("max_std_ratio", &gp.max_std_ratio)
      .field("tile_size_m", &gp.tile_size_m)
      .field("sample_spacing_m", &gp.sample_spacing_m)
      .field("max_samples_per_tile", &gp.max_samples_per_tile)
      .rejectUnknownKeys();
  map.rejectUnknownKeys();
  Section global = top.section("global");
  readEnum(global, "method", &c.global,
           {{"correlation", GlobalSearchMethod::kCorrelation},
            {"paper_pso", GlobalSearchMethod::kPaperPso}},
           file);
  global.field("coarse_cell_size_m", &c.coarse_cell_size_m)
      .field("yaw_step_deg", &c.search.yaw_step_deg)
      .field("min_overlap_m2", &c.search.min_overlap_m2)
      .field("max_modes", &c.search.max_modes)
      .field("credible_r", &c.search.credible_r)
      .field("mode_separation_m", &c.search.mode_separation_m)
      .field("mode_separation_deg", &c.search.mode_separation_deg)
      .field("use_compass_prior", &c.use_compass_prior)
      .field("compass_window_deg", &c.compass_window_deg)
      .rejectUnknownKeys();
  Section score = top.section("score");
  readEnum(score, "kind", &c.score.kind,
           {{"correlation", MatchScoreKind::kCorrelation},
            {"paper_fitness", MatchScoreKind::kPaperFitness},
            {"paper_likelihood", MatchScoreKind::kPaperLikelihood}},
           file);
  readEnum(score, "channels", &c.score.channels,
           {{"levelled", MatchChannels::kLevelled},
            {"rotated_vector", MatchChannels::kRotatedVector},
            {"vertical_total", MatchChannels::kVerticalTotal},
            {"vertical", MatchChannels::kVertical}},
           file);
  readEnum(score, "statistic", &c.score.statistic,
           {{"pearson", CorrelationStatistic::kPearson},
            {"concordance", CorrelationStatistic::kConcordance}},
           file);
  score.field("min_overlap_m2", &c.score.min_overlap_m2)
      .field("stride", &c.score.stride)
      .field("association_tolerance_uT", &c.score.association_tolerance_uT)
      .field("sigma_B_uT", &c.score.sigma_B_uT)
      .rejectUnknownKeys();
  Section refine = top.section("refinement");
  readEnum(refine, "method", &c.refinement,
           {{"pso", RefinementMethod::kPso},
            {"local_grid", RefinementMethod::kLocalGrid},
            {"none", RefinementMethod::kNone}},
           file);
  refine.field("modes", &c.refine_modes)
      .field("window_m", &c.refine_window_m)
      .field("window_deg", &c.refine_window_deg)
      .field("grid_step_m", &c.grid_step_m)
      .field("grid_step_deg", &c.grid_step_deg)
      .rejectUnknownKeys();
  for (auto [key, pso] : {std::pair{"pso", &c.pso}, std::pair{"paper_pso", &c.paper_pso}}) {
    Section s = top.section(key);
    s.field("particles", &pso->particles)
        .field("iterations", &pso->iterations)
        .field("inertia", &pso->inertia)
        .field("cognitive", &pso->cognitive)
        .field("social", &pso->social)
        .field("max_velocity_fraction", &pso->max_velocity_fraction)
        .field("tolerance", &pso->tolerance)
        .field("stall_iterations", &pso->stall_iterations)
        .field("seed", &pso->seed)
        .rejectUnknownKeys();
  }
  Section confidence = top.section("confidence");
  confidence.field("min_z", &c.min_z)
      .field("min_r", &c.min_r)
      .field("max_second_ratio", &c.max_second_ratio)
      .field("credible_r_gap", &c.credible_r_gap)
      .field("max_yaw_uncertainty_deg", &c.max_yaw_uncertainty_deg)
      .field("yaw_uncertainty_range_deg", &c.yaw_uncertainty_range_deg)
      .field("yaw_uncertainty_step_deg", &c.yaw_uncertainty_step_deg)
      .rejectUnknownKeys();
  MagneticMatcherConfig::SingleTrack& st = c.single_track;
  top.section("single_track")
      .field("coarse_cell_size_m", &st.coarse_cell_size_m)
      .field("min_overlap_m2", &st.min_overlap_m2)
      .field("stride", &st.stride)
      .field("mode_separation_m", &st.mode_separation_m)
      .field("refine_window_m", &st.refine_window_m)
      .field("refine_window_deg", &st.refine_window_deg)
      .field("min_z", &st.min_z)
      .field("min_r", &st.min_r)
      .rejectUnknownKeys();
  top.rejectUnknownKeys();
  std::string problem;
  if (!c.IsValid(&problem)) throw InputError(file, 0, problem);
  return c;
}

}  // namespace mm4mm
