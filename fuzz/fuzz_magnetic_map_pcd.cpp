// magnetic_map.pcd and changes/magnetic_change.pcd: grids as PCDs with their own fields, one
// grid comment.
#include "fuzz_input.hpp"
#include "mm4mm/io/magnetic_map_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto file = mm4mm::fuzz::scratchDirectory() / "magnetic_map.pcd";
  mm4mm::fuzz::writeInput(file, data, size);
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readMagneticMapPcd(file); });
  mm4mm::fuzz::expectReadOrRefusal([&] { mm4mm::readChangeMapPcd(file); });
  return 0;
}
