// The text readers of `mm4mm import`: the input's first byte picks one (GLIM's submap data.txt,
// hdl_graph_slam's keyframe data, FAST-LIO's pos_log.txt, a KITTI pose file, a magnetometer table,
// an extrinsics YAML), the rest is its file.
#include "fuzz_input.hpp"
#include "mm4mm/import/extrinsics.hpp"
#include "mm4mm/import/fast_lio.hpp"
#include "mm4mm/import/glim_dump.hpp"
#include "mm4mm/import/hdl_graph_slam_dump.hpp"
#include "mm4mm/import/kitti_odometry.hpp"
#include "mm4mm/import/magnetometer_table.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace fs = std::filesystem;
  if (size == 0) return 0;
  const fs::path dir = mm4mm::fuzz::scratchDirectory() / "import";
  fs::remove_all(dir);
  fs::create_directories(dir / "000000");
  const std::uint8_t choice = data[0] % 6;
  ++data;
  --size;
  using mm4mm::fuzz::expectReadOrRefusal;
  using mm4mm::fuzz::writeInput;
  switch (choice) {
    case 0:
      writeInput(dir / "000000" / "data.txt", data, size);
      expectReadOrRefusal([&] { mm4mm::readGlimDump(dir); });
      break;
    case 1:
      writeInput(dir / "graph.g2o", data, 0);
      writeInput(dir / "000000" / "data", data, size);
      expectReadOrRefusal([&] { mm4mm::readHdlGraphSlamDump(dir); });
      break;
    case 2:
      writeInput(dir / "pos_log.txt", data, size);
      expectReadOrRefusal([&] { mm4mm::readFastLioPcdSave(dir, dir / "pos_log.txt", 2, 0.0); });
      break;
    case 3:
      writeInput(dir / "poses.txt", data, size);
      expectReadOrRefusal([&] { mm4mm::readKittiPoses(dir / "poses.txt"); });
      break;
    case 4: {
      writeInput(dir / "mag.csv", data, size);
      mm4mm::MagnetometerTableOptions options;
      expectReadOrRefusal([&] { mm4mm::readMagnetometerTable(dir / "mag.csv", options); });
      break;
    }
    default:
      writeInput(dir / "rig.yaml", data, size);
      expectReadOrRefusal([&] { mm4mm::readExtrinsicsYaml(dir / "rig.yaml"); });
  }
  return 0;
}
