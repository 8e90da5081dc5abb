#include "session_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <initializer_list>
#include <string>

#include "mm4mm/io/input_error.hpp"
#include "text_io.hpp"

namespace mm4mm::io_detail {

namespace fs = std::filesystem;

namespace {

constexpr double kQuaternionNormTolerance = 1e-3;

class YamlReader {
 public:
  explicit YamlReader(const fs::path& file) : file_(file.string()) {}

  YAML::Node load() const {
    const std::string content =
        readWholeFile(file_, "every session needs its id and magnetometer positions there");
    try {
      return YAML::Load(content);
    } catch (const YAML::Exception& e) {
      throw InputError(file_, e.mark.is_null() ? 0 : e.mark.line + 1, e.msg);
    }
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& problem) const {
    const YAML::Mark mark = at.Mark();
    throw InputError(file_, mark.is_null() ? 0 : mark.line + 1, problem);
  }

  YAML::Node required(const YAML::Node& root, const char* key) const {
    const YAML::Node node = root[key];
    if (!node) throw InputError(file_, 0, std::string("missing required key '") + key + "'");
    return node;
  }

  Eigen::Matrix3d matrix(const YAML::Node& node, const std::string& key) const {
    const std::string expected = "'" + key + "' must be a 3x3 matrix [[..], [..], [..]]";
    if (!node.IsSequence() || node.size() != 3) fail(node, expected);
    Eigen::Matrix3d m;
    for (int r = 0; r < 3; ++r) m.row(r) = vector<3>(node[r], key, "per row").transpose();
    return m;
  }

  /// A calibration from the keys of `node` (absent keys keep the identity's values), checked.
  MagnetometerCalibration calibration(const YAML::Node& node, const std::string& key) const {
    MagnetometerCalibration c;
    if (const YAML::Node h = node["hard_iron_uT"])
      c.hard_iron_uT = vector<3>(h, key + ".hard_iron_uT", "[hx, hy, hz]");
    if (const YAML::Node s = node["soft_iron"]) c.soft_iron = matrix(s, key + ".soft_iron");
    if (const YAML::Node k = node["speed_uT_per_mps"])
      c.speed_uT_per_mps = vector<3>(k, key + ".speed_uT_per_mps", "[kx, ky, kz]");
    std::string problem;
    if (!c.IsValid(&problem)) fail(node, "'" + key + "': " + problem);
    return c;
  }

  /// Refuses keys of map `node` that are not in `known`.
  void onlyKeys(const YAML::Node& node, const std::string& key,
                std::initializer_list<const char*> known) const {
    for (const auto& entry : node) {
      const std::string name = entry.first.IsScalar() ? entry.first.Scalar() : std::string();
      bool ok = false;
      for (const char* k : known) ok = ok || name == k;
      if (!ok) fail(entry.first, "unknown key '" + name + "' in '" + key + "'");
    }
  }

  template <int N>
  Eigen::Matrix<double, N, 1> vector(const YAML::Node& node, const std::string& key,
                                     const char* shape) const {
    const std::string expected =
        "'" + key + "' must be a list of " + std::to_string(N) + " numbers " + shape;
    if (!node.IsSequence() || node.size() != N) fail(node, expected);
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) {
      try {
        v[i] = node[i].as<double>();
      } catch (const YAML::Exception&) {
        fail(node[i], expected);
      }
    }
    if (!v.allFinite()) fail(node, "'" + key + "' is not finite");
    return v;
  }

 private:
  std::string file_;
};

Eigen::Isometry3d readLidarPose(const YAML::Node& lidar, const YamlReader& reader) {
  Eigen::Isometry3d T_body_lidar = Eigen::Isometry3d::Identity();
  if (!lidar) return T_body_lidar;
  if (!lidar.IsMap()) reader.fail(lidar, "'lidar' must be a map with translation and quaternion");
  if (const YAML::Node t = lidar["translation"])
    T_body_lidar.translation() = reader.vector<3>(t, "lidar.translation", "[x, y, z]");
  if (const YAML::Node q_node = lidar["quaternion"]) {
    const Eigen::Vector4d xyzw = reader.vector<4>(q_node, "lidar.quaternion", "[x, y, z, w]");
    if (std::abs(xyzw.norm() - 1.0) > kQuaternionNormTolerance)
      reader.fail(q_node, "'lidar.quaternion' has norm " + formatNumber(xyzw.norm()) + ", not 1");
    const Eigen::Quaterniond q(xyzw[3], xyzw[0], xyzw[1], xyzw[2]);
    T_body_lidar.linear() = q.normalized().toRotationMatrix();
  }
  return T_body_lidar;
}

}  // namespace

bool isValidId(const std::string& id) {
  return !id.empty() && id != "." && id != ".." &&
         id.find_first_of(std::string("/\\\n\r\0", 5)) == std::string::npos;
}

void readSessionYaml(const fs::path& file, Session* session) {
  const YamlReader reader(file);
  const YAML::Node root = reader.load();
  if (!root.IsMap()) {
    throw InputError(file.string(), 0,
                     "must be a YAML map with the keys 'id', 'magnetometers' and 'lidar'");
  }
  const YAML::Node id = reader.required(root, "id");
  if (!id.IsScalar()) reader.fail(id, "'id' must be a string");
  session->id = id.Scalar();
  if (!isValidId(session->id))
    reader.fail(id, "id '" + session->id + "' must be usable as a file name (not empty, no '/')");

  const YAML::Node magnetometers = reader.required(root, "magnetometers");
  if (!magnetometers.IsSequence() || magnetometers.size() == 0)
    reader.fail(magnetometers, "'magnetometers' must be a list of at least one [x, y, z]");
  session->rig.magnetometers_body.clear();
  session->rig.calibrations.clear();
  bool any_calibration = false;
  std::vector<std::optional<MagnetometerCalibration>> calibrations;
  for (std::size_t i = 0; i < magnetometers.size(); ++i) {
    const std::string key = "magnetometers[" + std::to_string(i) + "]";
    const YAML::Node entry = magnetometers[i];
    if (entry.IsMap()) {
      reader.onlyKeys(entry, key, {"position", "hard_iron_uT", "soft_iron", "speed_uT_per_mps"});
      const YAML::Node position = entry["position"];
      if (!position) reader.fail(entry, "'" + key + "' needs a 'position: [x, y, z]'");
      session->rig.magnetometers_body.push_back(
          reader.vector<3>(position, key + ".position", "[x, y, z]"));
      if (entry.size() > 1) {
        calibrations.push_back(reader.calibration(entry, key));
        any_calibration = true;
      } else {
        calibrations.emplace_back();
      }
    } else {
      session->rig.magnetometers_body.push_back(reader.vector<3>(entry, key, "[x, y, z]"));
      calibrations.emplace_back();
    }
  }
  if (any_calibration) session->rig.calibrations = std::move(calibrations);
  session->rig.earth_field_horizontal_uT.reset();
  session->rig.earth_field_vertical_uT.reset();
  if (const YAML::Node earth = root["earth_field"]) {
    if (!earth.IsMap())
      reader.fail(earth, "'earth_field' must be a map {horizontal_uT: H, vertical_uT: Z}");
    reader.onlyKeys(earth, "earth_field", {"horizontal_uT", "vertical_uT"});
    const YAML::Node h = earth["horizontal_uT"], v = earth["vertical_uT"];
    if (!h && !v) reader.fail(earth, "'earth_field' needs 'horizontal_uT' or 'vertical_uT'");
    const auto number = [&](const YAML::Node& node, const char* key) {
      double value = 0.0;
      try {
        value = node.as<double>();
      } catch (const YAML::Exception&) {
        reader.fail(node, std::string("'earth_field.") + key + "' must be a number (µT)");
      }
      return value;
    };
    if (h) {
      const double value = number(h, "horizontal_uT");
      if (!(value > 0.0 && value <= 100.0))
        reader.fail(
            h, "'earth_field.horizontal_uT' must be in (0, 100] µT, got " + formatNumber(value));
      session->rig.earth_field_horizontal_uT = value;
    }
    if (v) {
      // The Earth's field is 25-65 µT in magnitude everywhere; 100 µT is a unit mistake.
      const double value = number(v, "vertical_uT");
      if (!(std::abs(value) <= 100.0))
        reader.fail(v, "'earth_field.vertical_uT' must be in [-100, 100] µT (z up), got " +
                           formatNumber(value));
      session->rig.earth_field_vertical_uT = value;
    }
  }
  session->rig.frame_height_above_floor_m.reset();
  if (const YAML::Node height = root["frame_height_above_floor_m"]) {
    double value = 0.0;
    try {
      value = height.as<double>();
    } catch (const YAML::Exception&) {
      reader.fail(height, "'frame_height_above_floor_m' must be a number (m)");
    }
    // A body's odometry starts on the floor or a few metres above it, not below it.
    if (!(value >= -1.0 && value <= 10.0))
      reader.fail(height,
                  "'frame_height_above_floor_m' must be in [-1, 10] m, got " + formatNumber(value));
    session->rig.frame_height_above_floor_m = value;
  }
  session->rig.T_body_lidar = readLidarPose(root["lidar"], reader);
}

namespace {

void list(YAML::Emitter& out, std::initializer_list<double> values) {
  // Shortest round-trip text; yaml-cpp would print 0.3 as 0.29999999999999999.
  out << YAML::Flow << YAML::BeginSeq;
  for (double value : values) out << formatNumber(value);
  out << YAML::EndSeq;
}

void emitCalibration(YAML::Emitter& out, const MagnetometerCalibration& c) {
  const Eigen::Vector3d& h = c.hard_iron_uT;
  const Eigen::Vector3d& k = c.speed_uT_per_mps;
  out << YAML::Key << "hard_iron_uT" << YAML::Value;
  list(out, {h.x(), h.y(), h.z()});
  out << YAML::Key << "soft_iron" << YAML::Value << YAML::Flow << YAML::BeginSeq;
  for (int r = 0; r < 3; ++r) list(out, {c.soft_iron(r, 0), c.soft_iron(r, 1), c.soft_iron(r, 2)});
  out << YAML::EndSeq;
  out << YAML::Key << "speed_uT_per_mps" << YAML::Value;
  list(out, {k.x(), k.y(), k.z()});
}

}  // namespace

std::vector<MagnetometerCalibration> readTrueCalibration(const fs::path& file,
                                                         std::size_t magnetometers) {
  const YamlReader reader(file);
  const YAML::Node root = reader.load();
  if (!root.IsMap()) throw InputError(file.string(), 0, "must be a map with 'magnetometers'");
  const YAML::Node list_node = reader.required(root, "magnetometers");
  if (!list_node.IsSequence() || list_node.size() != magnetometers)
    reader.fail(list_node, "'magnetometers' must list " + std::to_string(magnetometers) +
                               " calibrations, one per magnetometer of session.yaml");
  std::vector<MagnetometerCalibration> calibrations;
  for (std::size_t i = 0; i < list_node.size(); ++i) {
    const std::string key = "magnetometers[" + std::to_string(i) + "]";
    if (!list_node[i].IsMap()) reader.fail(list_node[i], "'" + key + "' must be a map");
    reader.onlyKeys(list_node[i], key, {"hard_iron_uT", "soft_iron", "speed_uT_per_mps"});
    calibrations.push_back(reader.calibration(list_node[i], key));
  }
  return calibrations;
}

std::string formatTrueCalibration(const std::vector<MagnetometerCalibration>& calibrations) {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "magnetometers" << YAML::Value << YAML::BeginSeq;
  for (const MagnetometerCalibration& c : calibrations) {
    out << YAML::BeginMap;
    emitCalibration(out, c);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return "# The simulator's true calibration of each magnetometer (session.yaml's order): the\n"
         "# reading is m = soft_iron * B + hard_iron_uT + speed * speed_uT_per_mps, plus what\n"
         "# this model leaves out (axis non-orthogonality, acceleration current, drift, noise).\n" +
         std::string(out.c_str()) + "\n";
}

std::string formatSessionYaml(const Session& session) {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "id" << YAML::Value << session.id;
  out << YAML::Key << "magnetometers" << YAML::Value << YAML::BeginSeq;
  const auto& rig = session.rig;
  for (std::size_t i = 0; i < rig.magnetometers_body.size(); ++i) {
    const Eigen::Vector3d& p = rig.magnetometers_body[i];
    if (i < rig.calibrations.size() && rig.calibrations[i]) {
      out << YAML::BeginMap << YAML::Key << "position" << YAML::Value;
      list(out, {p.x(), p.y(), p.z()});
      emitCalibration(out, *rig.calibrations[i]);
      out << YAML::EndMap;
    } else {
      list(out, {p.x(), p.y(), p.z()});
    }
  }
  out << YAML::EndSeq;
  if (rig.earth_field_horizontal_uT || rig.earth_field_vertical_uT) {
    out << YAML::Key << "earth_field" << YAML::Value << YAML::BeginMap;
    if (rig.earth_field_horizontal_uT)
      out << YAML::Key << "horizontal_uT" << YAML::Value
          << formatNumber(*rig.earth_field_horizontal_uT);
    if (rig.earth_field_vertical_uT)
      out << YAML::Key << "vertical_uT" << YAML::Value
          << formatNumber(*rig.earth_field_vertical_uT);
    out << YAML::EndMap;
  }
  if (rig.frame_height_above_floor_m)
    out << YAML::Key << "frame_height_above_floor_m" << YAML::Value
        << formatNumber(*rig.frame_height_above_floor_m);
  const Eigen::Vector3d t = session.rig.T_body_lidar.translation();
  const Eigen::Quaterniond q(session.rig.T_body_lidar.linear());
  out << YAML::Key << "lidar" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "translation" << YAML::Value;
  list(out, {t.x(), t.y(), t.z()});
  out << YAML::Key << "quaternion" << YAML::Value;
  list(out, {q.x(), q.y(), q.z(), q.w()});
  out << YAML::EndMap << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace mm4mm::io_detail
