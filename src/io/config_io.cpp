#include "mm4mm/io/config_io.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "config_fields.hpp"
#include "mm4mm/io/input_error.hpp"
#include "text_io.hpp"

namespace mm4mm {
namespace {

// Reads the keys of one YAML map into fields, remembering which keys it knew so that the rest
// can be reported as unknown.
class Section {
 public:
  Section(const YAML::Node& node, std::string path, std::string file)
      : node_(node), path_(std::move(path)), file_(std::move(file)) {
    if (node_ && !node_.IsMap())
      throw error(node_, (path_.empty() ? std::string("the top level") : "'" + path_ + "'") +
                             " must be a map");
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

  // An enumeration, written by its name.
  template <typename Enum>
  Section& enumField(const char* key, Enum* value, const io_detail::EnumNames<Enum>& names) {
    known_.insert(key);
    const YAML::Node child = node_ ? node_[key] : node_;
    if (!child) return *this;
    std::string name;
    try {
      name = child.as<std::string>();
    } catch (const YAML::Exception&) {
      name = "?";
    }
    for (const auto& [n, v] : names)
      if (n == name && child.IsScalar()) {
        *value = v;
        return *this;
      }
    std::string allowed;
    for (const auto& entry : names)
      allowed += (allowed.empty() ? "" : ", ") + std::string(entry.first);
    throw error(child,
                "'" + qualified(key) + "' must be one of " + allowed + ", got '" + name + "'");
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

template <typename T>
struct IsVector : std::false_type {};
template <typename T>
struct IsVector<std::vector<T>> : std::true_type {};
// Config structs are the class types that are neither lists nor strings.
template <typename T>
constexpr bool kIsStruct =
    std::is_class_v<T> && !IsVector<T>::value && !std::is_same_v<T, std::string>;

// Reads a struct's fields (config_fields.hpp) from its YAML map, and refuses keys it has not.
class StructReader {
 public:
  explicit StructReader(Section section) : section_(std::move(section)) {}

  template <typename T>
  void field(const char* key, T& value) {
    if constexpr (std::is_enum_v<T>) {
      section_.enumField(key, &value, io_detail::enumNames(T{}));
    } else if constexpr (kIsStruct<T>) {
      StructReader child(section_.section(key));
      io_detail::visitFields(child, value);
      child.section_.rejectUnknownKeys();
    } else {
      section_.field(key, &value);
    }
  }

  Section& section() { return section_; }

 private:
  Section section_;
};

// YAML has its own words for the non-finite numbers; every finite one is written so that it
// reads back to the same double.
std::string numberYaml(double value) {
  if (std::isnan(value)) return ".nan";
  if (std::isinf(value)) return value > 0 ? ".inf" : "-.inf";
  std::string text = io_detail::formatNumber(value);
  // "3.0", not "3": a reader of the file sees that the setting is not a count.
  if (text.find_first_of(".e") == std::string::npos) text += ".0";
  return text;
}

// Writes a struct's fields (config_fields.hpp) as a YAML map.
class StructWriter {
 public:
  explicit StructWriter(YAML::Emitter& out) : out_(out) {}

  template <typename T>
  void field(const char* key, T& value) {
    out_ << YAML::Key << key << YAML::Value;
    if constexpr (std::is_enum_v<T>) {
      for (const auto& [name, v] : io_detail::enumNames(T{}))
        if (v == value) out_ << name;
    } else if constexpr (kIsStruct<T>) {
      out_ << YAML::BeginMap;
      io_detail::visitFields(*this, value);
      out_ << YAML::EndMap;
    } else if constexpr (IsVector<T>::value) {
      out_ << YAML::Flow << YAML::BeginSeq;
      for (const double v : value) out_ << numberYaml(v);
      out_ << YAML::EndSeq;
    } else if constexpr (std::is_floating_point_v<T>) {
      out_ << numberYaml(value);
    } else {
      out_ << value;
    }
  }

 private:
  YAML::Emitter& out_;
};

// Keys of the matcher-only files of before (configs/matcher.yaml), which now live under
// merge.matcher with other names: said as such rather than as a typo.
const std::set<std::string> kOldMatcherKeys{"calibration", "map",        "global",
                                            "score",       "refinement", "pso",
                                            "paper_pso",   "confidence", "single_track"};

// The line of the key a validation message starts with ("merge.matcher.pso.particles must
// ..."), or of the deepest of its parents the file has; 0 when it has none.
int lineOfKeyIn(const YAML::Node& root, const std::string& message) {
  const std::string path = message.substr(0, message.find(' '));
  int line = 0;
  YAML::Node node = root;
  std::size_t begin = 0;
  while (begin <= path.size() && node.IsMap()) {
    const std::size_t end = std::min(path.find('.', begin), path.size());
    const std::string key = path.substr(begin, end - begin);
    // The key's own line: a map's value starts on the line after it.
    const auto entry = std::find_if(node.begin(), node.end(), [&](const auto& e) {
      return e.first.IsScalar() && e.first.Scalar() == key;
    });
    if (entry == node.end()) break;
    line = entry->first.Mark().line + 1;
    node = entry->second;
    begin = end + 1;
  }
  return line;
}

PipelineConfig readPipelineConfigNode(const YAML::Node& root, const std::string& file,
                                      PipelineConfig config, PipelineConfigCheck check) {
  if (!root.IsNull()) {
    if (root.IsMap())
      for (const auto& entry : root)
        if (entry.first.IsScalar() && kOldMatcherKeys.count(entry.first.Scalar()))
          throw InputError(
              file, entry.first.Mark().line + 1,
              "unknown key '" + entry.first.Scalar() +
                  "': a matcher file of the old format? Settings mirror PipelineConfig now, the "
                  "matcher's under merge.matcher (configs/mm4mm.yaml; `mm4mm config --dump` "
                  "prints every key)");
    StructReader top(Section(root, "", file));
    io_detail::visitFields(top, config);
    top.section().rejectUnknownKeys();
  }
  std::string problem;
  if (check && !check(config, &problem))
    throw InputError(file, lineOfKeyIn(root, problem), problem);
  return config;
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
  Section procedural = top.section("procedural");
  procedural.field("building", &c.procedural.building)
      .field("draw_floor_steel", &c.procedural.draw_floor_steel)
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
  Section change = top.section("change");
  change.field("first_session", &c.change.first_session)
      .field("removed_m", &c.change.removed_m)
      .field("added_m", &c.change.added_m)
      .field("truth_cell_m", &c.change.truth_cell_m)
      .field("truth_margin_m", &c.change.truth_margin_m)
      .field("truth_threshold_uT", &c.change.truth_threshold_uT)
      .rejectUnknownKeys();
  top.rejectUnknownKeys();

  std::string problem;
  if (!c.IsValid(&problem)) throw InputError(file, 0, problem);
  return c;
}

PipelineConfig readPipelineConfig(const std::filesystem::path& path, const PipelineConfig& base,
                                  PipelineConfigCheck check) {
  const std::string file = path.string();
  return readPipelineConfigNode(loadYaml(file), file, base, check);
}

PipelineConfig parsePipelineConfig(const std::string& text, const std::string& file,
                                   const PipelineConfig& base, PipelineConfigCheck check) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.line + 1, "not valid YAML: " + e.msg);
  }
  return readPipelineConfigNode(root, file, base, check);
}

std::string pipelineConfigYaml(const PipelineConfig& config) {
  PipelineConfig copy = config;  // the visitor reads and writes through one field list
  YAML::Emitter out;
  out << YAML::Comment(
             "mm4mm config (docs/design.md \"Configuration\"): every setting of merge and add")
      << YAML::Newline;
  out << YAML::BeginMap;
  StructWriter writer(out);
  io_detail::visitFields(writer, copy);
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace mm4mm
