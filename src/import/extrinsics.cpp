#include "mm4mm/import/extrinsics.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>

#include "../io/text_io.hpp"
#include "import_text.hpp"
#include "mm4mm/io/input_error.hpp"

namespace mm4mm {
namespace {

int lineOf(const YAML::Node& node) { return node.Mark().line + 1; }

// A complex key ("[0, 0, 1]: x" or "? {a: 1}") is valid YAML but names nothing here; as<string>()
// would throw yaml-cpp's own exception instead of an error with the file (found by fuzz_import).
std::string keyOf(const YAML::Node& key, const std::string& where, const std::string& file) {
  if (!key.IsScalar()) throw InputError(file, lineOf(key), where + " has a key that is not a name");
  return key.as<std::string>();
}

Eigen::VectorXd numbers(const YAML::Node& node, int count, const std::string& what,
                        const std::string& file) {
  if (!node.IsSequence() || static_cast<int>(node.size()) != count)
    throw InputError(file, lineOf(node),
                     what + " must be a list of " + std::to_string(count) + " numbers");
  Eigen::VectorXd v(count);
  for (int i = 0; i < count; ++i) {
    try {
      v[i] = node[i].as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(file, lineOf(node[i]), what + " holds a value that is not a number");
    }
    if (!std::isfinite(v[i])) throw InputError(file, lineOf(node[i]), what + " is not finite");
  }
  return v;
}

Eigen::Isometry3d transformOf(const YAML::Node& node, const std::string& key,
                              const std::string& file) {
  if (!node.IsMap()) throw InputError(file, lineOf(node), key + " must be a map");
  for (const auto& entry : node) {
    const std::string name = keyOf(entry.first, key, file);
    if (name != "translation" && name != "quaternion")
      throw InputError(file, lineOf(entry.first),
                       "unknown key '" + key + "." + name + "' (translation, quaternion)");
  }
  const Eigen::Vector3d t =
      node["translation"]
          ? Eigen::Vector3d(numbers(node["translation"], 3, key + ".translation", file))
          : Eigen::Vector3d::Zero();
  Eigen::Vector4d q(0, 0, 0, 1);
  if (node["quaternion"]) {
    q = numbers(node["quaternion"], 4, key + ".quaternion (x y z w)", file);
    if (std::abs(q.norm() - 1.0) > 1e-3)
      throw InputError(file, lineOf(node["quaternion"]),
                       key + ".quaternion's norm is " + std::to_string(q.norm()) + ", not 1");
  }
  return import_detail::poseFromTq(t, q);
}

}  // namespace

Extrinsics readExtrinsicsYaml(const std::filesystem::path& path) {
  const std::string file = path.string();
  const std::string content = io_detail::readWholeFile(path);
  YAML::Node root;
  try {
    root = YAML::Load(content);
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.line + 1, "not valid YAML: " + e.msg);
  }
  Extrinsics extrinsics;
  if (root.IsNull()) return extrinsics;
  if (!root.IsMap())
    throw InputError(file, 1, "must be a map of T_body_magnetometer, T_body_lidar");
  for (const auto& entry : root) {
    const std::string key = keyOf(entry.first, "the top level", file);
    if (key == "T_body_magnetometer")
      extrinsics.T_body_magnetometer = transformOf(entry.second, key, file);
    else if (key == "T_body_lidar")
      extrinsics.T_body_lidar = transformOf(entry.second, key, file);
    else
      throw InputError(file, lineOf(entry.first),
                       "unknown key '" + key + "' (T_body_magnetometer, T_body_lidar)");
  }
  return extrinsics;
}

}  // namespace mm4mm
