#include "mm4mm/io/change_truth_io.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <string>

#include "mm4mm/io/magnetic_map_io.hpp"
#include "text_io.hpp"

namespace mm4mm {

MagneticMap changeTruthMap(const sim::ChangeTruth& truth) {
  MagneticMap map;
  map.origin_m = truth.origin_m;
  map.cell_size_m = truth.cell_m;
  map.width = truth.width;
  map.height = truth.height;
  map.height_m = truth.height_m;
  map.horizontal_uT = truth.delta_h_uT;
  map.vertical_uT = truth.delta_v_uT;
  map.session_x_uT = truth.delta_x_uT;
  map.session_y_uT = truth.delta_y_uT;
  map.total_uT.resize(truth.delta_h_uT.size());
  for (std::size_t i = 0; i < map.total_uT.size(); ++i)
    map.total_uT[i] = static_cast<float>(std::hypot(truth.delta_h_uT[i], truth.delta_v_uT[i]));
  return map;
}

void writeChangeTruth(const std::filesystem::path& dir, const sim::ChangeConfig& change,
                      const sim::World& world, const sim::ChangeTruth& truth) {
  const std::string truth_file = "change_truth.pcd";
  writeMagneticMapPcd(dir / truth_file, changeTruthMap(truth));
  YAML::Emitter out;
  out.SetDoublePrecision(12);  // 9.9, not 9.9000000000000004
  out.SetFloatPrecision(7);
  out << YAML::Comment("mm4mm simulate: the change between sessions and its ground truth")
      << YAML::Newline;
  out << YAML::BeginMap;
  out << YAML::Key << "first_session" << YAML::Value << change.first_session;
  const auto boxes = [&](const char* key, const std::vector<std::vector<double>>& list) {
    out << YAML::Key << key << YAML::Value << YAML::BeginSeq;
    for (const auto& box : list) {
      const sim::BoxContents contents = sim::boxContents(world, sim::changeBox(box));
      out << YAML::BeginMap << YAML::Key << "box_m" << YAML::Value << YAML::Flow << box << YAML::Key
          << "dipoles" << YAML::Value << contents.dipoles << YAML::Key << "solids" << YAML::Value
          << contents.solids << YAML::EndMap;
    }
    out << YAML::EndSeq;
  };
  boxes("removed", change.removed_m);
  boxes("added", change.added_m);
  out << YAML::Key << "truth" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "file" << YAML::Value << truth_file;
  out << YAML::Key << "height_m" << YAML::Value << truth.height_m;
  out << YAML::Key << "cell_m" << YAML::Value << truth.cell_m;
  out << YAML::Key << "threshold_uT" << YAML::Value << change.truth_threshold_uT;
  out << YAML::Key << "changed_area_m2" << YAML::Value << truth.changed_area_m2;
  out << YAML::Key << "largest_uT" << YAML::Value << truth.largest_uT;
  out << YAML::EndMap << YAML::EndMap;
  io_detail::writeFileAtomically(dir / "change.yaml", std::string(out.c_str()) + "\n");
}

}  // namespace mm4mm
