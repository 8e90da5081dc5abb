// A building changed between sessions (issue 18): what a change's boxes take out of each state of
// the world, what that does to the field and to the LiDAR, and the ground truth written for it.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "mm4mm/io/change_truth_io.hpp"
#include "mm4mm/io/config_io.hpp"
#include "mm4mm/io/input_error.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"
#include "mm4mm/sim/simulator.hpp"
#include "mm4mm/sim/world_change.hpp"
#include "test_support.hpp"

namespace mm4mm::sim {
namespace {

// The default warehouse's middle double row of shelves in its first block (rows start at
// y = 10.7 m and repeat every 6.4 m, the block runs from x = 10 m to 39.7 m, the row is 2.4 m
// deep): uprights, beams, boards and goods, no pillar.
const std::vector<double> kMiddleRow{9.9, 36.2, 39.8, 38.8};

SimulationConfig changedWarehouse() {
  SimulationConfig config;
  config.change.first_session = 1;
  config.change.removed_m = {kMiddleRow};
  return config;
}

TEST(SimChange, ABoxTakesItsSteelAndSolidsOutOfOneStateOnly) {
  const SimulationConfig config = changedWarehouse();
  const ChangingWorld worlds(config, 7);
  ASSERT_TRUE(worlds.changes());
  const World& whole = worlds.whole().world;
  const BoxContents held = boxContents(whole, changeBox(kMiddleRow));
  // 24 uprights of 13 dipoles each, 16 beams' dipoles, 2 x 11 bays of 4 boards and 4 goods.
  EXPECT_GT(held.dipoles, 300);
  EXPECT_EQ(held.solids, 2 * 12 * 2 + 2 * 11 * 4 * 2);
  // Removed: standing before, gone after.
  EXPECT_EQ(worlds.before().world.dipoles.size(), whole.dipoles.size());
  EXPECT_EQ(worlds.before().world.solids.size(), whole.solids.size());
  EXPECT_EQ(worlds.after().world.dipoles.size(), whole.dipoles.size() - held.dipoles);
  EXPECT_EQ(worlds.after().world.solids.size(), whole.solids.size() - held.solids);
  EXPECT_EQ(&worlds.forSession(0), &worlds.before());
  EXPECT_EQ(&worlds.forSession(1), &worlds.after());
  EXPECT_EQ(&worlds.forSession(5), &worlds.after());

  // In the aisle beside the row the field changes by several µT; 35 m away, beyond every
  // dipole's cutoff (25 m), not at all.
  const Eigen::Vector3d beside(25.0, 35.0, 0.3), far(75.0, 12.0, 0.3);
  EXPECT_GT((worlds.after().field.fieldAt(beside) - worlds.before().field.fieldAt(beside)).norm(),
            3.0);
  EXPECT_EQ(worlds.after().field.fieldAt(far), worlds.before().field.fieldAt(far));
  // Same background, same floor: the whole world's field is the field before.
  EXPECT_EQ(worlds.whole().field.fieldAt(beside), worlds.before().field.fieldAt(beside));

  // A LiDAR ray across the aisle stops at the row before the change, at the next row after it.
  const Eigen::Vector3d origin(25.0, 34.0, 1.0), north(0.0, 1.0, 0.0);
  const auto before = worlds.before().raycaster.cast(origin, north, 30.0);
  const auto after = worlds.after().raycaster.cast(origin, north, 30.0);
  ASSERT_TRUE(before && after);
  EXPECT_NEAR(*before, 36.3 - 34.0, 0.15);
  EXPECT_NEAR(*after, 36.3 + 6.4 - 34.0, 0.15);
}

TEST(SimChange, WithoutAChangeEverySessionSeesTheWholeWorld) {
  const ChangingWorld worlds(SimulationConfig{}, 7);
  EXPECT_FALSE(worlds.changes());
  EXPECT_EQ(&worlds.forSession(3), &worlds.whole());
  // An added box: absent before the change, standing after it.
  SimulationConfig config;
  config.change.first_session = 2;
  config.change.added_m = {kMiddleRow};
  const ChangingWorld added(config, 7);
  const BoxContents held = boxContents(added.whole().world, changeBox(kMiddleRow));
  EXPECT_EQ(added.before().world.solids.size(), added.whole().world.solids.size() - held.solids);
  EXPECT_EQ(added.after().world.solids.size(), added.whole().world.solids.size());
  EXPECT_EQ(&added.forSession(1), &added.before());
  EXPECT_EQ(&added.forSession(2), &added.after());
}

TEST(SimChange, TheTruthIsTheFieldAfterLessTheFieldBefore) {
  const SimulationConfig config = changedWarehouse();
  const ChangingWorld worlds(config, 7);
  const double height = config.rig.magnetometer_height_m;
  const ChangeTruth truth =
      changeTruth(worlds.before().field, worlds.after().field, config.change, height);
  // The box dilated by 10 m on 0.25 m cells.
  EXPECT_EQ(truth.width, static_cast<int>(std::ceil((29.9 + 20.0) / 0.25)));
  EXPECT_EQ(truth.height, static_cast<int>(std::ceil((2.6 + 20.0) / 0.25)));
  const auto at = [&](int ix, int iy) -> Eigen::Vector2d {
    return truth.origin_m + truth.cell_m * Eigen::Vector2d(ix + 0.5, iy + 0.5);
  };
  // Cell by cell, the two fields' difference (a few cells spread over the grid).
  for (const auto& [ix, iy] : {std::pair{10, 10}, {60, 45}, {100, 50}, {190, 80}}) {
    const Eigen::Vector2d xy = at(ix, iy);
    const Eigen::Vector3d p(xy.x(), xy.y(), height);
    const Eigen::Vector3d b0 = worlds.before().field.fieldAt(p);
    const Eigen::Vector3d b1 = worlds.after().field.fieldAt(p);
    const std::size_t i = static_cast<std::size_t>(iy) * truth.width + ix;
    // Stored as float: to its precision (near a beam the change reaches hundreds of µT).
    const auto close = [](double stored, double exact) {
      return std::abs(stored - exact) <= 1e-6 * std::max(1.0, std::abs(exact));
    };
    EXPECT_TRUE(close(truth.delta_h_uT[i], b1.head<2>().norm() - b0.head<2>().norm()));
    EXPECT_TRUE(close(truth.delta_v_uT[i], b1.z() - b0.z()));
    EXPECT_TRUE(close(truth.delta_x_uT[i], b1.x() - b0.x()));
    EXPECT_TRUE(close(truth.delta_y_uT[i], b1.y() - b0.y()));
  }
  // What changed lies around the row: on most of its own footprint, nowhere 6 m from it.
  int on_row = 0, row_cells = 0, far_changed = 0;
  double area = 0.0;
  const Eigen::AlignedBox2d row = changeBox(kMiddleRow);
  for (int iy = 0; iy < truth.height; ++iy)
    for (int ix = 0; ix < truth.width; ++ix) {
      const std::size_t i = static_cast<std::size_t>(iy) * truth.width + ix;
      const double distance = row.exteriorDistance(at(ix, iy));
      if (distance == 0.0) ++row_cells, on_row += truth.changed[i] ? 1 : 0;
      if (distance > 6.0 && truth.changed[i]) ++far_changed;
      area += truth.changed[i] ? 0.0625 : 0.0;
      EXPECT_EQ(truth.changed[i], std::hypot(truth.delta_h_uT[i], truth.delta_v_uT[i]) >= 1.0);
    }
  EXPECT_GT(on_row, 0.9 * row_cells);
  EXPECT_EQ(far_changed, 0);
  EXPECT_DOUBLE_EQ(truth.changed_area_m2, area);
  EXPECT_GT(truth.changed_area_m2, row.volume());
  EXPECT_GT(truth.largest_uT, 5.0);
}

TEST(SimChange, TheTruthIsWrittenAndReadsBackCellForCell) {
  const SimulationConfig config = changedWarehouse();
  const ChangingWorld worlds(config, 7);
  const ChangeTruth truth = changeTruth(worlds.before().field, worlds.after().field, config.change,
                                        config.rig.magnetometer_height_m);
  const test::TempDir dir("sim_change_truth");
  writeChangeTruth(dir.path(), config.change, worlds.whole().world, truth);
  const MagneticMap written = changeTruthMap(truth);
  const MagneticMap read = readMagneticMapPcd(dir.path() / "change_truth.pcd");
  EXPECT_EQ(read.width, truth.width);
  EXPECT_EQ(read.height, truth.height);
  EXPECT_EQ(read.origin_m, truth.origin_m);
  EXPECT_EQ(read.horizontal_uT, written.horizontal_uT);
  EXPECT_EQ(read.vertical_uT, written.vertical_uT);
  EXPECT_EQ(read.total_uT, written.total_uT);
  EXPECT_EQ(read.session_y_uT, written.session_y_uT);
  const YAML::Node yaml = YAML::LoadFile((dir.path() / "change.yaml").string());
  EXPECT_EQ(yaml["first_session"].as<int>(), 1);
  EXPECT_EQ(yaml["removed"][0]["box_m"].as<std::vector<double>>(), kMiddleRow);
  EXPECT_EQ(yaml["removed"][0]["solids"].as<int>(),
            boxContents(worlds.whole().world, changeBox(kMiddleRow)).solids);
  EXPECT_EQ(yaml["added"].size(), 0u);
  EXPECT_EQ(yaml["truth"]["file"].as<std::string>(), "change_truth.pcd");
  EXPECT_DOUBLE_EQ(yaml["truth"]["changed_area_m2"].as<double>(), truth.changed_area_m2);
}

TEST(SimChange, BadChangesAreRefusedNamingTheSetting) {
  const auto problem = [](const ChangeConfig& change) {
    SimulationConfig config;
    config.change = change;
    std::string error;
    return config.IsValid(&error) ? std::string() : error;
  };
  ChangeConfig change;
  change.first_session = 1;
  EXPECT_NE(problem(change).find("removed_m and added_m are empty"), std::string::npos);
  change.removed_m = {{1.0, 2.0, 3.0}};
  EXPECT_NE(problem(change).find("[x_min, y_min, x_max, y_max]"), std::string::npos);
  change.removed_m = {{5.0, 2.0, 3.0, 4.0}};
  EXPECT_NE(problem(change).find("[x_min, y_min, x_max, y_max]"), std::string::npos);
  change.removed_m = {{1.0, 1.0, 5.0, 5.0}};
  change.added_m = {{4.0, 4.0, 8.0, 8.0}};
  EXPECT_NE(problem(change).find("must not overlap"), std::string::npos);
  change.added_m.clear();
  change.first_session = -1;
  EXPECT_NE(problem(change).find("first_session must be >= 0"), std::string::npos);
  change.first_session = 0;
  EXPECT_NE(problem(change).find("first_session is 0 (no change)"), std::string::npos);
  change.first_session = 1;
  EXPECT_EQ(problem(change), "");

  // A box over an empty stretch of floor changes nothing: refused, naming the box.
  SimulationConfig config;
  config.change.first_session = 1;
  config.change.removed_m = {kMiddleRow};
  config.change.added_m = {{42.0, 3.0, 44.0, 5.0}};  // the perimeter lane, south of the rows
  try {
    const ChangingWorld worlds(config, 7);
    FAIL() << "an empty box was taken";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("change.added_m[0] holds no steel and no solid"),
              std::string::npos)
        << e.what();
  }
}

TEST(SimChange, ThePresetAndAChangeInAConfigFileAreRead) {
  const SimulationConfig preset = loadSimulationConfig(std::filesystem::path(MM4MM_SOURCE_DIR) /
                                                       "configs" / "warehouse_changed.yaml");
  EXPECT_EQ(preset.change.first_session, 2);
  ASSERT_EQ(preset.change.removed_m.size(), 1u);
  EXPECT_EQ(preset.change.removed_m[0], kMiddleRow);
  EXPECT_TRUE(preset.change.added_m.empty());

  const test::TempDir dir("sim_change_config");
  const std::filesystem::path file = dir.path() / "bad.yaml";
  std::ofstream(file) << "change:\n  first_session: 1\n  added_m: [[1, 2, 3]]\n";
  try {
    loadSimulationConfig(file);
    FAIL() << "a box of three numbers was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("change.removed_m and change.added_m entries"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace mm4mm::sim
