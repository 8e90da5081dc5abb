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
  for (std::size_t i = 0; i < magnetometers.size(); ++i) {
    const std::string key = "magnetometers[" + std::to_string(i) + "]";
    session->rig.magnetometers_body.push_back(reader.vector<3>(magnetometers[i], key, "[x, y, z]"));
  }
  session->rig.T_body_lidar = readLidarPose(root["lidar"], reader);
}

std::string formatSessionYaml(const Session& session) {
  const auto list = [](YAML::Emitter& out, std::initializer_list<double> values) {
    // Shortest round-trip text; yaml-cpp would print 0.3 as 0.29999999999999999.
    out << YAML::Flow << YAML::BeginSeq;
    for (double value : values) out << formatNumber(value);
    out << YAML::EndSeq;
  };
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "id" << YAML::Value << session.id;
  out << YAML::Key << "magnetometers" << YAML::Value << YAML::BeginSeq;
  for (const Eigen::Vector3d& p : session.rig.magnetometers_body) list(out, {p.x(), p.y(), p.z()});
  out << YAML::EndSeq;
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
