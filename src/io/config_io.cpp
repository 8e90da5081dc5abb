#include "mm4mm/io/config_io.hpp"

#include <yaml-cpp/yaml.h>

#include <set>
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
    return Section(node_ ? node_[key] : YAML::Node(), qualified(key), file_);
  }

  void rejectUnknownKeys() const {
    if (!node_) return;
    for (const auto& entry : node_) {
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

}  // namespace

sim::SimulationConfig loadSimulationConfig(const std::filesystem::path& path,
                                           sim::SimulationConfig c) {
  const std::string file = path.string();
  if (!std::filesystem::is_regular_file(path)) throw InputError(file, 0, "no such config file");
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.line + 1, "not valid YAML: " + e.msg);
  }
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
      .field("floor_rebar_spacing_m", &c.steel.floor_rebar_spacing_m)
      .field("floor_rebar_depth_m", &c.steel.floor_rebar_depth_m)
      .field("floor_rebar_moment_Am2", &c.steel.floor_rebar_moment_Am2)
      .field("moment_jitter", &c.steel.moment_jitter)
      .field("cutoff_radius_m", &c.steel.cutoff_radius_m)
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
  rig.field("magnetometer_count", &c.rig.magnetometer_count)
      .field("magnetometer_spacing_m", &c.rig.magnetometer_spacing_m)
      .field("magnetometer_height_m", &c.rig.magnetometer_height_m)
      .field("magnetometer_rate_hz", &c.rig.magnetometer_rate_hz)
      .field("magnetometer_noise_uT", &c.rig.magnetometer_noise_uT)
      .field("magnetometer_bias_uT", &c.rig.magnetometer_bias_uT)
      .field("lidar_height_m", &c.rig.lidar_height_m)
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
      .rejectUnknownKeys();
  Section odometry = top.section("odometry");
  odometry.field("scale_error_max", &c.odometry.scale_error_max)
      .field("translation_noise_m_per_sqrt_m", &c.odometry.translation_noise_m_per_sqrt_m)
      .field("yaw_noise_deg_per_sqrt_m", &c.odometry.yaw_noise_deg_per_sqrt_m)
      .field("yaw_bias_deg_per_100m_max", &c.odometry.yaw_bias_deg_per_100m_max)
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

}  // namespace mm4mm
